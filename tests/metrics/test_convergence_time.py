"""The convergence time a tuner can trust (`time_outside`, `convergence_time`), the metric
objects, and `moving_average`.

Oracles: closed forms of exponentials (crossing times, interpolation bias), and central
finite differences of the same function for gradients (agreement to ~1e-8 relative, the
rounding of a 1e-6 step; 1e-6 leaves margin).
"""

from types import SimpleNamespace

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt import metrics
from jaxatt.metrics import (
    Absolute,
    Chattering,
    ConvergenceTime,
    Effort,
    Euclidean,
    Final,
    MaxAbs,
    Peak,
    SettlingTime,
    TimeOutside,
    convergence_time,
    moving_average,
    settling_time,
    time_outside,
)
from jaxatt.simulation import Trajectory


TOL = 1e-3
TS = jnp.linspace(0.0, 10.0, 2001)  # 5 ms samples


def _bumped(amplitude):
    """A decay that settles at 3.45 s, then a late bump of the given height near t = 6 s."""
    decay = jnp.exp(-2.0 * TS)
    bump = amplitude * jnp.exp(-(((TS - 6.0) / 0.05) ** 2))
    return decay + bump


@jax.jit
def _both(x):
    return settling_time(TS, x, TOL), convergence_time(TS, x, TOL)


def test_a_late_bump_adds_its_duration_instead_of_jumping_the_result():
    # The measurement: a bump of 0.99e-3 leaves the last exit at 3.45 s; 1.01e-3
    # moves it to 6.02 s. The convergence time moves by the bump's time above the band only.
    below, below_c = (float(v) for v in _both(_bumped(0.99e-3)))
    above, above_c = (float(v) for v in _both(_bumped(1.01e-3)))
    assert below == pytest.approx(np.log(1 / TOL) / 2, abs=1e-4)  # 3.4539 s
    assert 6.0 < above < 6.03  # the last exit jumps by 2.6 s
    assert 0 < above_c - below_c < 0.02  # the bump spends ~1e-2 s above the band
    assert below_c == pytest.approx(below, abs=1e-12)  # one crossing: the same number
    # Continuity: a finer sweep of the bump height through the band changes T_c gradually.
    heights = jnp.linspace(0.98e-3, 1.05e-3, 71)
    values = np.asarray(jax.vmap(lambda a: _both(_bumped(a))[1])(heights))
    assert np.max(np.abs(np.diff(values))) < 2e-3


def test_unsettled_extrapolation_uses_the_measured_decay():
    # The example: a slow decay whose true time to 1e-3 is 138 s, cut at t1 = 20 s.
    # Main scored it t1 + ln(x(t1)/tol) = 25.9 s; the measured decay gives 138 s.
    rate = np.log(1 / TOL) / 138.0
    ts = jnp.linspace(0.0, 20.0, 401)
    x = jnp.exp(-rate * ts)
    value = float(convergence_time(ts, x, TOL))
    assert value == pytest.approx(138.0, rel=1e-9)  # exact for an exponential tail
    old = 20.0 + float(jnp.log(x[-1] / TOL))
    assert old < 26  # what the constant extrapolation said
    # A signal that does not decay still gets a finite penalty (one e-fold per horizon).
    flat = float(convergence_time(ts, jnp.full_like(ts, 0.1), TOL))
    assert flat == pytest.approx(20.0 + 20.0 * np.log(100.0), rel=1e-12)
    # A window longer than the record measures the decay over the whole record (from t0).
    bent = jnp.exp(-0.2 * ts) * (1.0 + 0.5 * jnp.sin(ts))  # not exponential: w matters
    whole = float(convergence_time(ts, bent, TOL, window=20.0))
    assert float(convergence_time(ts, bent, TOL, window=1e3)) == whole
    assert float(convergence_time(ts, bent, TOL, window=2.0)) != whole


