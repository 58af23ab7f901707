"""Modified Rodrigues parameters: maps, DCM, shadow sets, kinematics, composition (float64).

Independent references: the closed form sigma = n tan(phi/4), SciPy's `Rotation.from_mrp`,
the quaternion route, SPEC seed 004 eq. (4) and finite differences.
"""

import math
from fractions import Fraction

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads
from scipy.spatial.transform import Rotation

from jaxatt import rotations as rot


def _axis_angle_np(axis, angle):
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])


def _samples(seed, n=24):
    """Random unit quaternions (both hemispheres, so |sigma| > 1 occurs), near identity, near pi.

    Excludes q0 = -1, where the literal MRP is singular.
    """
    rng = np.random.default_rng(seed)
    random = rng.normal(size=(n, 4))
    random /= np.linalg.norm(random, axis=1, keepdims=True)
    special = [
        [1.0, 0.0, 0.0, 0.0],
        _axis_angle_np(rng.normal(size=3), 1e-8),
        _axis_angle_np(rng.normal(size=3), math.pi - 1e-8),
        _axis_angle_np(rng.normal(size=3), math.pi),
        _axis_angle_np(rng.normal(size=3), math.pi + 1e-6),
        _axis_angle_np(rng.normal(size=3), 1.9 * math.pi),
    ]
    return np.concatenate([random, np.asarray(special)])


def _scipy_dcm_from_mrp(sigma):
    """C_BN: SciPy's `as_matrix` is the active rotation C_NB; its MRP is n tan(phi/4) too."""
    return Rotation.from_mrp(np.array(sigma)).as_matrix().swapaxes(-1, -2)


def _jv(fn):
    return jax.jit(jax.vmap(fn))


Q = _samples(0)
P = _samples(1)
N = Q.shape[0]
RNG = np.random.default_rng(321)
W = RNG.normal(size=(N, 3))

from_quat = _jv(rot.mrp_from_quat)
to_quat = _jv(rot.quat_from_mrp)
shadow = _jv(rot.mrp_shadow)
switch = _jv(rot.mrp_switch)
to_dcm = _jv(rot.mrp_to_dcm)
from_dcm = _jv(rot.mrp_from_dcm)
g_matrix = _jv(rot.mrp_kinematics_matrix)
kin = _jv(rot.mrp_kinematics)
compose = _jv(rot.mrp_compose)
quat_to_dcm = _jv(rot.quat_to_dcm)
quat_mul = _jv(rot.quat_multiply)

S = np.array(from_quat(Q))  # literal: |sigma| > 1 for q0 < 0
SP = np.array(from_quat(P))
NZ = np.linalg.norm(S, axis=1) > 0  # all but the identity sample


def _cross_matrix_columns(omega, c):
    """-[omega x] C, column by column, without the code under test."""
    return -np.cross(omega[:, :, None], c, axisa=1, axisb=1, axisc=1)


