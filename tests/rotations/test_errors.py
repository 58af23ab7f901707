"""Tracking errors: SPEC seed 000 eqs. (7)-(12) written out, and the MRP counterparts (float64)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt import rotations as rot

from ..helpers import primitives


def _axis_angle_np(axis, angle):
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])


def _random_quats(seed, n):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _skew_np(v):
    """[v x] for a batch of vectors, built from numpy's cross product."""
    return np.cross(v[:, :, None], np.eye(3)[None], axisa=1, axisb=1, axisc=1)


def _jv(fn):
    return jax.jit(jax.vmap(fn))


N = 24
RNG = np.random.default_rng(77)
Q = _random_quats(0, N)
QD = _random_quats(1, N)
QD[N - 3] = Q[N - 3]  # zero error
QD[N - 2] = -Q[N - 2]  # zero error with e0 = -1 (the MRP error's singular point)
QD[N - 1] = np.asarray(rot.quat_multiply(Q[N - 1], _axis_angle_np([1.0, 2.0, 3.0], 1e-8)))
OMEGA = RNG.normal(size=(N, 3))
OMEGA_D = RNG.normal(size=(N, 3))

err_quat = _jv(rot.attitude_error_quat)
rate_err = _jv(rot.rate_error)
err_mrp = _jv(rot.attitude_error_mrp)
rate_err_mrp = _jv(rot.rate_error_mrp)
quat_to_dcm = _jv(rot.quat_to_dcm)
quat_mul = _jv(rot.quat_multiply)
mrp_from_quat = _jv(rot.mrp_from_quat)
mrp_to_dcm = _jv(rot.mrp_to_dcm)
mrp_kin = _jv(rot.mrp_kinematics)
quat_kin = _jv(rot.quat_kinematics)


def _eq10(e):
    """SPEC seed 000 eq. (10): C = (1 - 2 ev^T ev) I + 2 ev ev^T - 2 e0 [ev x]."""
    e0, ev = e[:, 0], e[:, 1:]
    return (
        (1 - 2 * np.sum(ev * ev, axis=1))[:, None, None] * np.eye(3)
        + 2 * ev[:, :, None] * ev[:, None, :]
        - 2 * e0[:, None, None] * _skew_np(ev)
    )


def test_attitude_error_quat_matches_spec_eqs_7_8():
    e = np.asarray(err_quat(Q, QD))
    q0, qv, qd0, qdv = Q[:, 0], Q[:, 1:], QD[:, 0], QD[:, 1:]
    e0 = np.sum(qdv * qv, axis=1) + q0 * qd0
    ev = qd0[:, None] * qv - np.cross(qdv, qv) - q0[:, None] * qdv
    np.testing.assert_allclose(e[:, 0], e0, atol=1e-15)
    np.testing.assert_allclose(e[:, 1:], ev, atol=1e-15)
    # q = q_d (x) e, and zero error when q = +-q_d (samples N-3 and N-2).
    np.testing.assert_allclose(quat_mul(QD, e), Q, atol=1e-15)
    np.testing.assert_allclose(np.abs(e[N - 3 : N - 1]), [[1.0, 0, 0, 0]] * 2, atol=1e-15)


def test_error_dcm_is_spec_eq_10_and_maps_desired_to_body():
    e = np.asarray(err_quat(Q, QD))
    c_e = np.asarray(quat_to_dcm(e))
    np.testing.assert_allclose(c_e, _eq10(e), atol=1e-14)
    # C(e) = C_BD = C_BN C_DN^T.
    c_b, c_d = np.asarray(quat_to_dcm(Q)), np.asarray(quat_to_dcm(QD))
    np.testing.assert_allclose(c_e, c_b @ c_d.swapaxes(1, 2), atol=1e-14)


def test_rate_error_spec_eq_9():
    e = np.asarray(err_quat(Q, QD))
    expected = OMEGA - np.einsum("nij,nj->ni", _eq10(e), OMEGA_D)
    np.testing.assert_allclose(rate_err(e, OMEGA, OMEGA_D), expected, atol=1e-14)
    # Same rotation and same rate give zero error.
    identity = np.broadcast_to([1.0, 0.0, 0.0, 0.0], (N, 4))
    np.testing.assert_array_equal(rate_err(identity, OMEGA, OMEGA), np.zeros((N, 3)))