def test_continuous_across_the_settled_boundary_and_gradients_match_fd():
    ts = jnp.linspace(0.0, 10.0, 1001)

    def value(rate):
        return convergence_time(ts, jnp.exp(-rate * ts), TOL)

    boundary = np.log(1 / TOL) / 10.0  # crosses exactly at the horizon
    step = 1e-7
    left, right = float(value(boundary - step)), float(value(boundary + step))
    assert abs(left - right) < 1e-4  # continuous (slope ~ -T/rate ~ 14 s per unit rate)
    grad = jax.jit(jax.grad(value))
    for rate in (0.3, 1.2, boundary * 0.9, boundary * 1.1):  # unsettled, settled, both sides
        h = 1e-6 * rate
        fd = (float(value(rate + h)) - float(value(rate - h))) / (2 * h)
        g = float(grad(rate))
        assert np.isfinite(g) and abs(g - fd) <= 1e-6 * abs(fd), (rate, g, fd)


def test_interpolation_bias_is_bounded_by_lambda_dt_squared_over_8():
    for dt in (0.05, 0.01):
        ts = jnp.arange(0.0, 10.0 + dt / 2, dt)
        rate = 1.7
        true = np.log(1 / TOL) / rate
        measured = float(time_outside(ts, jnp.exp(-rate * ts), TOL))
        bias = measured - true
        assert 0 <= bias <= rate * dt**2 / 8 * 1.001, (dt, bias)  # late: convex signal


def test_nonfinite_samples_never_look_settled():
    x = jnp.exp(-TS).at[1800].set(jnp.nan)  # t = 9 s, long after the crossing at 6.9 s
    # The two intervals touching the NaN sample count as outside (2 x 5 ms).
    extra = float(time_outside(TS, x, TOL)) - float(time_outside(TS, jnp.exp(-TS), TOL))
    assert extra == pytest.approx(0.01, rel=1e-9)
    diverged = jnp.where(TS > 5.0, jnp.nan, jnp.exp(-TS))
    assert float(convergence_time(TS, diverged, TOL)) == np.inf
    assert float(settling_time(TS, diverged, TOL)) == np.inf


def _trajectory(signals):
    return Trajectory(
        ts=TS,
        states=None,
        signals=signals,
        status=jnp.array(0),
        failure_time=jnp.array(jnp.inf),
        events={},
    )


def test_metric_objects_read_named_signals_with_explicit_norms():
    e = jnp.stack([jnp.exp(-TS), 2 * jnp.exp(-2 * TS), -0.5 * jnp.exp(-TS)], axis=1)
    u = jnp.stack([jnp.sin(TS), -3 * jnp.cos(TS), jnp.zeros_like(TS)], axis=1)
    traj = _trajectory({"error": e, "u": u})
    euclid = float(SettlingTime("error", TOL)(traj))
    assert euclid == pytest.approx(
        float(settling_time(TS, jnp.linalg.norm(e, axis=1), TOL)), rel=1e-14
    )
    inf_norm = float(SettlingTime("error", TOL, MaxAbs())(traj))
    assert inf_norm == pytest.approx(float(settling_time(TS, jnp.max(jnp.abs(e), 1), TOL)))
    assert inf_norm < euclid
    per_axis = np.asarray(SettlingTime("error", TOL, Absolute())(traj))
    assert per_axis.shape == (3,)
    np.testing.assert_allclose(per_axis, [np.log(1e3), np.log(2e3) / 2, np.log(500)], rtol=1e-4)
    assert float(Peak("u")(traj)) == pytest.approx(3.0, rel=1e-6)
    assert float(Peak("u", Euclidean())(traj)) == pytest.approx(3.0, rel=1e-6)
    assert float(ConvergenceTime("error", TOL)(traj)) == pytest.approx(euclid, abs=1e-12)
    assert SettlingTime.failure_value == np.inf and np.isnan(Peak.failure_value)
    with pytest.raises(ValueError, match="no signal 'nope'"):
        SettlingTime("nope", TOL)(traj)
    with pytest.raises(ValueError, match="`tolerance` must be positive"):
        SettlingTime("error", -1.0)
    with pytest.raises(ValueError, match="time axis"):
        Euclidean(axes=0)(e)


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize("norm", [MaxAbs, Euclidean])
def test_a_norm_refuses_axes_it_cannot_name(norm):
    """An axis beyond the signal's axes was wrapped onto another one (`axes=3` of a `(T, 3)`
    signal reduced axis 1, a plausible magnitude); now it is refused, as are repeats and
    non-integers. Valid negative axes keep working."""
    e = jnp.arange(12.0).reshape(4, 3)
    with pytest.raises(ValueError, match=f"{norm.__name__}: axis 3 of `axes` is out of range"):
        norm(axes=3)(e)
    with pytest.raises(ValueError, match="axis -3 of `axes` is out of range"):
        norm(axes=-3)(e)
    with pytest.raises(ValueError, match="name the same axis twice"):
        norm(axes=(1, -1))(e)
    with pytest.raises(ValueError, match="must not repeat an axis"):
        norm(axes=(1, 1))
    for bad in (1.0, "1", (), True):
        with pytest.raises(ValueError, match="`axes` must be None, an integer"):
            norm(axes=bad)
    np.testing.assert_allclose(norm(axes=-1)(e), norm()(e))
    np.testing.assert_allclose(norm(axes=[1])(e), norm()(e))
    per_agent = norm(axes=-1)(jnp.ones((4, 2, 3)))
    assert per_agent.shape == (4, 2)


