"""Forward-mode sensitivities give reverse mode's gradient.

One small problem (a rigid body under MRP PD, two gains, 2 s of Euler steps of 1e-2 s, saved
every 5 steps, 3 initial states), compiled two ways: reverse mode with one checkpoint per save
interval (the default) and forward mode (`jax.jacfwd`). Recursive checkpoints:
`test_gradient_memory.py`.
"""

import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt import tune
from jaxatt.controllers import MRPPD
from jaxatt.metrics import ConvergenceTime
from jaxatt.plants import MRPState, RigidBodyMRP
from jaxatt.simulation import ClosedLoop, Euler, Simulation


J = jnp.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])
PARAMS = {
    "k1": tune.Parameter("controller.k1", tune.Positive()),
    "k2": tune.Parameter("controller.k2", tune.Positive()),
}


def _problem(checkpoint=True, checkpoints=None, horizon=2.0):
    loop = ClosedLoop(RigidBodyMRP(J), MRPPD(6.0, 5.0))
    x0s = MRPState(
        jnp.array([[0.1, -0.2, 0.3], [0.3, 0.1, -0.2], [-0.2, 0.2, 0.1]]),
        jnp.array([[0.01, 0.0, -0.02], [0.0, 0.02, 0.0], [0.0, 0.0, 0.0]]),
    )
    # One time metric (the settling objective's convergence time), Euler steps: small programs.
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
    return loop, x0s, objective, tune.initial_unconstrained(loop, PARAMS)


@pytest.fixture(scope="module")
def gradients():
    out = {}
    loop, x0s, objective, u = _problem()
    for mode in ("reverse", "forward"):
        (loss, aux), grads = tune.loss_and_grad(u, loop, PARAMS, objective, x0s, mode=mode)
        out[mode] = (float(loss), {k: float(v) for k, v in grads.items()}, aux)
    return out


def _relative(a: dict, b: dict) -> float:
    scale = max(abs(v) for v in b.values())
    return max(abs(a[k] - b[k]) for k in b) / scale


def test_forward_mode_gives_the_reverse_mode_gradient(gradients):
    loss_r, grad_r, _ = gradients["reverse"]
    loss_f, grad_f, aux_f = gradients["forward"]
    assert loss_f == pytest.approx(loss_r, rel=1e-14)
    assert all(np.isfinite(v) and v != 0 for v in grad_r.values())  # a real gradient
    assert _relative(grad_f, grad_r) <= 1e-8
    assert np.all(np.asarray(aux_f["successful"]))
    assert np.all(np.isfinite(np.asarray(aux_f["t"])))


def test_tune_in_forward_mode_follows_the_reverse_mode_path():
    # Reuses the programs compiled by the fixture (same arguments).
    loop, x0s, objective, _ = _problem()
    runs = {
        mode: tune.tune(loop, PARAMS, objective, x0s, steps=2, progress=False, mode=mode)
        for mode in ("reverse", "forward")
    }
    np.testing.assert_allclose(runs["forward"].losses, runs["reverse"].losses, rtol=1e-12)
    for name in PARAMS:
        np.testing.assert_allclose(
            runs["forward"].gains[name], runs["reverse"].gains[name], rtol=1e-8
        )
    assert runs["forward"].gains["k1"] != pytest.approx(6.0)  # it moved


def test_bad_options():
    for bad in ("treeverse", "nested"):
        with pytest.raises(ValueError, match="`checkpoint` must be True, False or 'recursive'"):
            Simulation(0.0, 1.0, 0.1, checkpoint=bad)
    with pytest.raises(ValueError, match="`checkpoints` applies to checkpoint='recursive'"):
        Simulation(0.0, 1.0, 0.1, checkpoints=4)
    for bad in (0, -3, True):
        with pytest.raises(ValueError, match="`checkpoints` must be a positive integer"):
            Simulation(0.0, 1.0, 0.1, checkpoint="recursive", checkpoints=bad)
    # equinox's checkpointed scan has no forward-mode rule: refused before compiling.
    loop, x0s, objective, u = _problem("recursive")
    with pytest.raises(ValueError, match="mode='forward' cannot differentiate"):
        tune.loss_and_grad(u, loop, PARAMS, objective, x0s, mode="forward")
    loop, x0s, objective, u = _problem()
    with pytest.raises(ValueError, match="mode"):
        tune.loss_and_grad(u, loop, PARAMS, objective, x0s, mode="jvp")
    with pytest.raises(ValueError, match="mode"):
        tune.tune(loop, PARAMS, objective, x0s, steps=1, mode="backward")
