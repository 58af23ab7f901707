"""PoseSlidingMode makes the sliding variable obey its reaching law exactly.

Along the closed loop, ds/dt (forward-mode autodiff of s(t, x) along t -> (t, x(t)), with the
plant's vector field under the controller's own u) must equal
r(s) - ||beta2 C^-1|| zeta phi(s) + beta2 C^-1 d (SPEC 003.2-003.3: the derivation of (11) and of
(33) with the corrected sign). The printed sign of (33)'s rho' term breaks the identity by
exactly 2 beta2 e2 rho2'/rho2.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.numerics import spectral_norm
from jaxatt.scenarios import zhang2021_hover as hover


T = 37.0


@pytest.fixture(scope="module")
def state():
    # an arbitrary state inside every initial envelope (rho0 = 40 m, 1.5, 1 m/s, 0.05 rad/s)
    return hover.initial_state(
        (12.0, -8.0, 5.0), (0.3, 0.1, -0.2), (0.4, 0.2, -0.5), (0.01, -0.03, 0.02)
    )


@eqx.filter_jit  # op-by-op dispatch of this much code takes ~20 s; compiled, ~2 s
def _sliding_rate(loop, x):
    controller, plant = loop.controller, loop.plant

    def s_of(t, x):
        kappa1, _, kappa2, _, _ = controller._parts(t, x)
        return controller.surface_gain * kappa1 + kappa2

    u, _ = controller(T, x, None, None)
    x_dot = plant.vector_field(T, x, u)
    s, s_dot = jax.jvp(s_of, (jnp.asarray(T), x), (jnp.asarray(1.0), x_dot))
    _, _, _, beta2, _ = controller._parts(T, x)
    gain = beta2[:, None] * controller.model.inverse_inertia()
    d = jnp.concatenate([plant.disturbance_force(T), plant.disturbance_torque(T)])
    law = controller.reaching_law
    expected = law.rate(s) - spectral_norm(gain) * controller.disturbance_bound * law.switching(s)
    return s_dot, expected + gain @ d, beta2


@pytest.mark.parametrize("name", hover.CONTROLLERS)
def test_sliding_variable_follows_the_reaching_law(name, state):
    s_dot, expected, _ = _sliding_rate(hover.build(name), state)
    np.testing.assert_allclose(s_dot, expected, rtol=1e-9, atol=1e-12)


def test_the_printed_sign_breaks_the_reaching_dynamics(state):
    loop = hover.build("ppc", rate_term="literal")
    s_dot, expected, beta2 = _sliding_rate(loop, state)
    rho, rho_dot = loop.controller.envelope_at(T)
    e2 = state.e2
    np.testing.assert_allclose(s_dot - expected, -2 * beta2 * e2 * rho_dot[6:] / rho[6:], rtol=1e-9)
    assert float(jnp.max(jnp.abs(s_dot - expected))) > 1e-4


def test_robust_gain_is_the_norm_of_the_whole_6x6_whichever_block_dominates():
    """The controller takes ||beta2 C^-1||_2 block by block (C^-1 = blkdiag(I/m, J^-1)); it
    must equal the 6x6 norm (LAPACK) when either block is the larger, not only at the
    scenario's mass and inertia (where the rotational block dominates)."""
    from jaxatt.controllers._pose_sliding_mode import _block_diagonal_norm

    rng = np.random.default_rng(5)
    inertia = np.array([[14.0, 0.3, -0.2], [0.3, 15.0, 0.1], [-0.2, 0.1, 17.0]])
    for mass in (100.0, 0.01):  # rotational block larger, translational block larger
        c_inv = np.zeros((6, 6))
        c_inv[:3, :3] = np.eye(3) / mass
        c_inv[3:, 3:] = np.linalg.inv(inertia)
        beta2 = rng.uniform(1.0, 3.0, size=6)
        gain = beta2[:, None] * c_inv
        np.testing.assert_allclose(
            _block_diagonal_norm(jnp.asarray(gain)), np.linalg.norm(gain, 2), rtol=1e-13
        )