def test_moving_average_removes_a_chatter_and_keeps_a_bias():
    ts = jnp.linspace(0.0, 2.0, 4001)
    chatter = 1e-3 * jnp.sign(jnp.sin(2 * jnp.pi * 50 * ts))  # 50 Hz square wave
    averaged = moving_average(ts, chatter + 2e-4, 0.1)  # 5 periods per window
    late = np.asarray(ts) >= 0.1
    # A 1e-3 chatter is averaged out to within the trapezoid rule's error at its jumps: up to
    # 10 jumps per window, each misplacing at most 1e-3 x 2.5e-4 s of area, over 0.1 s.
    np.testing.assert_allclose(np.asarray(averaged)[late], 2e-4, atol=5e-5)
    both = moving_average(ts, jnp.stack([chatter, jnp.ones_like(ts)], axis=1), 0.1)
    assert both.shape == (4001, 2)
    np.testing.assert_allclose(np.asarray(both[:, 1]), 1.0, rtol=1e-12)
    with pytest.raises(ValueError, match="`window` must be positive"):
        moving_average(ts, chatter, 0.0)
    assert metrics.moving_average is moving_average


def test_moving_average_refuses_a_window_that_is_not_a_scalar(no_jaxtyping):
    # A (T,) window broadcast against the times into one window per sample: for T = 3 it
    # returned [1, 0.75, 0.3], a plausible average.
    ts = jnp.linspace(0.0, 1.0, 3)
    with pytest.raises(ValueError, match=r"moving_average: `window` must be a scalar, got shape"):
        moving_average(ts, jnp.array([1.0, 0.5, 0.1]), jnp.array([0.1, 0.2, 0.3]))


# --- Streaming: every metric object reduced on the fly equals its trajectory reduction -------


