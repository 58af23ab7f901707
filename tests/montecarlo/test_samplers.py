"""Samplers: distributions against closed forms (KS bounds), reproducibility, argument errors.

Statistical tolerances: for n draws, the Kolmogorov-Smirnov statistic sup|F_n - F| exceeds
1.95 / sqrt(n) with probability about 1e-3 under the hypothesis, and a sample mean strays more
than 5 standard errors with probability below 1e-6. The keys are fixed, so each test is
deterministic; the bounds say how unlikely a correct sampler is to fail them with another key.
"""

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest

from jaxatt import montecarlo as mc
from jaxatt.plants import Sinusoid
from jaxatt.rotations import quat_angle, quat_conjugate, quat_multiply, quat_to_dcm

from ..helpers import J0, Q0


N = 8_000  # one batch size everywhere, so that each sampler compiles once in this module
KS = 1.95


def ks_statistic(samples, cdf) -> float:
    x = np.sort(np.asarray(samples))
    f = cdf(x)
    n = x.size
    return float(max(np.max(np.arange(1, n + 1) / n - f), np.max(f - np.arange(n) / n)))


def haar_angle_cdf(theta, max_angle=np.pi):
    return (theta - np.sin(theta)) / (max_angle - np.sin(max_angle))


@jax.jit
def _angles_from(nominal, q):
    return jax.vmap(lambda p: quat_angle(quat_multiply(quat_conjugate(nominal), p)))(q)


def angles_from(nominal, q):
    return np.asarray(_angles_from(nominal, q))


def test_uniform_attitudes_are_haar_uniform():
    q = np.asarray(mc.uniform_attitudes(jr.key(1), N))
    assert q.shape == (N, 4)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-14)
    assert np.all(q[:, 0] >= 0)
    angles = 2 * np.arccos(np.clip(q[:, 0], -1, 1))
    assert ks_statistic(angles, haar_angle_cdf) < KS / np.sqrt(N)
    # Uniform on S^3: E[q_i] = 0 for the vector part (the canonical sign only flips q0's
    # sign, which is symmetric for q_1..q_3) and E[q q^T] = I / 4 (sign-invariant).
    standard_error = 0.5 / np.sqrt(N)
    assert np.all(np.abs(q[:, 1:].mean(axis=0)) < 5 * standard_error)
    second = q.T @ q / N
    # Var(q_i q_j) <= E[q_i^2 q_j^2] <= 1/8 for the uniform sphere in 4-D.
    assert np.max(np.abs(second - np.eye(4) / 4)) < 5 * np.sqrt(1 / 8 / N)


@pytest.mark.parametrize("max_angle", [np.pi / 3, 2.5, np.pi, 1e-3])
def test_attitudes_within_match_restricted_haar_cdf(max_angle):
    nominal = jnp.asarray(Q0)
    q = mc.attitudes_within(jr.key(2), N, max_angle, nominal)
    np.testing.assert_allclose(np.linalg.norm(np.asarray(q), axis=1), 1.0, atol=1e-14)
    angles = angles_from(nominal, q)
    assert np.max(angles) <= max_angle * (1 + 1e-12)
    statistic = ks_statistic(angles, lambda t: haar_angle_cdf(t, max_angle))
    assert statistic < KS / np.sqrt(N)
    # Axis uniform on the sphere: mean axis ~ 0 (each component has variance 1/3).
    e = np.asarray(jax.vmap(lambda p: quat_multiply(quat_conjugate(nominal), p))(q))
    axes = e[:, 1:] / np.linalg.norm(e[:, 1:], axis=1, keepdims=True)
    assert np.all(np.abs(axes.mean(axis=0)) < 5 * np.sqrt(1 / 3 / N))


def test_attitudes_within_default_nominal_is_identity_and_reaches_the_edge():
    q = mc.attitudes_within(jr.key(3), N, 0.5)
    angles = angles_from(jnp.array([1.0, 0, 0, 0]), q)
    assert np.max(angles) <= 0.5 + 1e-12
    # P(theta < 0.49) = F(0.49) ~ 0.94, so the largest of N draws exceeds 0.49 surely.
    assert np.max(angles) > 0.49
    # Proper rotations (det +1), never reflections.
    dets = np.linalg.det(np.asarray(jax.vmap(quat_to_dcm)(q[:100])))
    np.testing.assert_allclose(dets, 1.0, atol=1e-12)


