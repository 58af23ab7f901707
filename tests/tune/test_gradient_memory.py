"""Reverse mode through a streamed objective with `checkpoint="recursive"` needs memory that
does not grow with the horizon; with one checkpoint per save interval it grows.

XLA's static estimate of the compiled gradient's temporary buffers
(`memory_analysis().temp_size_in_bytes`) at 2 s and 8 s of the small problem of
`test_forward_mode.py` (Euler steps of 1e-2 s, saved every 5: 40 and 160 save intervals). The
objective's metric streams, so no trajectory is stored: what remains is the loop states kept
for the backward sweep. Measured when written (float64): `checkpoint=True` 32 968 -> 57 928
bytes (1.76x), `"recursive"` with 4 checkpoints 30 928 -> 31 888 bytes (1.03x; the 960 extra
bytes are the scan's 120 more interval indices).
"""

import jax
import pytest

from jaxatt import tune
from jaxatt.metrics import ConvergenceTime
from jaxatt.simulation import Euler

from .test_forward_mode import PARAMS, _problem


def _gradient_temp_bytes(horizon: float, checkpoint, checkpoints=None) -> int:
    loop, x0s, _, u = _problem()
    times = {"t": ConvergenceTime("attitude_error_vector", 1e-3)}
    objective = tune.MetricObjective(
        horizon,
        1e-2,
        times,
        save_every=5,
        solver=Euler(),
        checkpoint=checkpoint,
        checkpoints=checkpoints,
    )

    def loss(u):
        return objective(tune.apply(loop, PARAMS, u), x0s)[0]

    compiled = jax.jit(jax.value_and_grad(loss)).lower(u).compile()
    return compiled.memory_analysis().temp_size_in_bytes


@pytest.mark.parametrize(
    ("checkpoint", "checkpoints", "low", "high"),
    [(True, None, 1.5, 4.0), ("recursive", 4, 0.95, 1.1)],
)
def test_gradient_memory_against_the_horizon(checkpoint, checkpoints, low, high):
    short = _gradient_temp_bytes(2.0, checkpoint, checkpoints)
    long = _gradient_temp_bytes(8.0, checkpoint, checkpoints)
    assert low <= long / short <= high, (short, long)