def _records(seed=0, n=10, t_len=61):
    """A batch of records with repeated band crossings, non-uniform times and bad samples."""
    rng = np.random.default_rng(seed)
    ts = np.sort(np.concatenate([[0.0], rng.uniform(0.0, 12.0, t_len - 1)]))
    a, r = rng.uniform(0.02, 0.2, (n, 1, 3)), rng.uniform(0.2, 1.0, (n, 1, 3))
    w, phi = rng.uniform(2.0, 6.0, (n, 1, 3)), rng.uniform(0.0, 6.0, (n, 1, 3))
    t = ts[None, :, None]
    e = a * np.exp(-r * t) * (1.0 + 0.9 * np.sin(w * t + phi))
    u = np.sign(np.sin(3 * w[..., :2] * t)) * a[..., :2] + 0.01 * rng.normal(size=(n, t_len, 2))
    e[0, 30] = np.nan  # a NaN sample inside the record
    e[1, -1], u[1, -1] = np.nan, np.nan  # a NaN last sample
    e[2, 10, 1], u[2, 10, 0] = np.inf, np.inf  # an inf sample
    e[3] = 0.0  # always inside the band (exact zeros)
    e[4] = 1.0  # never inside
    e[5, 20:] = 0.0
    e[5, 20, 0] = 1e-2  # a sample exactly on the band
    return jnp.asarray(ts), {"e": jnp.asarray(e), "u": jnp.asarray(u)}


STREAMING_METRICS = {
    "settling": SettlingTime("e", 1e-2),
    "settling_inf": SettlingTime("e", 1e-2, MaxAbs()),
    "settling_axis": SettlingTime("e", 1e-2, Absolute()),
    "outside": TimeOutside("e", 1e-2),
    "outside_axis": TimeOutside("e", 1e-2, Absolute()),
    "convergence": ConvergenceTime("e", 1e-3),
    "convergence_window": ConvergenceTime("e", 1e-2, MaxAbs(), window=0.7),
    "convergence_long_window": ConvergenceTime("e", 1e-2, window=100.0),
    "peak": Peak("u"),
    "peak_axis": Peak("e", Absolute()),
    "final": Final("e"),
    "effort": Effort(),
    "chattering": Chattering("u"),
    "chattering_window": Chattering("u", 1.0, 4.0),
}


@eqx.filter_jit
def _both_ways(metric_objects, ts, signals):
    """(streamed, reduced) values of every metric of `metric_objects`, batched."""

    def one(signals):
        traj = SimpleNamespace(ts=ts, signals=signals)
        reduced = {name: m(traj) for name, m in metric_objects.items()}

        def sample(k):
            return {key: value[k] for key, value in signals.items()}

        def step(state, k):
            return {
                name: m.stream_update(state[name], ts[k], sample(k))
                for name, m in metric_objects.items()
            }, None

        state = {
            name: m.stream_init(ts[0], sample(0), ts[-1]) for name, m in metric_objects.items()
        }
        state, _ = jax.lax.scan(step, state, jnp.arange(1, ts.shape[0]))
        streamed = {name: m.stream_value(state[name]) for name, m in metric_objects.items()}
        return streamed, reduced

    return jax.vmap(one)(signals)


def test_streamed_metrics_equal_the_trajectory_reduction_bad_samples_included():
    ts, signals = _records()
    streamed, reduced = _both_ways(STREAMING_METRICS, ts, signals)
    for name in STREAMING_METRICS:
        got, expected = np.asarray(streamed[name]), np.asarray(reduced[name])
        assert got.shape == expected.shape, name
        # inf and NaN exactly where the reduction has them (a failure looks like a failure)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(expected), err_msg=name)
        np.testing.assert_array_equal(np.isposinf(got), np.isposinf(expected), err_msg=name)
        finite = np.isfinite(expected)
        np.testing.assert_allclose(got[finite], expected[finite], rtol=1e-12, err_msg=name)
    # The records exercise what they are meant to: re-entries, never/always inside, NaN.
    settling = np.asarray(reduced["settling"])
    assert settling[3] == 0.0 and settling[4] == np.inf and settling[1] == np.inf
    assert np.isnan(np.asarray(reduced["peak"])[1]) and np.isfinite(settling).sum() >= 5
    outside = np.asarray(reduced["outside"])
    assert np.sum(outside[np.isfinite(settling)] < settling[np.isfinite(settling)] - 1e-3) >= 2
    assert all(m.streams for m in STREAMING_METRICS.values())