def test_attitudes_within_keeps_float32():
    q = mc.attitudes_within(jr.key(3), N, jnp.float32(1.0))
    assert q.dtype == jnp.float32
    assert np.max(angles_from(jnp.array([1.0, 0, 0, 0], jnp.float32), q)) <= 1.0 + 1e-6


def test_rates_in_box_uniform_within_bounds():
    bound = np.array([0.05, 0.1, 0.2])
    w = np.asarray(mc.rates_in_box(jr.key(4), N, jnp.asarray(bound)))
    assert w.shape == (N, 3)
    assert np.all(np.abs(w) <= bound)
    for i in range(3):
        cdf = lambda x, b=bound[i]: (x + b) / (2 * b)
        assert ks_statistic(w[:, i], cdf) < KS / np.sqrt(N)
    scalar = np.asarray(mc.rates_in_box(jr.key(4), N, 0.05))
    assert np.all(np.abs(scalar) <= 0.05)


def test_rates_in_ball_uniform_in_the_ball():
    radius = 0.05
    w = np.asarray(mc.rates_in_ball(jr.key(5), N, radius))
    norms = np.linalg.norm(w, axis=1)
    assert np.all(norms <= radius * (1 + 1e-12))
    assert ks_statistic(norms, lambda r: (r / radius) ** 3) < KS / np.sqrt(N)
    directions = w / norms[:, None]
    assert np.all(np.abs(directions.mean(axis=0)) < 5 * np.sqrt(1 / 3 / N))


def test_inertia_dispersion_is_spd_and_within_stated_bounds():
    scale, misalignment, n = 0.05, 0.2, N
    js = np.asarray(
        mc.inertia_dispersion(
            jr.key(6), n, jnp.asarray(J0), principal_scale=scale, max_misalignment=misalignment
        )
    )
    assert js.shape == (n, 3, 3)
    np.testing.assert_array_equal(js, np.swapaxes(js, 1, 2))
    moments0, axes0 = np.linalg.eigh(J0)
    moments, axes = np.linalg.eigh(js)
    assert np.all(moments > 0)
    # Sorted eigenvalues stay within the sorted bounds (order statistics of interval draws).
    assert np.all(moments >= (1 - scale) * moments0 * (1 - 1e-12))
    assert np.all(moments <= (1 + scale) * moments0 * (1 + 1e-12))
    # J0's moments (14.27, 17.00, 20.74) scaled by 1 +- 0.05 cannot change order (14.98 <
    # 16.15, 17.85 < 19.70), so delta_i = lambda_i / lambda0_i - 1 is uniform on [-s, s].
    for i in range(3):
        delta = moments[:, i] / moments0[i] - 1
        assert ks_statistic(delta, lambda d: (d + scale) / (2 * scale)) < KS / np.sqrt(n)
    # Each principal axis moves by at most the misalignment, and some get close to it.
    cosines = np.abs(np.einsum("ji,nji->ni", axes0, axes))
    angles = np.arccos(np.clip(cosines, -1, 1))
    assert np.max(angles) <= misalignment + 1e-9
    assert np.max(angles) > 0.9 * misalignment


def test_inertia_dispersion_without_misalignment_keeps_the_axes():
    js = np.asarray(
        mc.inertia_dispersion(
            jr.key(7), N, jnp.asarray(J0), principal_scale=0.3, max_misalignment=0.0
        )
    )
    _, axes0 = np.linalg.eigh(J0)
    rotated = np.einsum("ji,njk,kl->nil", axes0, js, axes0)  # V^T J V is diagonal
    off_diagonal = rotated - np.einsum("nii->ni", rotated)[:, :, None] * np.eye(3)
    assert np.max(np.abs(off_diagonal)) < 1e-12