def _trajectories(t):
    """Exact solutions for constant body rates: q(t) = q(0) (x) exp(omega t / 2), same for q_d."""
    steps = np.stack([_axis_angle_np(w, np.linalg.norm(w) * t) for w in OMEGA])
    steps_d = np.stack([_axis_angle_np(w, np.linalg.norm(w) * t) for w in OMEGA_D])
    return np.asarray(quat_mul(Q, steps)), np.asarray(quat_mul(QD, steps_d))


def test_trajectories_solve_the_kinematics():
    t, h = 0.6, 1e-5
    (qp, qdp), (qm, qdm) = _trajectories(t + h), _trajectories(t - h)
    q, qd = _trajectories(t)
    np.testing.assert_allclose((qp - qm) / (2 * h), quat_kin(q, OMEGA), atol=1e-10)
    np.testing.assert_allclose((qdp - qdm) / (2 * h), quat_kin(qd, OMEGA_D), atol=1e-10)


def test_error_kinematics_spec_eqs_11_12():
    # d/dt e = 1/2 E(e) e_omega along q_dot = 1/2 E(q) omega, q_d_dot = 1/2 E(q_d) omega_d.
    t, h = 0.6, 1e-5
    e_plus = np.asarray(err_quat(*_trajectories(t + h)))
    e_minus = np.asarray(err_quat(*_trajectories(t - h)))
    e = np.asarray(err_quat(*_trajectories(t)))
    e_dot_fd = (e_plus - e_minus) / (2 * h)
    e_omega = np.asarray(rate_err(e, OMEGA, OMEGA_D))
    e0, ev = e[:, 0], e[:, 1:]
    np.testing.assert_allclose(e_dot_fd[:, 0], -0.5 * np.sum(ev * e_omega, axis=1), atol=1e-10)
    expected_v = 0.5 * (e0[:, None] * e_omega + np.cross(ev, e_omega))
    np.testing.assert_allclose(e_dot_fd[:, 1:], expected_v, atol=1e-10)


def test_attitude_error_mrp_equals_quaternion_route_and_schaub_formula():
    s, sd = np.asarray(mrp_from_quat(Q)), np.asarray(mrp_from_quat(QD))
    se = np.asarray(err_mrp(s, sd))
    route = np.asarray(mrp_from_quat(err_quat(Q, QD)))
    ok = np.linalg.norm(route, axis=1) < 1e3  # away from e0 = -1 (sample N-2 is exactly there)
    assert ok.sum() == N - 1
    np.testing.assert_allclose(se[ok], route[ok], rtol=1e-10, atol=1e-13)
    # Schaub's MRP subtraction, written out.
    s2, sd2 = np.sum(s * s, axis=1), np.sum(sd * sd, axis=1)
    num = (1 - sd2)[:, None] * s - (1 - s2)[:, None] * sd + 2 * np.cross(s, sd)
    den = 1 + sd2 * s2 + 2 * np.sum(sd * s, axis=1)
    np.testing.assert_allclose(se[ok], num[ok] / den[ok, None], rtol=1e-10, atol=1e-13)
    # C(sigma_e) = C(sigma) C(sigma_d)^T everywhere, including the singular sample.
    c, cd = np.asarray(mrp_to_dcm(s)), np.asarray(mrp_to_dcm(sd))
    np.testing.assert_allclose(mrp_to_dcm(se), c @ cd.swapaxes(1, 2), atol=1e-11)


def test_attitude_error_mrp_of_shadow_pair_is_zero():
    # sigma and its shadow set are the same attitude: the error is the identity, not inf.
    s = np.asarray(mrp_from_quat(Q))
    se = np.asarray(err_mrp(s, jax.vmap(rot.mrp_shadow)(s)))
    assert np.all(np.isfinite(se))
    np.testing.assert_allclose(se, 0.0, atol=1e-7)


