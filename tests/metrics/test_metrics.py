"""Tests for jaxatt.metrics against closed forms, NumPy references and finite differences.

Compilation dominates the run time on CPU, so most tests share a few input shapes (the grid
`TS` of 801 samples, a 7-sample hand-built record) and module-level jitted functions.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxatt.metrics as metrics


# ----------------------------------------------------------------------------- shared set-up

H = 0.01
TS = jnp.linspace(0.0, 8.0, 801)  # uniform, step H
X0, TOL = 2.0, 1e-2
TS7 = jnp.array([0.0, 1.0, 2.0, 3.0, 4.5, 5.0, 7.0])  # non-uniform hand-built record

settling_jit = jax.jit(metrics.settling_time)
settled_jit = jax.jit(metrics.settled)
soft_jit = jax.jit(metrics.soft_settling_time)
settling_grad = jax.jit(jax.grad(metrics.settling_time, argnums=(0, 1, 2)))
soft_grad = jax.jit(jax.grad(metrics.soft_settling_time, argnums=(0, 1, 2, 3)))


def decay(k, ts=TS):
    return X0 * jnp.exp(-k * ts)


settling_of_rate = jax.jit(lambda k: metrics.settling_time(TS, decay(k), TOL))
settling_of_rate_grad = jax.jit(jax.grad(lambda k: metrics.settling_time(TS, decay(k), TOL)))


def np_settling_time(ts, x, tol):
    """Independent NumPy reference: last exit, linearly interpolated."""
    ts = np.asarray(ts, dtype=float)
    x = np.asarray(x, dtype=float)
    above = np.nonzero(x > tol)[0]
    if above.size == 0:
        return ts[0]
    k = above[-1]
    if k == x.size - 1:
        return np.inf
    return np.interp(tol, [x[k + 1], x[k]], [ts[k + 1], ts[k]])


def np_trapezoid(y, t):
    y = np.asarray(y, dtype=float)
    t = np.asarray(t, dtype=float)
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)))


def central_difference(f, p, h):
    return (float(f(p + h)) - float(f(p - h))) / (2 * h)


def all_finite(tree):
    return all(bool(jnp.all(jnp.isfinite(leaf))) for leaf in jax.tree_util.tree_leaves(tree))


# ----------------------------------------------------------------------------- settling_time


def test_settling_time_exponential_matches_interpolated_crossing():
    x = jnp.exp(-TS)
    t_s = float(settling_jit(TS, x, 1e-2))
    reference = np_settling_time(np.asarray(TS), np.exp(-np.asarray(TS)), 1e-2)
    assert t_s == pytest.approx(reference, rel=1e-13)
    # The chord of a convex exp lies above it, so the interpolated crossing is late, by at most
    # k h^2 / 8 (interpolation error h^2 k^2 x / 8 divided by the slope k x), here 1.25e-5 s.
    assert 0 < t_s - math.log(100.0) <= H**2 / 8 * (1 + 1e-6)


def test_settling_time_nonuniform_samples():
    u = np.linspace(0.0, 1.0, 801)
    ts_np = 9.0 * u**1.7  # dense early, sparse late
    x_np = 3.0 * np.exp(-0.9 * ts_np) * (1 + 0.3 * np.cos(5 * ts_np))
    t_s = float(settling_jit(jnp.asarray(ts_np), jnp.asarray(x_np), 0.02))
    assert t_s == pytest.approx(np_settling_time(ts_np, x_np, 0.02), rel=1e-13)


def test_settling_time_reentry_counts_last_exit():
    x = jnp.array([2.0, 0.5, 0.05, 0.5, 2.0, 0.05, 0.01])
    # Last sample above 0.1 is index 4 (t = 4.5, x = 2); next sample x = 0.05 at t = 5.
    expected = 4.5 + (2.0 - 0.1) / (2.0 - 0.05) * 0.5
    assert float(settling_jit(TS7, x, 0.1)) == pytest.approx(expected, rel=1e-14)
    assert bool(settled_jit(TS7, x, 0.1))
    g_ts, g_x, g_tol = settling_grad(TS7, x, 0.1)
    # d/dx4 of t4 + (x4 - tol)/(x4 - x5) dt = (tol - x5) dt / (x4 - x5)^2, etc.
    d = 2.0 - 0.05
    np.testing.assert_allclose(g_x[4], (0.1 - 0.05) * 0.5 / d**2, rtol=1e-12)
    np.testing.assert_allclose(g_x[5], (2.0 - 0.1) * 0.5 / d**2, rtol=1e-12)
    np.testing.assert_allclose(float(g_tol), -0.5 / d, rtol=1e-12)
    frac = (2.0 - 0.1) / d
    np.testing.assert_allclose(g_ts, [0, 0, 0, 0, 1 - frac, frac, 0], rtol=1e-12, atol=1e-15)


def test_settling_time_never_above_returns_first_time_with_zero_gradient():
    ts = TS7 + 1.5
    x = jnp.full(7, 0.01)
    assert float(settling_jit(ts, x, 0.1)) == 1.5
    g_ts, g_x, g_tol = settling_grad(ts, x, 0.1)
    np.testing.assert_array_equal(g_ts, np.eye(7)[0])
    np.testing.assert_array_equal(g_x, np.zeros(7))
    assert float(g_tol) == 0.0


def test_settling_time_never_settles_is_inf_with_zero_finite_gradient():
    x = 1.0 - 0.05 * TS7  # ends at 0.65 > tol
    assert float(settling_jit(TS7, x, 0.1)) == math.inf
    assert not bool(settled_jit(TS7, x, 0.1))
    grads = settling_grad(TS7, x, 0.1)
    assert all_finite(grads)
    for g in grads:
        np.testing.assert_array_equal(g, np.zeros_like(g))


def test_settling_time_single_sample_and_nonfinite_samples():
    one = jnp.array([0.0])
    assert float(settling_jit(one, jnp.array([0.5]), 0.1)) == math.inf
    assert float(settling_jit(one, jnp.array([0.05]), 0.1)) == 0.0
    # A NaN at the end means "not settled"; an inf before the band gives the next sample time.
    x_nan = jnp.array([1.0, 0.5, 0.05, 0.05, 0.05, 0.05, jnp.nan])
    assert float(settling_jit(TS7, x_nan, 0.1)) == math.inf
    assert not bool(settled_jit(TS7, x_nan, 0.1))
    x_inf = jnp.array([1.0, jnp.inf, 0.05, 0.05, 0.05, 0.05, 0.05])
    assert float(settling_jit(TS7, x_inf, 0.1)) == 2.0
    g_ts, _, g_tol = settling_grad(TS7, x_inf, 0.1)
    assert all_finite((g_ts, g_tol))


@pytest.mark.parametrize("k", [0.77, 1.3, 1.9])
def test_settling_time_gradient_in_decay_rate(k):
    grad = float(settling_of_rate_grad(k))
    # Same function, finite differences: k moves the crossing by ~1e-6 s, far less than a
    # sample step, so the index is unchanged and the two must agree to FD truncation error.
    assert grad == pytest.approx(central_difference(settling_of_rate, k, 1e-6), rel=1e-6)
    # Continuous crossing T* = ln(x0/tol)/k, dT*/dk = -ln(x0/tol)/k^2. The interpolated
    # crossing is T* + e(s), s the crossing's offset in its cell, e(s) ~ k s (h - s)/2, and
    # s slides with k at ds/dk = dT*/dk, so the relative error of the derivative is at most
    # max|de/ds| = k h / (1 - exp(-k h)) - 1 = k h/2 + O((k h)^2) (0.4-1 % here; observed
    # 0.08-0.7 %).
    analytic = -math.log(X0 / TOL) / k**2
    kh = k * H
    assert grad == pytest.approx(analytic, rel=kh / 2 * (1 + kh))
    assert float(settling_of_rate(k)) == pytest.approx(math.log(X0 / TOL) / k, abs=k * H**2 / 8)


def test_settling_time_gradient_in_tol_and_time_shift():
    k = 1.3
    x = decay(k)
    g_ts, _, g_tol = settling_grad(TS, x, TOL)
    f_tol = lambda tol: settling_jit(TS, x, tol)
    assert float(g_tol) == pytest.approx(central_difference(f_tol, TOL, 1e-9), rel=1e-6)
    # dT*/dtol = -1 / (k tol), up to the interpolation error (slope of the chord, < k h).
    assert float(g_tol) == pytest.approx(-1 / (k * TOL), rel=k * H)
    # Shifting every sample time by c shifts the settling time by c: the gradients sum to 1.
    assert float(jnp.sum(g_ts)) == pytest.approx(1.0, rel=1e-12)


def test_settling_time_gradient_finite_with_exact_zeros():
    a = 0.25
    x = jnp.maximum(1.0 - a * TS, 0.0)  # zero from t = 4 on
    # x is piecewise linear, so interpolation is exact: x = 0.1 at t = 0.9 / a = 3.6.
    assert float(settling_jit(TS, x, 0.1)) == pytest.approx(0.9 / a, rel=1e-12)
    g_ts, g_x, g_tol = settling_grad(TS, x, 0.1)
    assert all_finite((g_ts, g_x, g_tol))
    # Chain rule by hand, dx/da = -t where x > 0: d t_s / da = -0.9 / a^2 = -14.4.
    g_a = float(jnp.sum(g_x * jnp.where(x > 0, -TS, 0.0)))
    assert g_a == pytest.approx(-0.9 / a**2, rel=1e-9)
    step = jnp.where(TS < 0.5, 1.0, 0.0)
    assert all_finite(settling_grad(TS, step, 0.1))


# ----------------------------------------------------------------------------- soft settling


def softplus(z):
    return float(np.logaddexp(0.0, z))


def finite_time_signal(t_f, ts=TS):
    """(1 - t/t_f)^3 for t < t_f and exactly 0 afterwards (finite-time convergence)."""
    return jnp.maximum(1.0 - ts / t_f, 0.0) ** 3


def test_soft_settling_time_closed_form_for_exponential():
    k, w = 1.3, 0.05
    t_star = math.log(X0 / TOL) / k
    closed = w / k * (softplus(k * t_star / w) - softplus(k * (t_star - 8.0) / w))
    value = float(soft_jit(TS, decay(k), TOL, w))
    # The integrand is flat at both ends, so the trapezoid rule is spectrally accurate.
    assert value == pytest.approx(closed, rel=1e-9)


def test_soft_settling_time_approaches_settling_time_as_width_shrinks():
    x = finite_time_signal(4.0)
    t_star = 4.0 * (1.0 - 0.01 ** (1 / 3))  # continuous crossing of 1e-2
    errors = [abs(float(soft_jit(TS, x, 1e-2, w)) - t_star) for w in (0.3, 0.1, 0.05)]
    # ln x is curved at the crossing, so the bias is O(w^2): observed 1.4e-2, 1.6e-3, 3.9e-4.
    assert errors[0] > 1e-2
    assert errors[0] > 5 * errors[1] > 20 * errors[2]
    assert errors[2] < 1e-3
    assert float(settling_jit(TS, x, 1e-2)) == pytest.approx(t_star, abs=1e-4)


def test_soft_settling_time_gradient_finite_and_matches_fd():
    f = jax.jit(lambda t_f: metrics.soft_settling_time(TS, finite_time_signal(t_f), 1e-2, 0.1))
    g = float(jax.jit(jax.grad(f))(4.0))
    assert g == pytest.approx(central_difference(f, 4.0, 1e-5), rel=1e-6)
    # d t*/d t_f = 1 - 0.01^(1/3) = 0.7846 for the continuous crossing; the surrogate is close.
    assert g == pytest.approx(1 - 0.01 ** (1 / 3), rel=0.02)
    x = finite_time_signal(4.0)
    grads = soft_grad(TS, x, 1e-2, 0.1)
    assert all_finite(grads)
    assert float(jnp.sum(jnp.abs(grads[1][TS > 4.0]))) == 0.0  # exact zeros: gradient 0
    zeros = jnp.zeros_like(TS)
    assert all_finite(soft_grad(TS, zeros, 1e-2, 0.1))
    assert float(soft_jit(TS, zeros, 1e-2, 0.1)) == 0.0


def test_soft_settling_time_counts_all_time_above():
    # Above 1 on [0, 2) and [5, 6), small elsewhere: last exit at 6, time above 3.
    x = jnp.where((TS < 2.0 - H / 2) | ((TS > 5.0 - H / 2) & (TS < 6.0 - H / 2)), 10.0, 0.01)
    assert float(soft_jit(TS, x, 1.0, 0.01)) == pytest.approx(3.0, abs=H)
    assert float(settling_jit(TS, x, 1.0)) == pytest.approx(6.0, abs=H)


# ----------------------------------------------------------------------------- itae / iae


def test_itae_iae_against_numpy_and_closed_form():
    rng = np.random.default_rng(0)
    ts_np = np.sort(rng.uniform(0.0, 12.0, 801))
    ts_np[0] = 0.0
    x_np = np.exp(-ts_np) * np.cos(3 * ts_np)
    ts, x = jnp.asarray(ts_np), jnp.asarray(x_np)
    itae, iae = jax.jit(metrics.itae), jax.jit(metrics.iae)
    assert float(iae(ts, x)) == pytest.approx(np_trapezoid(np.abs(x_np), ts_np), rel=1e-12)
    assert float(itae(ts, x)) == pytest.approx(np_trapezoid(ts_np * np.abs(x_np), ts_np), rel=1e-12)
    # Closed forms on [0, 8]: int t e^-t = 1 - 9 e^-8, int e^-t = 1 - e^-8. Trapezoid error
    # h^2/12 |f'(8) - f'(0)| <= h^2/12 (8.3e-6 here).
    e = jnp.exp(-TS)
    assert float(itae(TS, e)) == pytest.approx(1 - 9 * math.exp(-8), abs=H**2 / 12 * 1.01)
    assert float(iae(TS, e)) == pytest.approx(1 - math.exp(-8), abs=H**2 / 12 * 1.01)
    # ITAE weights time since the first sample: invariant to the time origin.
    assert float(itae(ts + 100.0, x)) == pytest.approx(float(itae(ts, x)), rel=1e-9)


# ----------------------------------------------------------------------------- overshoot


def step_error(zeta, omega, ts):
    """Error of a 2nd-order step response; first undershoot at pi/omega_d, exp(-zeta pi/sqrt)."""
    omega_d = omega * jnp.sqrt(1 - zeta**2)
    c = zeta / jnp.sqrt(1 - zeta**2)
    return jnp.exp(-zeta * omega * ts) * (jnp.cos(omega_d * ts) + c * jnp.sin(omega_d * ts))


def overshoot_grid(zeta, omega):
    """400 uniform samples plus the first undershoot time; `overshoot` ignores sample order."""
    t_peak = jnp.pi / (omega * jnp.sqrt(1 - zeta**2))
    return jnp.concatenate([jnp.linspace(0.0, 10.0, 400), t_peak[None]])


def test_overshoot_damped_oscillation_closed_form():
    zeta, omega = 0.3, 2.0
    ts = overshoot_grid(jnp.asarray(zeta), omega)
    e = step_error(zeta, omega, ts)
    x = jnp.stack(
        [
            e,  # positive start
            -3.0 * e,  # negative start, same relative overshoot
            jnp.zeros_like(ts),  # starts (and stays) at 0 -> 0
            jnp.exp(-ts),  # never crosses zero -> 0
            jnp.exp(-zeta * omega * ts) * jnp.cos(omega * jnp.sqrt(1 - zeta**2) * ts),
        ],
        axis=-1,
    )
    expected_classic = math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))  # 0.3723
    # exp(-z w t) cos(w_d t): extreme at w_d t1 = pi - atan(z w / w_d), value -exp(-z w t1) w_d/w.
    omega_d = omega * math.sqrt(1 - zeta**2)
    t1 = (math.pi - math.atan(zeta * omega / omega_d)) / omega_d
    expected_cos = math.exp(-zeta * omega * t1) * math.sqrt(1 - zeta**2)
    m = np.asarray(jax.jit(metrics.overshoot)(x))
    np.testing.assert_allclose(m[:4], [expected_classic, expected_classic, 0.0, 0.0], rtol=1e-12)
    # t1 is not on the grid: the sampled max is low by at most |x''| (dt/2)^2 / 2 ~ 1.3e-4.
    assert expected_cos - 2e-4 <= m[4] <= expected_cos


def test_overshoot_gradient_matches_closed_form_and_is_finite_at_zero_start():
    omega = 2.0

    def f(zeta):
        ts = overshoot_grid(zeta, omega)
        return metrics.overshoot(step_error(zeta, omega, ts)[:, None])[0]

    zeta = 0.3
    # d/dzeta exp(-zeta pi / sqrt(1 - zeta^2)) = -pi (1 - zeta^2)^(-3/2) exp(...); the sample
    # sits on the extremum (x' = 0 there), so the moving grid point adds nothing.
    analytic = -math.pi * (1 - zeta**2) ** -1.5 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))
    assert float(jax.jit(jax.grad(f))(zeta)) == pytest.approx(analytic, rel=1e-8)
    x = jnp.zeros((5, 2)).at[1:, 1].set(-0.1).at[:, 0].set(jnp.array([1.0, 0.2, -0.3, 0.1, 0.0]))
    g = jax.jit(jax.grad(lambda x: jnp.sum(metrics.overshoot(x))))(x)
    assert all_finite(g)
    np.testing.assert_array_equal(g[:, 1], np.zeros(5))  # x0 = 0 component: gradient 0
    # Component 0: 0.3 / x0 -> d/dx[2] = -1 / x0 = -1, d/dx[0] = -0.3 / x0^2 = -0.3.
    np.testing.assert_allclose(g[:, 0], [-0.3, 0.0, -1.0, 0.0, 0.0], rtol=1e-12)


# ----------------------------------------------------------------------------- effort, chattering


@pytest.fixture(scope="module")
def control_record():
    rng = np.random.default_rng(1)
    ts = np.sort(rng.uniform(0.0, 5.0, 60))
    u = rng.normal(size=(60, 3))
    return ts, u


def test_control_effort_against_numpy(control_record):
    ts, u = control_record
    expected = np_trapezoid(np.sum(u**2, axis=1), ts)
    effort = jax.jit(metrics.control_effort)
    assert float(effort(jnp.asarray(ts), jnp.asarray(u))) == pytest.approx(expected, rel=1e-12)
    # Constant torque [0.1, 0.2, 0.2] N m for 5 s: 0.09 * 5 = 0.45 N^2 m^2 s.
    const = jnp.tile(jnp.array([0.1, 0.2, 0.2]), (60, 1))
    assert float(effort(jnp.asarray(ts) - ts[0], const)) == pytest.approx(
        0.09 * (ts[-1] - ts[0]), rel=1e-12
    )


def np_chattering(ts, u, t_start, t_end):
    total = 0.0
    for k in range(len(ts) - 1):
        if ts[k] >= t_start and ts[k + 1] <= t_end:
            total += np.sum(np.abs(u[k + 1] - u[k]))
    return total


@pytest.fixture(scope="module")
def chattering_jit():
    return jax.jit(metrics.chattering)


@pytest.mark.parametrize("window", [(None, None), (1.0, 4.0), (2.5, 2.6), (4.9, 10.0)])
def test_chattering_against_numpy_and_jit(control_record, chattering_jit, window):
    ts, u = control_record
    t_start, t_end = window
    expected = np_chattering(
        ts, u, -np.inf if t_start is None else t_start, np.inf if t_end is None else t_end
    )
    # Window bounds traced: one compilation serves every window (None is static: a second).
    value = float(chattering_jit(jnp.asarray(ts), jnp.asarray(u), t_start, t_end))
    assert value == pytest.approx(expected, rel=1e-12, abs=1e-15)


def test_chattering_of_switching_signal_and_gradient(chattering_jit):
    # 0.3 sign(sin(2 pi t + 0.1)) changes sign at t = (m pi - 0.1) / (2 pi), m = 1..16, all
    # strictly between samples: 16 jumps of 2 * 0.3 each; inside [1, 7] the jumps m = 3..14.
    u = 0.3 * jnp.sign(jnp.sin(2 * jnp.pi * TS + 0.1))[:, None]
    assert float(chattering_jit(TS, u, 0.0, 8.0)) == pytest.approx(16 * 0.6, rel=1e-12)
    assert float(chattering_jit(TS, u, 1.0, 7.0)) == pytest.approx(12 * 0.6, rel=1e-12)
    g = jax.jit(jax.grad(metrics.chattering, argnums=(1, 2, 3)))(TS, u, 1.0, 7.0)
    assert all_finite(g)
    assert float(g[1]) == 0.0 and float(g[2]) == 0.0


def test_chattering_window_ends_tolerate_the_rounding_of_save_times(chattering_jit):
    # Save times t0 + i dt: 0 + 70 * 0.01 = 0.7000000000000001, one ulp above t1 = 0.7, and
    # 0 + 11 * 0.03 = 0.32999999999999996, one ulp below 0.33. Each record's only increment is
    # in the interval touching that sample; a window with the bound at the intended time keeps it.
    ts = 0.0 + jnp.arange(71) * 1e-2
    assert float(ts[-1]) > 0.7
    u = jnp.zeros((71, 1)).at[-1, 0].set(1.0)
    assert float(chattering_jit(ts, u, 0.35, 0.7)) == 1.0
    ts = 0.0 + jnp.arange(13) * 0.03
    assert float(ts[11]) < 0.33
    u = jnp.zeros((13, 1)).at[-1, 0].set(1.0)
    assert float(chattering_jit(ts, u, 0.33, 0.36)) == 1.0
    # A sample further off than a few ulps is still outside.
    assert float(chattering_jit(ts, u, 0.33 + 1e-12, 0.36)) == 0.0


# ----------------------------------------------------------------------------- peak, constraints


@jax.jit
def _peaks_and_constraints(x, bound):
    return {
        "peak": metrics.peak(x),
        "peak_per_axis": metrics.peak_per_axis(x),
        "max_abs": metrics.max_abs(x),
        "margin_0.6": metrics.constraint_margin(x, 0.6),
        "margin_0.4": metrics.constraint_margin(x, 0.4),
        "violated_0.6": metrics.constraint_violated(x, 0.6),
        "violated_0.5": metrics.constraint_violated(x, 0.5),
        "margin_vec": metrics.constraint_margin(x, bound),
        "violated_vec": metrics.constraint_violated(x, bound),
        "violated_nan": metrics.constraint_violated(x.at[1, 1].set(jnp.nan), 10.0),
        "grad": jax.grad(metrics.constraint_margin, argnums=(0, 1))(x, bound),
    }


def test_peak_and_constraints():
    x = jnp.array([[0.1, -0.5], [0.3, 0.2], [-0.25, 0.4]])
    r = _peaks_and_constraints(x, jnp.array([0.35, 1.0]))
    assert float(r["peak"]) == 0.5
    np.testing.assert_array_equal(r["peak_per_axis"], [0.3, 0.5])
    np.testing.assert_array_equal(r["max_abs"], [0.3, 0.5])
    assert float(r["margin_0.6"]) == pytest.approx(0.1, rel=1e-12)
    assert float(r["margin_0.4"]) == pytest.approx(-0.1, rel=1e-12)
    assert not bool(r["violated_0.6"])
    assert bool(r["violated_0.5"])  # touching the bound counts
    # Per-component bounds: margins [0.35 - 0.3, 1.0 - 0.5] -> 0.05.
    assert float(r["margin_vec"]) == pytest.approx(0.05, rel=1e-12)
    assert not bool(r["violated_vec"])
    assert bool(r["violated_nan"])  # NaN counts as a violation
    g_x, g_bound = r["grad"]
    np.testing.assert_array_equal(g_x, [[0.0, 0.0], [-1.0, 0.0], [0.0, 0.0]])
    np.testing.assert_array_equal(g_bound, [1.0, 0.0])


# ----------------------------------------------------------------------------- jit, vmap, dtype


def _all_metrics(ts, x, u):
    return {
        "settling_time": metrics.settling_time(ts, x, 0.05),
        "settled": metrics.settled(ts, x, 0.05),
        "soft_settling_time": metrics.soft_settling_time(ts, x, 0.05, 0.2),
        "itae": metrics.itae(ts, x),
        "iae": metrics.iae(ts, x),
        "overshoot": metrics.overshoot(u),
        "control_effort": metrics.control_effort(ts, u),
        "chattering": metrics.chattering(ts, u, 0.5, 2.5),
        "peak": metrics.peak(u),
        "peak_per_axis": metrics.peak_per_axis(u),
        "constraint_margin": metrics.constraint_margin(u, 2.0),
        "constraint_violated": metrics.constraint_violated(u, 2.0),
        "max_abs": metrics.max_abs(u),
    }


def test_jit_equals_eager_and_vmap_equals_loop():
    ts = TS7
    rates = jnp.array([0.2, 1.0, 2.0])  # 0.2: never settles within 7 s (e^-1.4 > 0.05)
    xs = jnp.exp(-rates[:, None] * ts[None, :])
    us = jnp.stack([jnp.stack([x * jnp.cos(5 * ts), -x], axis=-1) for x in xs])
    jitted = jax.jit(_all_metrics)
    batched = jax.jit(jax.vmap(_all_metrics, in_axes=(None, 0, 0)))(ts, xs, us)
    assert not bool(batched["settled"][0]) and bool(jnp.all(batched["settled"][1:]))
    assert float(batched["settling_time"][0]) == math.inf
    for i in range(xs.shape[0]):
        compiled = jitted(ts, xs[i], us[i])
        # Eager (op-by-op) dispatch is slow to warm up: once for a settled and an unsettled run.
        eager = _all_metrics(ts, xs[i], us[i]) if i < 2 else compiled
        for name, value in eager.items():
            np.testing.assert_allclose(compiled[name], value, rtol=1e-13, err_msg=name)
            np.testing.assert_allclose(batched[name][i], value, rtol=1e-13, err_msg=name)


def test_vmapped_settling_gradient_equals_loop():
    rates = jnp.array([0.8, 1.3, 1.9])
    batched = jax.jit(jax.vmap(jax.grad(lambda k: metrics.settling_time(TS, decay(k), TOL))))(rates)
    looped = [float(settling_of_rate_grad(k)) for k in rates]
    np.testing.assert_allclose(batched, looped, rtol=1e-13)


def test_float32_inputs_give_float32_outputs():
    ts = TS.astype(jnp.float32)
    x = jnp.exp(-ts)
    t_s = settling_jit(ts, x, 1e-2)
    soft = soft_jit(ts, x, 1e-2, 0.1)
    assert t_s.dtype == jnp.float32 and soft.dtype == jnp.float32
    assert float(t_s) == pytest.approx(math.log(100.0), abs=1e-4)
    assert all_finite(soft_grad(ts, x.at[-5:].set(0), 1e-2, 0.1))


# ----------------------------------------------------------------------------- validation


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize(
    ("call", "match"),
    [
        (
            lambda: metrics.settling_time(jnp.arange(4.0), jnp.ones((4, 3)), 0.1),
            "settling_time: `x`",
        ),
        (lambda: metrics.settling_time(jnp.arange(5.0), jnp.ones(4), 0.1), "`ts` and `x`"),
        (lambda: metrics.settling_time(jnp.ones((4, 1)), jnp.ones(4), 0.1), "`ts` must be 1-D"),
        (
            lambda: metrics.settling_time(jnp.arange(4.0), jnp.ones(4), 0.0),
            "`tol` must be positive",
        ),
        (lambda: metrics.settling_time(jnp.zeros(0), jnp.zeros(0), 0.1), "`x` must hold at least"),
        (lambda: metrics.settled(jnp.arange(4.0), jnp.ones(4), -1.0), "settled: `tol`"),
        (
            lambda: metrics.settling_time(jnp.array([0.0, 2.0, 1.0]), jnp.ones(3), 0.1),
            "`ts` must be non-decreasing",
        ),
        (
            lambda: metrics.settling_time(jnp.array([0.0, jnp.nan, 2.0]), jnp.ones(3), 0.1),
            r"settling_time: `ts` must not hold NaN .*index 1",
        ),
        (
            lambda: metrics.iae(jnp.array([0.0, 1.0, jnp.nan]), jnp.ones(3)),
            r"iae: `ts` must not hold NaN",
        ),
        (
            lambda: metrics.soft_settling_time(jnp.arange(4.0), jnp.ones(4), 0.1, width=0.0),
            "`width` must be positive",
        ),
        (lambda: metrics.itae(jnp.arange(4.0), jnp.ones((4, 2))), "itae: `x`"),
        (lambda: metrics.iae(jnp.arange(3.0), jnp.ones(4)), "iae: `ts` and `x`"),
        (lambda: metrics.overshoot(jnp.ones(4)), r"overshoot: `x` must be 2-D.*x\[:, None\]"),
        (lambda: metrics.control_effort(jnp.arange(4.0), jnp.ones(4)), "control_effort: `u`"),
        (lambda: metrics.chattering(jnp.arange(4.0), jnp.ones((3, 2))), "`ts` and `u`"),
        (
            lambda: metrics.chattering(jnp.arange(4.0), jnp.ones((4, 2)), 3.0, 1.0),
            r"chattering: `t_start` must be less than `t_end`, got t_start=3.0 and t_end=1.0\.",
        ),
        (
            lambda: metrics.chattering(jnp.arange(4.0), jnp.ones((4, 2)), 1.0, 1.0),
            "`t_start` must be less than `t_end`",
        ),
        (
            lambda: metrics.chattering(jnp.arange(4.0), jnp.ones((4, 2)), math.nan, 1.0),
            "chattering: `t_start` must not be NaN",
        ),
        (
            lambda: metrics.chattering(jnp.arange(4.0), jnp.ones((4, 2)), None, math.nan),
            "chattering: `t_end` must not be NaN",
        ),
        (
            lambda: metrics.chattering(jnp.arange(4.0), jnp.ones((4, 2)), jnp.zeros(2), 1.0),
            r"chattering: `t_start` must be a scalar, got shape \(2,\)",
        ),
        (
            lambda: metrics.settling_time(jnp.arange(4.0), jnp.ones(4), jnp.ones(3)),
            r"settling_time: `tol` must be a scalar, got shape \(3,\)\.",
        ),
        (
            lambda: metrics.convergence_time(jnp.arange(4.0), jnp.ones(4), jnp.ones(3)),
            r"convergence_time: `tol` must be a scalar, got shape \(3,\)\.",
        ),
        (
            lambda: metrics.convergence_time(jnp.arange(4.0), jnp.ones(4), 0.1, jnp.ones(2)),
            r"convergence_time: `window` must be a scalar, got shape \(2,\)\.",
        ),
        (lambda: metrics.peak(jnp.ones(3)), "peak: `u`"),
        (lambda: metrics.peak_per_axis(jnp.ones((2, 2, 2))), "peak_per_axis: `u`"),
        (lambda: metrics.max_abs(jnp.ones(3)), "max_abs: `x`"),
        (lambda: metrics.constraint_margin(jnp.ones((3, 2)), -1.0), "`bound` must be positive"),
        (
            lambda: metrics.constraint_violated(jnp.ones((3, 2)), jnp.ones(3)),
            "constraint_violated: `bound` must be a scalar or have one entry per component",
        ),
    ],
)
def test_value_errors_name_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_shape_misuse_rejected_under_type_checking():
    # With the jaxtyping hook active (the test suite's default) the annotation rejects it first.
    # (The library's own ValueError is checked above, with the hook off.)
    with pytest.raises(TypeError, match="typechecking parameter 'x'"):
        metrics.settling_time(jnp.arange(4.0), jnp.ones((4, 3)), 0.1)


def test_traced_nonpositive_tol_fails_at_run_time():
    f = jax.jit(lambda tol: metrics.settling_time(TS7, jnp.ones(7), tol))
    assert float(f(2.0)) == 0.0
    with pytest.raises(Exception, match="`tol` must be positive"):
        f(-0.01).block_until_ready()