def test_sinusoid_dispersion_ranges_and_evaluation():
    signal = Sinusoid(jnp.array([0.1, 0.2, 0.3]), jnp.array([0.1, 0.2, 0.3]))
    n, scale, spread = N, 0.5, np.pi
    batch = mc.sinusoid_dispersion(jr.key(8), n, signal, amplitude_scale=scale, phase_spread=spread)
    assert isinstance(batch, Sinusoid)
    for field in (batch.amplitude, batch.frequency, batch.phase, batch.offset):
        assert field.shape == (n, 3)
    ratio = np.asarray(batch.amplitude) / np.array([0.1, 0.2, 0.3])
    assert np.all(np.abs(ratio - 1) <= scale * (1 + 1e-12))
    assert ks_statistic(ratio[:, 0], lambda r: (r - 1 + scale) / (2 * scale)) < KS / np.sqrt(n)
    assert np.all(np.abs(np.asarray(batch.phase)) <= spread)
    np.testing.assert_array_equal(np.asarray(batch.frequency[5]), [0.1, 0.2, 0.3])
    values = jax.vmap(lambda s: s(2.0))(batch)
    expected = np.asarray(batch.amplitude) * np.sin(
        0.1 * np.arange(1, 4) * 2.0 + np.asarray(batch.phase)
    )
    np.testing.assert_allclose(values, expected, rtol=1e-12, atol=1e-15)


def test_sinusoid_dispersion_keeps_zero_amplitudes_zero():
    perturbation = Sinusoid(jnp.diag(jnp.array([1.0, 2, 3])), jnp.diag(jnp.array([0.1, 0.2, 0.3])))
    batch = mc.sinusoid_dispersion(
        jr.key(9), N, perturbation, amplitude_scale=0.2, phase_spread=0.5
    )
    assert batch.amplitude.shape == (N, 3, 3)
    off = np.asarray(batch.amplitude) * (1 - np.eye(3))
    np.testing.assert_array_equal(off, 0.0)


SAMPLERS = {
    "uniform_attitudes": lambda key: mc.uniform_attitudes(key, N),
    "attitudes_within": lambda key: mc.attitudes_within(key, N, 1.0),
    "rates_in_box": lambda key: mc.rates_in_box(key, N, 0.1),
    "rates_in_ball": lambda key: mc.rates_in_ball(key, N, 0.1),
    "inertia_dispersion": lambda key: mc.inertia_dispersion(
        key, N, jnp.asarray(J0), principal_scale=0.1, max_misalignment=0.1
    ),
    "sinusoid_dispersion": lambda key: mc.sinusoid_dispersion(
        key, N, Sinusoid(jnp.ones(3), jnp.ones(3)), amplitude_scale=0.1, phase_spread=0.1
    ),
}


@pytest.mark.parametrize("name", SAMPLERS)
def test_same_key_same_draws_different_key_different_draws(name):
    sample = SAMPLERS[name]
    a = jax.tree.leaves(sample(jr.key(10)))
    b = jax.tree.leaves(sample(jr.key(10)))
    c = jax.tree.leaves(sample(jr.key(11)))
    for x, y in zip(a, b):
        assert x.shape[0] == N
        np.testing.assert_array_equal(x, y)
    assert any(not np.array_equal(x, z) for x, z in zip(a, c))


@pytest.mark.parametrize("name", SAMPLERS)
def test_samplers_trace_under_jit(name):
    # Tracing is what jit needs (no Python control flow on values); one compiled comparison
    # below checks that a jitted sampler draws the same numbers.
    jaxpr = jax.make_jaxpr(SAMPLERS[name])(jr.key(10))
    assert len(jaxpr.eqns) > 0