def test_rate_error_mrp_and_mrp_error_kinematics():
    s, sd = np.asarray(mrp_from_quat(Q)), np.asarray(mrp_from_quat(QD))
    e = np.asarray(err_quat(Q, QD))
    ok = np.abs(1 + e[:, 0]) > 1e-3
    se = np.asarray(err_mrp(s, sd))
    np.testing.assert_allclose(
        rate_err_mrp(se, OMEGA, OMEGA_D)[ok], rate_err(e, OMEGA, OMEGA_D)[ok], atol=1e-12
    )
    # d/dt sigma_e = G(sigma_e) (omega - C(sigma_e) omega_d) along the exact trajectories.
    t, h = 0.6, 1e-5

    def sigma_e_at(time):
        q, qd = _trajectories(time)
        return np.asarray(err_mrp(mrp_from_quat(q), mrp_from_quat(qd)))

    se_t = sigma_e_at(t)
    fine = np.linalg.norm(se_t, axis=1) < 20
    rate_fd = (sigma_e_at(t + h) - sigma_e_at(t - h)) / (2 * h)
    expected = mrp_kin(se_t, rate_err_mrp(se_t, OMEGA, OMEGA_D))
    np.testing.assert_allclose(rate_fd[fine], expected[fine], rtol=1e-7, atol=1e-8)


def test_gradients_finite_at_zero_error():
    s = jnp.asarray(mrp_from_quat(Q[:3]))

    def loss(sigma, sigma_d):
        return jnp.sum(rot.attitude_error_mrp(sigma, sigma_d) ** 2)

    g_same = _jv(jax.grad(loss, argnums=(0, 1)))(s, s)
    g_shadow = _jv(jax.grad(loss, argnums=(0, 1)))(s, jax.vmap(rot.mrp_shadow)(s))
    for g in (*g_same, *g_shadow):
        assert np.all(np.isfinite(g))
    g_quat = _jv(jax.grad(lambda q, qd: rot.quat_angle(rot.attitude_error_quat(q, qd))))(Q, Q)
    assert np.all(np.isfinite(g_quat))


def test_jit_matches_eager():
    e = rot.attitude_error_quat(Q[0], QD[0])
    np.testing.assert_allclose(e, err_quat(Q[:1], QD[:1])[0], atol=1e-16)
    np.testing.assert_allclose(
        rot.rate_error(e, OMEGA[0], OMEGA_D[0]),
        rate_err(e[None], OMEGA[:1], OMEGA_D[:1])[0],
        atol=1e-15,
    )


_Q32 = np.asarray(Q[0], dtype=np.float32)
_V32 = np.asarray(OMEGA[0], dtype=np.float32)


@pytest.mark.parametrize(
    "fn, args",
    [
        (rot.attitude_error_quat, (_Q32, _Q32)),
        (rot.rate_error, (_Q32, _V32, _V32)),
        (rot.attitude_error_mrp, (_V32, _V32)),
        (rot.rate_error_mrp, (_V32, _V32, _V32)),
    ],
)
def test_float32_in_float32_out(fn, args):
    assert jax.eval_shape(fn, *args).dtype == jnp.float32


@pytest.mark.parametrize("fn, error", [(rot.rate_error, Q[0]), (rot.rate_error_mrp, Q[0, 1:])])
def test_a_known_zero_desired_rate_gives_the_formulas_value_with_no_arithmetic(fn, error):
    """A NumPy zero `omega_d` (ConstantAttitude's) is known when the program is traced: the
    rate error is `omega` itself, as the formula gives, in the formula's dtype, and the traced
    program computes nothing. Traced zeros still go through the formula."""
    zero = np.zeros(3)
    formula = jax.jit(fn)  # inside jit the zero is an argument: the formula
    np.testing.assert_array_equal(fn(error, OMEGA[0], zero), formula(error, OMEGA[0], zero))
    np.testing.assert_array_equal(fn(error, OMEGA[0], zero), OMEGA[0])
    known = jax.make_jaxpr(lambda e, w: fn(e, w, zero))(error, OMEGA[0])
    assert not primitives(known) & {"mul", "sub", "dot_general", "div"}
    traced = jax.make_jaxpr(fn)(error, OMEGA[0], zero)
    assert primitives(traced) & {"mul", "sub", "dot_general"}
    e32, w32 = np.asarray(error, np.float32), OMEGA[0].astype(np.float32)
    for zeros in (np.zeros(3, np.float32), zero):  # float32 stays, a float64 zero promotes
        shortcut = jax.eval_shape(lambda e, w, zeros=zeros: fn(e, w, zeros), e32, w32)
        assert shortcut.dtype == formula.eval_shape(e32, w32, zeros).dtype
