"""Reverse mode through a streamed objective with `checkpoint="recursive"` gives the gradient
of `checkpoint=True` with memory that does not grow with the horizon; with `True` it grows.

XLA's static estimate of the compiled gradient's temporary buffers
(`memory_analysis().temp_size_in_bytes`) at 2 s and 8 s of the small problem of
`test_forward_mode.py` (Euler steps of 1e-2 s, saved every 5: 40 and 160 save intervals). The
objective's metric streams, so no trajectory is stored: what remains is the loop states kept
for the backward sweep. Measured when written (float64): `checkpoint=True` 32 968 -> 57 928
bytes (1.76x), `"recursive"` with 4 checkpoints 30 928 -> 31 888 bytes (1.03x; the 960 extra
bytes are the scan's 120 more interval indices). Four compiled programs, shared by the tests.
"""

import jax
import numpy as np
import pytest

from jaxatt import tune

from .test_forward_mode import PARAMS, _problem


SETTINGS = {"every save": (True, None), "recursive, 4 checkpoints": ("recursive", 4)}
HORIZONS = (2.0, 8.0)


@pytest.fixture(scope="module")
def compiled():
    """(setting, horizon) -> (the compiled `value_and_grad` of the loss, the unconstrained
    gains)."""
    out = {}
    for name, (checkpoint, checkpoints) in SETTINGS.items():
        for horizon in HORIZONS:
            loop, x0s, objective, u = _problem(checkpoint, checkpoints, horizon)

            def loss(u, loop=loop, x0s=x0s, objective=objective):
                return objective(tune.apply(loop, PARAMS, u), x0s)[0]

            out[name, horizon] = jax.jit(jax.value_and_grad(loss)).lower(u).compile()
    return out, u


@pytest.mark.parametrize(
    ("name", "low", "high"), [("every save", 1.5, 4.0), ("recursive, 4 checkpoints", 0.95, 1.1)]
)
def test_gradient_memory_against_the_horizon(compiled, name, low, high):
    programs, _ = compiled
    short, long = (programs[name, h].memory_analysis().temp_size_in_bytes for h in HORIZONS)
    assert low <= long / short <= high, (short, long)


def test_recursive_checkpoints_give_the_same_loss_and_gradient(compiled):
    # 40 save intervals through 4 stored loop states: most intervals are recomputed.
    programs, u = compiled
    loss_r, grad_r = programs["every save", HORIZONS[0]](u)
    loss_c, grad_c = programs["recursive, 4 checkpoints", HORIZONS[0]](u)
    assert float(loss_c) == float(loss_r)  # the same forward computation
    scale = max(abs(float(v)) for v in grad_r.values())
    assert scale > 0 and all(np.isfinite(float(v)) for v in grad_r.values())
    assert max(abs(float(grad_c[k]) - float(grad_r[k])) for k in grad_r) <= 1e-12 * scale
