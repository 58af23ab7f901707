"""Gradients of the Shi 2024 objectives (attitude convergence time, residual modal energy) with
respect to the TVSMC gains and the smoother frequency, against central finite differences.

A 40 s manoeuvre at dt = 2e-2 s without the observer (its relay has no useful derivative), the
smoother at 0.6258 rad/s (a 20 s command) and the 0.1 tolerance, crossed around 20-30 s.
Separate module so that `pytest -n 2` runs it beside the reproduction.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxatt.metrics import settling_time
from jaxatt.scenarios import shi2024
from jaxatt.simulation import simulate


def _objective_inputs():
    """A short manoeuvre: case 2 structure (no observer), the smoother at 0.6258 rad/s."""
    loop = shi2024.build("case2")
    shaper = shi2024.ZeroVibrationSmoother(0.6258, 0.01)
    loop = eqx.tree_at(
        lambda lp: lp.reference,
        loop,
        shi2024.ShapedAttitude(shaper, shi2024.q0(), jnp.array([1.0, 0, 0, 0])),
    )
    return loop


def test_gradients_match_finite_differences():
    """d/dp of the attitude convergence time (to 0.1) and of the final modal energy, for the TVSMC
    gains kp, k0, gamma_k and the smoother frequency; forward mode against central differences."""
    base = _objective_inputs()
    x0 = shi2024.initial_state()

    def objectives(params):
        kp, k0, gamma_k, freq = params
        loop = eqx.tree_at(
            lambda lp: (
                lp.controller.kp,
                lp.controller.k0,
                lp.controller.gamma_k,
                lp.reference.shaper.frequency,
            ),
            base,
            (kp, k0, gamma_k, freq),
        )
        traj = simulate(loop, x0, 0.0, 40.0, dt=2e-2, save_every=5, throw=False)
        att = jnp.max(jnp.abs(traj.plant_states.q[:, 1:]), axis=1)
        return jnp.stack([settling_time(traj.ts, att, 0.1), traj.signals["modal_energy"][-1]])

    p0 = jnp.array([0.4, 2.0, 0.005, 0.6258])
    f = jax.jit(objectives)
    jac = np.asarray(jax.jit(jax.jacfwd(objectives))(p0))
    assert np.all(np.isfinite(jac))
    for i, rel in enumerate((1e-4, 1e-4, 1e-3, 1e-4)):
        h = rel * float(p0[i])
        e = jnp.zeros(4).at[i].set(h)
        fd = (np.asarray(f(p0 + e)) - np.asarray(f(p0 - e))) / (2 * h)
        np.testing.assert_allclose(jac[:, i], fd, rtol=2e-3, atol=1e-9)
