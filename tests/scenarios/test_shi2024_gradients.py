"""Gradients of the Shi 2024 tuning objectives (attitude convergence time, residual modal energy)
with respect to the TVSMC gains and the smoother frequency, against central finite differences.

The objectives are `shi2024_tuning.objectives` on the tuning loop (no observer: its relay has
no useful derivative; smoother from 0.6258 rad/s), 60 s at dt = 2e-2 s. One compiled program,
`jax.jvp` of both objectives along one direction: the four Jacobian columns (unit
directions) and the eight primal values of the central differences (its primal output) all
come from it. Separate module so that `pytest -n 2` runs it beside the reproduction.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from jaxatt.scenarios import shi2024, shi2024_tuning


def test_gradients_match_finite_differences():
    """d/dp of T_c (convergence_time to 1e-2 of max_i |q_e,i|, extrapolated past the horizon)
    and of the mean modal energy over the last 10 s, p = (kp, k0, gamma_k, omega_k)."""
    base = shi2024_tuning.template()
    x0 = shi2024.initial_state()
    sim = shi2024_tuning.simulation()

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
        return jnp.stack(shi2024_tuning.objectives(loop, x0, sim))

    directional = jax.jit(lambda p, v: jax.jvp(objectives, (p,), (v,)))
    p0 = jnp.array([0.4, 2.0, 0.005, float(shi2024_tuning.START_FREQUENCY)])
    value, _ = directional(p0, jnp.zeros(4))
    assert 55 < float(value[0]) < 80 and 1e-3 < float(value[1]) < 1  # s, J: both informative
    for i, rel in enumerate((1e-4, 1e-4, 1e-3, 1e-4)):
        e = jnp.zeros(4).at[i].set(1.0)
        _, column = directional(p0, e)
        column = np.asarray(column)
        assert np.all(np.isfinite(column))
        h = rel * float(p0[i])
        plus, _ = directional(p0 + h * e, jnp.zeros(4))
        minus, _ = directional(p0 - h * e, jnp.zeros(4))
        fd = (np.asarray(plus) - np.asarray(minus)) / (2 * h)
        np.testing.assert_allclose(column, fd, rtol=2e-3, atol=1e-9)
        assert np.all(np.abs(column) > 1e-6)  # every parameter moves both objectives

    # A failed run (the same compiled program): a NaN gain (a tuner step gone wrong) makes the
    # state non-finite; the objectives are the library's failure values (inf time, NaN
    # energy), not the NaN or the extrapolated time the trajectory would give.
    failed, _ = directional(p0.at[1].set(jnp.nan), jnp.zeros(4))
    assert float(failed[0]) == np.inf and np.isnan(float(failed[1]))