def test_mrp_from_quat_closed_form_tan_quarter_angle():
    axes = RNG.normal(size=(N, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.linspace(-1.95 * math.pi, 1.95 * math.pi, N)
    qs = np.stack([_axis_angle_np(a, phi) for a, phi in zip(axes, angles)])
    sigma = np.asarray(from_quat(qs))
    np.testing.assert_allclose(sigma, axes * np.tan(angles / 4)[:, None], atol=1e-13)
    # Literal map: angles beyond pi (q0 < 0) give |sigma| > 1.
    assert np.all((np.linalg.norm(sigma, axis=1) > 1) == (np.abs(angles) > math.pi))


def test_quat_from_mrp_inverts_mrp_from_quat():
    np.testing.assert_allclose(to_quat(S), Q, atol=1e-12)
    np.testing.assert_allclose(from_quat(to_quat(S)), S, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(to_quat(S), axis=1), 1.0, atol=1e-15)
    # q0 >= 0 exactly when |sigma| <= 1.
    assert np.all((np.asarray(to_quat(S))[:, 0] >= 0) == (np.linalg.norm(S, axis=1) <= 1))


def test_mrp_dcm_matches_quaternion_dcm_and_scipy():
    c = np.asarray(to_dcm(S))
    np.testing.assert_allclose(c, quat_to_dcm(Q), atol=1e-13)
    np.testing.assert_allclose(c, _scipy_dcm_from_mrp(S), atol=1e-13)
    # Written out as in SPEC (general conventions), with numpy's own skew matrices.
    sx = np.cross(S[:, :, None], np.eye(3)[None], axisa=1, axisb=1, axisc=1)
    s2 = np.sum(S * S, axis=1)[:, None, None]
    expected = np.eye(3) + (8 * sx @ sx - 4 * (1 - s2) * sx) / (1 + s2) ** 2
    np.testing.assert_allclose(c, expected, atol=1e-13)
    np.testing.assert_allclose(
        c @ c.swapaxes(1, 2), np.broadcast_to(np.eye(3), c.shape), atol=1e-13
    )
    np.testing.assert_allclose(np.linalg.det(c), 1.0, atol=1e-13)


def test_shadow_set():
    s, q = S[NZ], Q[NZ]  # the identity has no finite shadow set
    sh = np.asarray(shadow(s))
    np.testing.assert_allclose(to_dcm(sh), to_dcm(s), atol=1e-12)
    # The shadow set is the MRP of -q, and an involution.
    far = np.abs(q[:, 0] - 1) > 1e-6  # -q near -identity has a huge MRP
    np.testing.assert_allclose(sh[far], from_quat(-q)[far], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(shadow(sh), s, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(sh, axis=1) * np.linalg.norm(s, axis=1), 1.0)
    np.testing.assert_array_equal(shadow(np.zeros((1, 3))), np.zeros((1, 3)))


def test_switch():
    norms = np.linalg.norm(S, axis=1)
    out = np.asarray(switch(S))
    inside = norms <= 1
    assert inside.any() and (~inside).any()
    np.testing.assert_array_equal(out[inside], S[inside])
    assert np.all(np.linalg.norm(out, axis=1) <= 1)
    np.testing.assert_allclose(to_dcm(out), to_dcm(S), atol=1e-12)
    np.testing.assert_array_equal(switch(np.zeros((1, 3))), np.zeros((1, 3)))
    # A larger threshold leaves |sigma| = 1.5 alone, the default switches it.
    s = np.array([1.5, 0.0, 0.0])
    np.testing.assert_array_equal(rot.mrp_switch(s, 2.0), s)
    np.testing.assert_allclose(rot.mrp_switch(s), [-1 / 1.5, 0.0, 0.0], atol=1e-16)
    with pytest.raises(ValueError, match="threshold"):
        rot.mrp_switch(s, 0.5)


def test_mrp_from_dcm_round_trip_and_bound():
    sigma = np.asarray(from_dcm(quat_to_dcm(Q)))
    assert np.all(np.linalg.norm(sigma, axis=1) <= 1 + 1e-15)
    np.testing.assert_allclose(to_dcm(sigma), quat_to_dcm(Q), atol=1e-13)
    interior = np.abs(np.linalg.norm(S, axis=1) - 1) > 1e-6  # at |sigma| = 1 both sets qualify
    np.testing.assert_allclose(sigma[interior], switch(S)[interior], atol=1e-12)
    mats = Rotation.random(N, random_state=4).as_matrix()
    np.testing.assert_allclose(to_dcm(from_dcm(mats)), mats, atol=1e-13)


def test_kinematics_matrix_closed_form_and_spec_identities():
    g = np.asarray(g_matrix(S))
    s2 = np.sum(S * S, axis=1)
    sx = np.cross(S[:, :, None], np.eye(3)[None], axisa=1, axisb=1, axisc=1)
    expected = 0.25 * (
        (1 - s2)[:, None, None] * np.eye(3) + 2 * sx + 2 * S[:, :, None] * S[:, None, :]
    )
    np.testing.assert_allclose(g, expected, atol=1e-14)
    np.testing.assert_allclose(kin(S, W), np.einsum("nij,nj->ni", g, W), atol=1e-13)
    # SPEC seed 004 eq. (4): s^T G w = (1 + s^T s)/4 s^T w and G G^T = ((1 + s^T s)/4)^2 I.
    lhs = np.einsum("ni,nij,nj->n", S, g, W)
    np.testing.assert_allclose(lhs, (1 + s2) / 4 * np.sum(S * W, axis=1), rtol=1e-12, atol=1e-14)
    ggt = g @ g.swapaxes(1, 2) / ((1 + s2) / 4)[:, None, None] ** 2
    np.testing.assert_allclose(ggt, np.broadcast_to(np.eye(3), ggt.shape), atol=1e-13)


def test_dcm_kinematics_by_finite_differences():
    # Along sigma_dot = G(sigma) omega: dC_BN/dt = -[omega x] C_BN.
    h = 1e-6
    s_dot = np.asarray(kin(S, W))
    c_dot = (np.asarray(to_dcm(S + h * s_dot)) - np.asarray(to_dcm(S - h * s_dot))) / (2 * h)
    np.testing.assert_allclose(c_dot, _cross_matrix_columns(W, np.asarray(to_dcm(S))), atol=1e-7)


def test_kinematics_agree_with_quaternion_trajectory():
    # sigma(t) = mrp(q(0) (x) exp(omega t/2)); its finite-difference rate equals G(sigma) omega.
    t, h = 0.4, 1e-5

    def sigma_at(s):
        steps = np.stack([_axis_angle_np(w, np.linalg.norm(w) * s) for w in W])
        return np.asarray(from_quat(quat_mul(Q, steps)))

    rate_fd = (sigma_at(t + h) - sigma_at(t - h)) / (2 * h)
    sigma = sigma_at(t)
    ok = np.linalg.norm(sigma, axis=1) < 50  # skip samples passing close to q0 = -1
    np.testing.assert_allclose(rate_fd[ok], kin(sigma, W)[ok], rtol=1e-7, atol=1e-8)


def test_compose_equals_quaternion_route():
    route = np.asarray(from_quat(quat_mul(Q, P)))
    ok = np.linalg.norm(route, axis=1) < 1e3  # far from the q0 = -1 singularity
    composed = np.asarray(compose(S, SP))
    np.testing.assert_allclose(composed[ok], route[ok], rtol=1e-10, atol=1e-12)
    # Frame chain: C(compose(a, b)) = C(b) C(a).
    np.testing.assert_allclose(to_dcm(composed), to_dcm(SP) @ to_dcm(S), atol=1e-11)
    # Identity and inverse.
    np.testing.assert_allclose(compose(S, np.zeros_like(S)), S, atol=0)
    np.testing.assert_allclose(compose(np.zeros_like(S), S), S, atol=0)
    np.testing.assert_allclose(compose(S, -S), np.zeros_like(S), atol=1e-15)


def test_compose_singular_denominator():
    # sigma_b = sigma_a / |sigma_a|^2 is the shadow of -sigma_a: the composed quaternion is -1,
    # the literal denominator vanishes, and the identity's MRP (0) is returned.
    sa = S[NZ]
    sb = sa / np.sum(sa * sa, axis=1, keepdims=True)
    out = np.asarray(compose(sa, sb))
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(out, 0.0, atol=1e-7)
    np.testing.assert_allclose(to_dcm(out), np.broadcast_to(np.eye(3), (len(sa), 3, 3)), atol=1e-7)
    # Near (not at) the singularity the literal result is kept and matches the quaternion route.
    # (Moderate |sigma_a| only: for |sigma_a| ~ 1e-8 the quaternion route itself overflows.)
    moderate = (np.linalg.norm(sa, axis=1) > 0.05) & (np.linalg.norm(sa, axis=1) < 20)
    sa, sb_near = sa[moderate], sb[moderate] * (1 + 1e-3)
    q_route = np.asarray(from_quat(quat_mul(to_quat(sa), to_quat(sb_near))))
    np.testing.assert_allclose(compose(sa, sb_near), q_route, rtol=1e-8)
    assert np.all(np.linalg.norm(q_route, axis=1) > 1)


def _exact_compose(sa, sb):
    """Schaub's addition formula in exact rational arithmetic on the float inputs."""
    a, b = [Fraction(x) for x in sa], [Fraction(x) for x in sb]
    a2, b2 = sum(x * x for x in a), sum(x * x for x in b)
    cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    den = 1 + a2 * b2 - 2 * sum(x * y for x, y in zip(a, b))
    return [float(((1 - a2) * y + (1 - b2) * x + 2 * c) / den) for x, y, c in zip(a, b, cross)]


def test_compose_is_accurate_near_a_full_turn():
    # sigma_b 1e-6 away from the shadow of -sigma_a: the composed rotation is 1e-6 short of
    # 2 pi, the literal MRP about 1e6 long, and what a controller uses is its shadow (the
    # attitude error when the body and the reference sit in different shadow sets). The
    # denominator 1 + a2 b2 - 2 a.b, ~1e-12, was computed by cancellation: relative errors up
    # to 2e-3 (in the literal result and in its shadow); now ~1e-10 (eps / 1e-6).
    rng = np.random.default_rng(7)
    sa = rng.normal(size=(N, 3))
    sa *= rng.uniform(0.2, 5.0, size=(N, 1)) / np.linalg.norm(sa, axis=1, keepdims=True)
    sb = sa / np.sum(sa * sa, axis=1, keepdims=True) + 1e-6 * rng.normal(size=(N, 3))
    got = np.asarray(compose(sa, sb))
    exact = np.array([_exact_compose(x, y) for x, y in zip(sa, sb)])
    assert np.all(np.linalg.norm(exact, axis=1) > 1e4)
    np.testing.assert_allclose(got, exact, rtol=1e-8)
    np.testing.assert_allclose(switch(got), switch(exact), rtol=1e-8, atol=1e-20)


# --- gradients ------------------------------------------------------------------------

_W3 = jnp.array([0.3, -0.2, 0.5])


def test_gradients_finite_at_identity():
    zeros = np.zeros((1, 3))
    identity = np.array([[1.0, 0.0, 0.0, 0.0]])
    g = _jv(jax.grad(lambda q: jnp.dot(_W3, rot.mrp_from_quat(q))))(identity)
    np.testing.assert_array_equal(g, [[0.0, 0.15, -0.1, 0.25]])  # d sigma / d qv = I / 2 there
    for fn in (rot.mrp_shadow, rot.mrp_switch, rot.quat_from_mrp):
        g = _jv(jax.grad(lambda s, fn=fn: jnp.sum(fn(s))))(zeros)
        assert np.all(np.isfinite(g)), fn.__name__
    g = _jv(jax.grad(lambda c: jnp.dot(_W3, rot.mrp_from_dcm(c))))(np.eye(3)[None])
    assert np.all(np.isfinite(g))
    sa = S[1:4]
    sb = sa / np.sum(sa * sa, axis=1, keepdims=True)
    g = _jv(jax.grad(lambda a, b: jnp.dot(_W3, rot.mrp_compose(a, b)), argnums=(0, 1)))(sa, sb)
    assert all(np.all(np.isfinite(x)) for x in g)


@pytest.mark.parametrize(
    "fn, args",
    [
        (rot.mrp_from_quat, (Q[1],)),
        (rot.quat_from_mrp, (S[1],)),
        (rot.mrp_shadow, (S[1],)),
        (rot.mrp_to_dcm, (S[2],)),
        (rot.mrp_from_dcm, (Rotation.from_mrp(S[3]).as_matrix(),)),
        (rot.mrp_kinematics, (S[1], W[1])),
        (rot.mrp_compose, (S[1], SP[2])),
    ],
)
def test_gradients_match_finite_differences(fn, args):
    check_grads(jax.jit(fn), tuple(jnp.asarray(a) for a in args), order=1, modes=["rev"])


# --- transformations and dtypes ---------------------------------------------------------


def test_jit_matches_eager_and_vmap_matches_loop():
    np.testing.assert_allclose(
        rot.mrp_compose(S[1], SP[1]), compose(S[1:2], SP[1:2])[0], atol=1e-15
    )
    np.testing.assert_allclose(rot.mrp_switch(S[5]), jax.jit(rot.mrp_switch)(S[5]), atol=0)
    looped = np.stack([rot.mrp_to_dcm(s) for s in S[:3]])
    np.testing.assert_allclose(to_dcm(S)[:3], looped, atol=1e-15)


_S32 = np.asarray(S[1], dtype=np.float32)
_Q32 = np.asarray(Q[1], dtype=np.float32)
_C32 = np.asarray(Rotation.from_mrp(S[1]).as_matrix(), dtype=np.float32)


@pytest.mark.parametrize(
    "fn, args",
    [
        (rot.mrp_from_quat, (_Q32,)),
        (rot.quat_from_mrp, (_S32,)),
        (rot.mrp_shadow, (_S32,)),
        (rot.mrp_switch, (_S32,)),
        (rot.mrp_to_dcm, (_S32,)),
        (rot.mrp_from_dcm, (_C32,)),
        (rot.mrp_kinematics_matrix, (_S32,)),
        (rot.mrp_kinematics, (_S32, _S32)),
        (rot.mrp_compose, (_S32, _S32)),
    ],
)
def test_float32_in_float32_out(fn, args):
    out = jax.eval_shape(fn, *args)
    assert out.dtype == jnp.float32, out
