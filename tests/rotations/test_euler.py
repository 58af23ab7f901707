"""3-2-1 Euler angles: DCM round trips against SciPy, and the gimbal-lock behaviour (float64).

Two programs, jitted and vmapped once at module level (the angles of a DCM come with their
Jacobian, so one compilation serves the value and the gradient tests).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
from scipy.spatial.transform import Rotation

from jaxatt import rotations as rot


to_dcm = jax.jit(jax.vmap(rot.euler321_to_dcm))
_from_dcm_and_jacobian = jax.jit(
    jax.vmap(lambda c: (rot.euler321_from_dcm(c), jax.jacfwd(rot.euler321_from_dcm)(c)))
)


def from_dcm(c):
    return _from_dcm_and_jacobian(jnp.asarray(c))[0]


def _angles(theta, n=16, seed=0):
    rng = np.random.default_rng(seed)
    out = rng.uniform(-3.0, 3.0, size=(n, 3))
    out[:, 1] = theta
    return out


def _scipy_dcm(angles):
    """C_BN = R1(phi) R2(theta) R3(psi): SciPy's intrinsic 'ZYX' (psi, theta, phi), transposed."""
    return Rotation.from_euler("ZYX", angles[:, ::-1]).as_matrix().swapaxes(-1, -2)


def test_round_trip_matches_scipy_at_random_angles():
    angles = _angles(0.0)
    angles[:, 1] = np.random.default_rng(1).uniform(-1.5, 1.5, size=len(angles))
    np.testing.assert_allclose(to_dcm(angles), _scipy_dcm(angles), atol=1e-15)
    np.testing.assert_allclose(from_dcm(_scipy_dcm(angles)), angles, atol=2e-15)


def test_gimbal_lock_angles_reproduce_the_dcm():
    # At |theta| = pi/2 only phi -/+ psi is determined: the split is arbitrary, but the angles
    # returned must give the same attitude. With theta = -arcsin(C13) and phi, psi from
    # atan2(C23, C33) and atan2(C12, C11) (rounding-level entries there), the DCM of the angles
    # differed from the input by up to 1.4 and theta was off by 2.6e-8.
    for theta in (math.pi / 2, -math.pi / 2, math.pi / 2 - 1e-9):
        c = _scipy_dcm(_angles(theta))  # through SciPy's quaternion: rounding-level C11, C12
        got = np.asarray(from_dcm(c))
        np.testing.assert_allclose(to_dcm(got), c, atol=2e-15)
        np.testing.assert_allclose(got[:, 1], theta, atol=1e-15)


def test_pitch_is_accurate_near_gimbal_lock():
    # -arcsin(C13) loses digits as eps / |cos theta|: 4e-10 rad at cos theta = 1e-6.
    for theta in (math.pi / 2 - 1e-6, -math.pi / 2 + 1e-4):
        angles = _angles(theta)
        got = np.asarray(from_dcm(to_dcm(angles)))
        np.testing.assert_allclose(got[:, 1], theta, atol=1e-15)
        np.testing.assert_allclose(to_dcm(got), to_dcm(angles), atol=2e-15)


def test_gradient_finite_at_exact_gimbal_lock():
    # Exact zeros in C11 and C12 (theta = +-pi/2): atan2(0, 0) and arcsin'(1) gave NaN and inf.
    # (Eight copies of each: the batch size of the other tests, so nothing is compiled again.)
    c = np.array([[[0.0, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, 0.0]] for s in (1.0, -1.0)] * 8)
    angles, jacobian = _from_dcm_and_jacobian(jnp.asarray(c))
    np.testing.assert_allclose(angles, [[0.0, math.pi / 2, 0.0], [0.0, -math.pi / 2, 0.0]] * 8)
    assert np.all(np.isfinite(jacobian))