def test_streamed_chattering_keeps_the_interval_ending_one_ulp_after_the_window():
    # The save times 0 + i * 0.01 end at 0.7000000000000001; the window (0.35, 0.7), the
    # tuning objective's default for t1 = 0.7, must keep the last interval's increment, in
    # the trajectory and the streaming form alike.
    ts = 0.0 + jnp.arange(71) * 1e-2
    assert float(ts[-1]) > 0.7
    u = jnp.zeros((1, 71, 2)).at[0, -1].set(jnp.array([1.0, -0.5]))
    streamed, reduced = _both_ways({"ch": Chattering("u", 0.35, 0.7)}, ts, {"u": u})
    assert float(reduced["ch"][0]) == 1.5
    assert float(streamed["ch"][0]) == 1.5


def test_convergence_time_is_continuous_at_a_zero_sample_at_the_window_start():
    # The default window starts at t = 0.9 (k = 9); the record ends outside the band. x_k = 0
    # is the limit x_k -> 0+: the measured rate ln(x_k / x_end) / w -> -inf, floored at one
    # e-fold per horizon (1 s), so T_c = T_out + ln(0.5 / 0.01) s in both cases.
    ts = jnp.linspace(0.0, 1.0, 11)
    records = jnp.array([[0.5, 0.1, 0.001, 0, 0, 0, 0, 0, 0, x_k, 0.5] for x_k in (0.0, 1e-300)])
    tol = 0.01
    expected = float(time_outside(ts, records[0], tol)) + np.log(0.5 / tol)
    reduced = [float(convergence_time(ts, x, tol)) for x in records]
    np.testing.assert_allclose(reduced, expected, rtol=1e-12)
    streamed, _ = _both_ways({"c": ConvergenceTime("e", tol)}, ts, {"e": records[..., None]})
    np.testing.assert_allclose(np.asarray(streamed["c"]), expected, rtol=1e-12)
    # No logarithm of 0 leaks into the backward pass.
    grad = jax.grad(convergence_time, argnums=(1, 2))(ts, records[0], tol)
    assert all(np.all(np.isfinite(np.asarray(g))) for g in grad)


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize(
    ("make", "match"),
    [
        (
            lambda: SettlingTime("e", jnp.array([1e-2, 5e-2, 1e-1])),
            r"^SettlingTime: `tolerance` must be a scalar, got shape \(3,\)\.$",
        ),
        (lambda: TimeOutside("e", np.ones(2)), r"TimeOutside: `tolerance` must be a scalar"),
        (lambda: ConvergenceTime("e", [1e-3, 1e-2]), r"ConvergenceTime: `tolerance` must be a"),
        (lambda: ConvergenceTime("e", 1e-3, window=jnp.ones(3)), r"`window` must be a scalar"),
        (lambda: SettlingTime("e", 0.0), r"SettlingTime: `tolerance` must be positive"),
        (lambda: Chattering("u", 0.8, 0.2), r"^Chattering: `start` must be less than `end`"),
        (lambda: Chattering("u", 0.5, 0.5), r"Chattering: `start` must be less than `end`"),
        (lambda: Chattering("u", np.nan, 1.0), r"^Chattering: `start` must not be NaN"),
        (lambda: Chattering("u", end=np.nan), r"^Chattering: `end` must not be NaN"),
        (lambda: Chattering("u", jnp.zeros(2)), r"Chattering: `start` must be a scalar"),
        (lambda: Chattering("u", "0.5"), r"Chattering: `start` must be a number"),
    ],
)
def test_metric_objects_refuse_bad_tolerances_and_windows(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_chattering_accepts_infinite_window_ends():
    whole = Chattering("u")
    assert float(whole.start) == -np.inf and float(whole.end) == np.inf
    assert float(Chattering("u", 1.0).start) == 1.0
    assert float(Chattering("u", -np.inf, 2).end) == 2.0