def test_jitted_sampler_draws_the_same_numbers():
    draw = jax.jit(lambda key, max_angle: mc.attitudes_within(key, N, max_angle))
    np.testing.assert_allclose(
        draw(jr.key(13), 1.0), mc.attitudes_within(jr.key(13), N, 1.0), rtol=1e-13, atol=1e-15
    )


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: mc.uniform_attitudes(jr.key(0), 0), "n"),
        (lambda: mc.attitudes_within(jr.key(0), 3, 0.0), "max_angle"),
        (lambda: mc.attitudes_within(jr.key(0), 3, 3.2), "max_angle"),
        (lambda: mc.attitudes_within(jr.key(0), 3, float("nan")), "max_angle"),
        (lambda: mc.attitudes_within(jr.key(0), 3, 1.0, jnp.array([1.0, 1, 0, 0])), "nominal"),
        (lambda: mc.rates_in_box(jr.key(0), 3, -0.1), "max_rate"),
        (lambda: mc.rates_in_ball(jr.key(0), 3, -1.0), "max_norm"),
        (
            lambda: mc.inertia_dispersion(
                jr.key(0), 3, jnp.asarray(J0), principal_scale=1.0, max_misalignment=0.1
            ),
            "principal_scale",
        ),
        (
            lambda: mc.inertia_dispersion(
                jr.key(0), 3, jnp.asarray(J0), principal_scale=0.1, max_misalignment=4.0
            ),
            "max_misalignment",
        ),
        (
            lambda: mc.inertia_dispersion(
                jr.key(0), 3, -jnp.eye(3), principal_scale=0.1, max_misalignment=0.1
            ),
            "inertia",
        ),
        (
            lambda: mc.sinusoid_dispersion(
                jr.key(0), 3, Sinusoid(1.0, 1.0), amplitude_scale=-0.1, phase_spread=0.1
            ),
            "amplitude_scale",
        ),
        # Documented M > 0 and p > 0: zero gave all-zero rates (review, 2026-12-05).
        (
            lambda: mc.rates_with_barrier_ratio(
                jr.key(0), 3, rate_limit=0.1, exponent=0.0, max_ratio=0.9
            ),
            "exponent",
        ),
        (
            lambda: mc.rates_with_barrier_ratio(
                jr.key(0), 3, rate_limit=0.0, exponent=1.5, max_ratio=0.9
            ),
            "rate_limit",
        ),
        (
            lambda: mc.barrier_states(
                jr.key(0), 3, max_sigma=0.5, rate_limit=0.1, exponent=0.0, max_ratio=0.9
            ),
            "exponent",
        ),
        # Regression (audit): documented > 0, a radius of 0 gave every draw the identity.
        (lambda: mc.mrps_in_ball(jr.key(0), 3, 0.0), "max_norm"),
        (
            lambda: mc.barrier_states(
                jr.key(0), 3, max_sigma=0.0, rate_limit=0.1, exponent=1.5, max_ratio=0.9
            ),
            "max_sigma",
        ),
    ],
)
def test_bad_arguments_raise_value_error_naming_them(call, name):
    with pytest.raises(ValueError, match=f"`{name}`"):
        call()


def test_wrong_types_are_rejected(no_jaxtyping):
    # What a user (no runtime type checker) meets: the samplers' own ValueErrors. Under the
    # suite's jaxtyping hook the annotations refused these first, so the samplers' checks were
    # never reached, and `match="n"` matched any message with an "n" in it.
    with pytest.raises(ValueError, match=r"uniform_attitudes: `n` must be a positive Python int"):
        mc.uniform_attitudes(jr.key(0), 2.5)
    with pytest.raises(ValueError, match="`signal` must be a jaxatt.plants.Sinusoid, got Array"):
        mc.sinusoid_dispersion(jr.key(0), 3, jnp.ones(3), amplitude_scale=0.1, phase_spread=0.1)
    with pytest.raises(ValueError, match=r"`max_rate` must have one of the shapes .*\(2,\)"):
        mc.rates_in_box(jr.key(0), 3, jnp.ones(2))


def test_a_barrier_ratio_must_be_one_number(no_jaxtyping):
    # Regression (audit): a ratio per axis broadcast against the draws and scaled each axis by
    # its own ratio, a law other than the documented one, with no error.
    ratios = jnp.array([0.5, 0.5, 0.9])
    with pytest.raises(ValueError, match="`max_ratio` must be a scalar"):
        mc.rates_with_barrier_ratio(jr.key(0), 3, rate_limit=0.1, exponent=1.5, max_ratio=ratios)
    with pytest.raises(ValueError, match="`max_ratio` must be a scalar"):
        mc.barrier_states(
            jr.key(0), 3, max_sigma=0.5, rate_limit=0.1, exponent=1.5, max_ratio=ratios
        )
