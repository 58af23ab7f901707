"""Quaternion algebra, DCMs, axis-angle and kinematics (jaxlie-style property tests, float64).

References are independent of the code under test: SciPy's `Rotation`, the Hamilton basis
table, closed forms of rotations about coordinate axes, and finite differences. Functions are
jitted and vmapped once at module level (eager first calls compile every primitive).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads
from scipy.spatial.transform import Rotation

from jaxatt import rotations as rot


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _axis_angle_np(axis, angle):
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * _unit(axis)])


def _samples(seed, n=24):
    """Random unit quaternions (both hemispheres) plus identity, near-identity and near-pi."""
    rng = np.random.default_rng(seed)
    random = rng.normal(size=(n, 4))
    random /= np.linalg.norm(random, axis=1, keepdims=True)
    special = [
        [1.0, 0.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0, 0.0],
        _axis_angle_np(rng.normal(size=3), 1e-8),
        -_axis_angle_np(rng.normal(size=3), 1e-8),
        _axis_angle_np(rng.normal(size=3), math.pi - 1e-8),
        _axis_angle_np(rng.normal(size=3), math.pi + 1e-8),
        _axis_angle_np([1.0, 0.0, 0.0], math.pi),
        _axis_angle_np([0.0, 1.0, 0.0], math.pi),
        _axis_angle_np([0.0, 0.0, 1.0], math.pi),
        _axis_angle_np([1.0, -2.0, 0.5], math.pi),
    ]
    return np.concatenate([random, np.asarray(special)])


def _scipy_dcm(q):
    """C_BN from SciPy: `as_matrix` is the active rotation C_NB (scalar-last quaternions)."""
    return Rotation.from_quat(np.asarray(q)[..., [1, 2, 3, 0]]).as_matrix().swapaxes(-1, -2)


def _max_diff_up_to_sign(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return np.minimum(np.max(np.abs(a - b), axis=-1), np.max(np.abs(a + b), axis=-1))


Q = _samples(0)
P = _samples(1)
R3 = _samples(2)
N = Q.shape[0]
RNG = np.random.default_rng(123)
V = RNG.normal(size=(N, 3))
W = RNG.normal(size=(N, 3))


def _jv(fn):
    return jax.jit(jax.vmap(fn))


mul = _jv(rot.quat_multiply)
conj = _jv(rot.quat_conjugate)
inverse = _jv(rot.quat_inverse)
canonical = _jv(rot.quat_canonical)
to_dcm = _jv(rot.quat_to_dcm)
from_dcm = _jv(rot.quat_from_dcm)
rotate = _jv(rot.quat_rotate)
to_axis_angle = _jv(rot.quat_to_axis_angle)
from_axis_angle = _jv(rot.quat_from_axis_angle)
angle = _jv(rot.quat_angle)
kin = _jv(rot.quat_kinematics)
kin_matrix = _jv(rot.quat_kinematics_matrix)
skew = _jv(rot.skew)
vee = _jv(rot.vee)


def test_skew_and_vee():
    s = np.asarray(skew(V))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", s, W), np.cross(V, W), atol=1e-15)
    np.testing.assert_array_equal(s, -s.swapaxes(1, 2))
    np.testing.assert_array_equal(vee(s), V)
    m = RNG.normal(size=(N, 3, 3))
    np.testing.assert_allclose(vee(m), vee(0.5 * (m - m.swapaxes(1, 2))), atol=1e-15)


def test_hamilton_basis_table():
    one, i, j, k = np.eye(4)
    left = np.array([i, j, k, j, k, i, i, j, k])
    right = np.array([j, k, i, i, j, k, i, j, k])
    expected = np.array([k, i, j, -k, -i, -j, -one, -one, -one])
    np.testing.assert_array_equal(mul(left, right), expected)


def test_group_axioms():
    identity = np.broadcast_to(np.array([1.0, 0.0, 0.0, 0.0]), Q.shape)
    np.testing.assert_allclose(mul(mul(P, Q), R3), mul(P, mul(Q, R3)), atol=1e-15)
    np.testing.assert_array_equal(mul(Q, identity), Q)
    np.testing.assert_array_equal(mul(identity, Q), Q)
    np.testing.assert_allclose(mul(Q, inverse(Q)), identity, atol=1e-15)
    np.testing.assert_allclose(mul(inverse(Q), Q), identity, atol=1e-15)
    np.testing.assert_allclose(inverse(Q), conj(Q), atol=1e-15)
    np.testing.assert_allclose(conj(mul(P, Q)), mul(conj(Q), conj(P)), atol=1e-15)


def test_inverse_of_non_unit_and_zero_quaternion():
    q = np.array([[0.3, -1.2, 2.0, 0.7], [0.0, 0.0, 0.0, 0.0]])
    out = np.asarray(inverse(q))
    np.testing.assert_allclose(mul(q[:1], out[:1])[0], [1.0, 0.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_array_equal(out[1], np.zeros(4))


def test_identity_dtype():
    assert rot.quat_identity().dtype == jnp.float64
    assert rot.quat_identity(jnp.float32).dtype == jnp.float32
    np.testing.assert_array_equal(rot.quat_identity(), [1.0, 0.0, 0.0, 0.0])


def test_dcm_matches_scipy_and_is_a_rotation():
    c = np.asarray(to_dcm(Q))
    np.testing.assert_allclose(c, _scipy_dcm(Q), atol=1e-14)
    np.testing.assert_allclose(
        c @ c.swapaxes(1, 2), np.broadcast_to(np.eye(3), c.shape), atol=1e-14
    )
    np.testing.assert_allclose(np.linalg.det(c), 1.0, atol=1e-14)


def test_dcm_and_rotate_about_z_closed_form():
    # B turned by +theta about n3: v_B = C_BN v_N with the passive matrix R3(theta).
    theta = 0.7
    c, s = math.cos(theta), math.sin(theta)
    expected = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    axes = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 1.0]])
    qs = from_axis_angle(axes, np.array([theta, math.pi / 2]))
    np.testing.assert_allclose(to_dcm(qs)[0], expected, atol=1e-15)
    # Turning body x by +90 deg about z gives inertial y.
    x_axis = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    np.testing.assert_allclose(rotate(qs, x_axis)[1], [0.0, 1.0, 0.0], atol=1e-15)


def test_dcm_composition_order():
    # q_{B/N} = p (x) q with p = A/N and q = B/A, so C_BN = C_BA C_AN = C(q) C(p).
    np.testing.assert_allclose(to_dcm(mul(P, Q)), to_dcm(Q) @ to_dcm(P), atol=1e-14)
    # The other order is genuinely different (guards against a commuting implementation).
    assert np.max(np.abs(to_dcm(mul(P, Q)) - to_dcm(P) @ to_dcm(Q))) > 1e-2


def test_dcm_of_negated_quaternion_is_the_same():
    np.testing.assert_array_equal(to_dcm(-Q), to_dcm(Q))


def test_rotate_is_sandwich_product_and_transposed_dcm():
    rotated = rotate(Q, V)
    pure = np.concatenate([np.zeros((N, 1)), V], axis=1)
    sandwich = np.asarray(mul(mul(Q, pure), conj(Q)))
    np.testing.assert_allclose(rotated, sandwich[:, 1:], atol=1e-14)
    np.testing.assert_allclose(sandwich[:, 0], 0.0, atol=1e-14)
    np.testing.assert_allclose(rotated, np.einsum("nji,nj->ni", _scipy_dcm(Q), V), atol=1e-14)


def test_quat_dcm_round_trips():
    recovered = np.asarray(from_dcm(to_dcm(Q)))
    assert np.all(recovered[:, 0] >= 0)
    assert np.all(_max_diff_up_to_sign(recovered, Q) <= 1e-12)
    # Away from q0 = 0 the canonical sign is determined: compare directly.
    away = np.abs(Q[:, 0]) > 1e-6
    np.testing.assert_allclose(recovered[away], canonical(Q)[away], atol=1e-12)
    # dcm -> quat -> dcm starting from SciPy's matrices.
    mats = np.concatenate([Rotation.random(N - 4, random_state=5).as_matrix(), _scipy_dcm(Q[-4:])])
    np.testing.assert_allclose(to_dcm(from_dcm(mats)), mats, atol=1e-14)


def test_from_dcm_near_pi_and_near_identity():
    rng = np.random.default_rng(6)
    angles = np.repeat([math.pi, math.pi - 1e-8, math.pi - 1e-4, 1e-8, 0.0, 2.0], 4)[:N]
    qs = np.stack([_axis_angle_np(rng.normal(size=3), a) for a in angles])
    recovered = from_dcm(_scipy_dcm(qs))
    assert np.all(_max_diff_up_to_sign(recovered, qs) <= 1e-12)
    np.testing.assert_allclose(np.linalg.norm(recovered, axis=1), 1.0, atol=1e-15)


def test_from_dcm_of_slightly_non_orthogonal_matrix_is_unit():
    c = _scipy_dcm(Q) + 1e-6 * RNG.normal(size=(N, 3, 3))
    q = from_dcm(c)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)
    assert np.all(_max_diff_up_to_sign(q, Q) <= 1e-5)


def test_axis_angle_round_trips():
    axis, ang = to_axis_angle(Q)
    assert np.all((ang >= 0) & (ang <= math.pi))
    back = from_axis_angle(axis, ang)
    assert np.all(_max_diff_up_to_sign(back, canonical(Q)) <= 1e-12)
    # axis-angle -> quaternion -> axis-angle for angles in (0, pi): exact recovery.
    axes = V / np.linalg.norm(V, axis=1, keepdims=True)
    angles = np.concatenate([RNG.uniform(0, math.pi, size=N - 3), [1e-8, 1e-12, math.pi - 1e-8]])
    axis2, angle2 = to_axis_angle(from_axis_angle(axes, angles))
    np.testing.assert_allclose(angle2, angles, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(axis2, axes, atol=1e-12)
    # Angles above pi come back as 2 pi - angle about the opposite axis.
    axis3, angle3 = to_axis_angle(from_axis_angle(axes, np.full(N, 4.0)))
    np.testing.assert_allclose(angle3, 2 * math.pi - 4.0, atol=1e-14)
    np.testing.assert_allclose(axis3, -axes, atol=1e-14)
    # Closed form [cos(phi/2), sin(phi/2) n]; the axis length does not matter, however small
    # or large (|axis|^2 under/overflowed beyond ~1e-154 / 1e154: the result was
    # [cos(phi/2), 0, 0, 0], not a unit quaternion).
    closed_form = np.concatenate(
        [np.cos(angles / 2)[:, None], np.sin(angles / 2)[:, None] * axes], 1
    )
    for scale in (3.0, 1e-200, 1e200):
        np.testing.assert_allclose(from_axis_angle(scale * axes, angles), closed_form, atol=1e-15)


def test_axis_angle_degenerate_inputs():
    zero_axis = from_axis_angle(np.zeros((2, 3)), np.array([1.3, 0.0]))
    np.testing.assert_array_equal(zero_axis, [[1.0, 0, 0, 0], [1.0, 0, 0, 0]])
    axis, ang = to_axis_angle(np.array([[1.0, 0, 0, 0], [-2.0, 0, 0, 0]]))
    np.testing.assert_array_equal(axis, np.zeros((2, 3)))
    np.testing.assert_array_equal(ang, [0.0, 0.0])


def test_quat_angle_against_scipy():
    ang = angle(Q)
    np.testing.assert_allclose(ang, Rotation.from_quat(Q[:, [1, 2, 3, 0]]).magnitude(), atol=1e-12)
    np.testing.assert_array_equal(angle(-Q), ang)
    np.testing.assert_allclose(angle(3.0 * Q), ang, atol=1e-15)
    # Small angles are accurate in relative terms (no arccos of a number close to 1).
    small = np.stack([_axis_angle_np(v, 1e-8) for v in V])
    np.testing.assert_allclose(angle(small), 1e-8, rtol=1e-14)


def test_normalize_and_canonical():
    q = np.array([-3.0, 0.0, 4.0, 0.0])
    normalized = _jv(rot.quat_normalize)(np.stack([q, np.zeros(4)]))
    np.testing.assert_allclose(normalized[0], q / 5, atol=1e-16)
    np.testing.assert_array_equal(normalized[1], np.zeros(4))
    np.testing.assert_array_equal(canonical(np.stack([q, -q])), [-q, -q])


def test_kinematics_matrix_is_right_multiplication_by_pure_rate():
    pure = np.concatenate([np.zeros((N, 1)), W], axis=1)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", kin_matrix(Q), W), mul(Q, pure), atol=1e-15)
    q_dot = np.asarray(kin(Q, W))
    # Written out as SPEC seed 000 eqs. (1)-(2).
    q0, qv = Q[:, 0], Q[:, 1:]
    np.testing.assert_allclose(q_dot[:, 0], -0.5 * np.sum(qv * W, axis=1), atol=1e-15)
    np.testing.assert_allclose(q_dot[:, 1:], 0.5 * (q0[:, None] * W + np.cross(qv, W)), atol=1e-15)
    np.testing.assert_allclose(np.sum(Q * q_dot, axis=1), 0.0, atol=1e-15)


def test_dcm_kinematics_by_finite_differences():
    # Along q_dot = 1/2 E(q) omega: dC_BN/dt = -[omega x] C_BN (central differences, h = 1e-6).
    h = 1e-6
    q_dot = np.asarray(kin(Q, W))
    c_dot = (np.asarray(to_dcm(Q + h * q_dot)) - np.asarray(to_dcm(Q - h * q_dot))) / (2 * h)
    c = np.asarray(to_dcm(Q))
    expected = -np.cross(W[:, :, None], c, axisa=1, axisb=1, axisc=1)  # columns: -omega x C e_j
    np.testing.assert_allclose(c_dot, expected, atol=1e-8)


def test_exact_constant_rate_solution_satisfies_kinematics():
    # q(t) = q(0) (x) [cos(|w| t/2), w/|w| sin(|w| t/2)] solves q_dot = 1/2 q (x) [0, w].
    t, h = 0.8, 1e-5

    def q_at(s):
        steps = np.stack([_axis_angle_np(w, np.linalg.norm(w) * s) for w in W])
        return np.asarray(mul(Q, steps))

    q_dot_fd = (q_at(t + h) - q_at(t - h)) / (2 * h)
    np.testing.assert_allclose(q_dot_fd, kin(q_at(t), W), atol=1e-10)


# --- gradients ------------------------------------------------------------------------

_WEIGHTS4 = jnp.array([0.3, -0.2, 0.5, 0.7])
_SINGULAR_QS = np.array([[1.0, 0, 0, 0], [-1.0, 0, 0, 0], [0.0, 0, 1, 0], [0.0, 0, 0, 0]])


def test_gradients_finite_at_identity_and_pi():
    g_angle = np.asarray(_jv(jax.grad(rot.quat_angle))(_SINGULAR_QS))
    assert np.all(np.isfinite(g_angle))
    np.testing.assert_array_equal(g_angle[[0, 1, 3]], np.zeros((3, 4)))
    np.testing.assert_array_equal(g_angle[2], np.zeros(4))  # cone maximum at pi: subgradient 0
    g_norm = _jv(jax.grad(lambda q: jnp.dot(_WEIGHTS4, rot.quat_normalize(q))))(_SINGULAR_QS)
    assert np.all(np.isfinite(g_norm))
    np.testing.assert_array_equal(g_norm[3], np.zeros(4))
    dcms = _scipy_dcm(np.concatenate([_SINGULAR_QS[:3], Q[-6:]]))
    g_dcm = _jv(jax.grad(lambda c: jnp.dot(_WEIGHTS4, rot.quat_from_dcm(c))))(dcms)
    assert np.all(np.isfinite(g_dcm))
    g_axis = _jv(jax.grad(lambda q: jnp.sum(rot.quat_to_axis_angle(q)[0])))(_SINGULAR_QS)
    assert np.all(np.isfinite(g_axis))
    g_from = jax.jit(jax.grad(lambda a: jnp.sum(rot.quat_from_axis_angle(a, 0.5))))(jnp.zeros(3))
    assert np.all(np.isfinite(g_from))


@pytest.mark.parametrize(
    "fn, args",
    [
        (rot.quat_multiply, (Q[1], P[1])),
        (rot.quat_to_dcm, (Q[1],)),
        (rot.quat_rotate, (Q[1], V[1])),
        (rot.quat_angle, (Q[1],)),
        (rot.quat_normalize, (2.0 * Q[1],)),
        (rot.quat_from_dcm, (_scipy_dcm(Q[1]),)),
        # Near pi Shepperd selects a vector row (at exactly pi the canonical sign jumps).
        (rot.quat_from_dcm, (_scipy_dcm(_axis_angle_np([1.0, -2.0, 0.5], 2.9)),)),
        (rot.quat_from_axis_angle, (V[1], 0.9)),
        (rot.quat_kinematics, (Q[1], W[1])),
    ],
)
def test_gradients_match_finite_differences(fn, args):
    check_grads(jax.jit(fn), tuple(jnp.asarray(a) for a in args), order=1, modes=["rev"])


# --- transformations and dtypes ---------------------------------------------------------


def test_jit_matches_eager_and_vmap_matches_loop():
    q, p = jnp.asarray(Q[2]), jnp.asarray(P[2])
    np.testing.assert_array_equal(rot.quat_multiply(q, p), mul(Q[2:3], P[2:3])[0])
    c = rot.quat_to_dcm(q)
    np.testing.assert_allclose(jax.jit(rot.quat_from_dcm)(c), rot.quat_from_dcm(c), atol=1e-15)
    np.testing.assert_allclose(
        to_dcm(Q)[:3], np.stack([rot.quat_to_dcm(qi) for qi in Q[:3]]), atol=1e-15
    )


_Q32 = np.asarray(Q[0], dtype=np.float32)
_V32 = np.asarray(V[0], dtype=np.float32)
_C32 = np.asarray(_scipy_dcm(Q[0]), dtype=np.float32)


@pytest.mark.parametrize(
    "fn, args",
    [
        (rot.skew, (_V32,)),
        (rot.vee, (_C32,)),
        (rot.quat_multiply, (_Q32, _Q32)),
        (rot.quat_conjugate, (_Q32,)),
        (rot.quat_inverse, (_Q32,)),
        (rot.quat_normalize, (_Q32,)),
        (rot.quat_canonical, (_Q32,)),
        (rot.quat_from_axis_angle, (_V32, 0.3)),
        (rot.quat_to_axis_angle, (_Q32,)),
        (rot.quat_angle, (_Q32,)),
        (rot.quat_rotate, (_Q32, _V32)),
        (rot.quat_to_dcm, (_Q32,)),
        (rot.quat_from_dcm, (_C32,)),
        (rot.quat_kinematics_matrix, (_Q32,)),
        (rot.quat_kinematics, (_Q32, _V32)),
    ],
)
def test_float32_in_float32_out(fn, args):
    out = jax.eval_shape(fn, *args)
    assert all(leaf.dtype == jnp.float32 for leaf in jax.tree_util.tree_leaves(out)), out
