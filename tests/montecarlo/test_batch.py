"""`monte_carlo` and `batch_field`: equal to a Python loop of `simulate`, failures counted,
chunking, batched closed-loop fields, one compilation for 4096 samples, and the summaries."""

import functools as ft
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest

import jaxatt
from jaxatt import montecarlo as mc
from jaxatt.metrics import (
    Absolute,
    AbstractMetric,
    Chattering,
    ConvergenceTime,
    Effort,
    Final,
    Peak,
    SettlingTime,
    TimeOutside,
    control_effort,
    peak,
    settling_time,
)
from jaxatt.numerics import safe_norm
from jaxatt.performance import MinimumMargin
from jaxatt.plants import MRPState, QuaternionState
from jaxatt.scenarios import chen2022_two_phase_power as chen
from jaxatt.simulation import (
    NO_LIBRARY_FUSIONS,
    SCALARIZE_FROM,
    SCALARIZED_VECTOR_WIDTH,
    Euler,
    Performance,
    Status,
    Trajectory,
    samples_at_once,
)

from ..helpers import mrp_pd_loop


N = 5
HORIZON, DT, SAVE_EVERY = 3.0, 5e-3, 4
BAD = 3  # the sample whose initial rate (1e150 rad/s) overflows at once: it diverges


mrps_from_quats = jax.jit(jax.vmap(jaxatt.rotations.mrp_from_quat))


def _index(tree, k):
    return jax.tree.map(lambda x: x[k], tree)


@pytest.fixture(scope="module")
def chen_batch():
    """Chen 2022 M1 with dispersed inertia and disturbance, one diverging sample."""
    loop = chen.build("M1")
    keys = jr.split(jr.key(0), 4)
    x0s = QuaternionState(
        mc.attitudes_within(keys[0], N, jnp.pi / 3), mc.rates_in_ball(keys[1], N, 0.05)
    )
    x0s = eqx.tree_at(lambda x: x.omega, x0s, x0s.omega.at[BAD].set(jnp.array([1e150, 1e150, 0])))
    inertias = mc.inertia_dispersion(
        keys[2], N, loop.plant.body.inertia, principal_scale=0.1, max_misalignment=0.1
    )
    disturbances = mc.sinusoid_dispersion(
        keys[3], N, loop.plant.body.disturbance, amplitude_scale=0.5, phase_spread=1.0
    )
    batched, axes = mc.batch_field(loop, lambda m: m.plant.body.inertia, inertias)
    batched, axes = mc.batch_field(batched, lambda m: m.plant.body.disturbance, disturbances, axes)
    result = mc.monte_carlo(
        batched,
        x0s,
        0.0,
        HORIZON,
        dt=DT,
        loop_axes=axes,
        save_every=SAVE_EVERY,
        keep_trajectories=True,
    )
    return loop, x0s, inertias, disturbances, result


def test_monte_carlo_equals_a_python_loop_of_simulate(chen_batch):
    loop, x0s, inertias, disturbances, result = chen_batch
    assert result.n == N
    for k in range(N):
        # Build the k-th closed loop by hand, independently of batch_field's in_axes.
        loop_k = eqx.tree_at(
            lambda m: (m.plant.body.inertia, m.plant.body.disturbance),
            loop,
            (inertias[k], _index(disturbances, k)),
        )
        traj = jaxatt.simulate(
            loop_k, _index(x0s, k), 0.0, HORIZON, dt=DT, save_every=SAVE_EVERY, throw=False
        )
        assert int(traj.status) == int(result.status[k])
        if k == BAD:
            continue
        # The default metrics of a quaternion plant, computed here from the trajectory.
        e_v = traj.signals["attitude_error"][:, 1:]
        expected = {
            "settling_time": settling_time(traj.ts, safe_norm(e_v), 1e-2),
            "peak_torque": peak(traj.signals["u"]),
            "effort": control_effort(traj.ts, traj.signals["u"]),
            "max_rate_error": jnp.max(safe_norm(traj.signals["rate_error"])),
        }
        assert set(result.metrics) == set(expected)
        for name, value in expected.items():
            np.testing.assert_allclose(result.metrics[name][k], value, rtol=1e-10, err_msg=name)
        np.testing.assert_allclose(
            result.trajectories.states.plant.q[k], traj.states.plant.q, rtol=1e-10, atol=1e-13
        )


def test_streamed_default_equals_the_saved_trajectory_reduction(chen_batch):
    # monte_carlo's default reduces the metrics on the fly (nothing saved). It must give what
    # the saved-trajectory path gives (the fixture's run, keep_trajectories=True), for every
    # kind of metric, at the save resolution, with the failed sample failed in both; once as
    # the plain program and once scalarized (the default from 1000 samples): scalarize=True
    # changes the layout, not the numbers (batched loop fields and the failure included).
    loop, x0s, inertias, disturbances, saved = chen_batch
    batched, axes = mc.batch_field(loop, lambda m: m.plant.body.inertia, inertias)
    batched, axes = mc.batch_field(batched, lambda m: m.plant.body.disturbance, disturbances, axes)
    objects = dict(
        loop.default_metrics(1e-2),
        per_axis=SettlingTime("attitude_error_vector", 1e-2, Absolute()),
        outside=TimeOutside("attitude_error_vector", 1e-2),
        convergence=ConvergenceTime("attitude_error_vector", 1e-3),
        final=Final("rate_error"),
        chattering=Chattering("u", 0.5, 2.5),
    )
    trajs = saved.trajectories
    ok = np.asarray(saved.successful)
    performances = (
        Performance(scalarize=False),
        Performance(scalarize=True),  # compiled for 512-bit vectors on CPU (the default)
        Performance(scalarize=True, vector_width=256),  # XLA's own width
    )
    for performance in performances:
        streamed = mc.monte_carlo(
            batched,
            x0s,
            0.0,
            HORIZON,
            dt=DT,
            loop_axes=axes,
            save_every=SAVE_EVERY,
            metrics=objects,
            performance=performance,
        )
        assert streamed.trajectories is None  # nothing saved by default
        np.testing.assert_array_equal(streamed.status, saved.status)
        np.testing.assert_array_equal(streamed.failure_time, saved.failure_time)
        for name, metric in objects.items():
            expected = np.asarray(jax.vmap(metric)(trajs))
            expected = np.where(
                ok.reshape(-1, *[1] * (expected.ndim - 1)), expected, metric.failure_value
            )
            got = np.asarray(streamed.metrics[name])
            np.testing.assert_array_equal(np.isnan(got), np.isnan(expected), err_msg=name)
            np.testing.assert_array_equal(np.isposinf(got), np.isposinf(expected), err_msg=name)
            finite = np.isfinite(expected)
            np.testing.assert_allclose(got[finite], expected[finite], rtol=1e-12, err_msg=name)
        assert np.asarray(streamed.metrics["settling_time"])[BAD] == math.inf


def test_default_scalarization_rule():
    assert SCALARIZE_FROM == 1000
    auto = Performance()
    assert not auto.resolve(999, "cpu").scalarize and auto.resolve(1000, "cpu").scalarize
    assert not auto.resolve(10**6, "gpu").scalarize  # unmeasured there: off
    assert samples_at_once(4000, batch_size=500) == 500  # lax.map runs 500 at a time
    assert samples_at_once(1500, devices=2) == 750 and samples_at_once(2000, devices=2) == 1000
    assert Performance(scalarize=False).resolve(10**6, "cpu").scalarize is False


def test_vector_width_option():
    option = "xla_cpu_prefer_vector_width"
    auto = Performance(library_fusions=True)  # the width alone (the next test has the rest)
    assert SCALARIZED_VECTOR_WIDTH == 512
    assert auto.resolve(1000, "cpu").compiler_options("cpu") == {option: 512}  # scalarized
    assert auto.resolve(999, "cpu").compiler_options("cpu") == {}  # plain: XLA's default
    for width in (512, 256, 128):
        chosen = Performance(vector_width=width, library_fusions=True)
        assert chosen.resolve(1000, "cpu").compiler_options("cpu") == {option: width}
    assert Performance(vector_width=128, library_fusions=True).resolve(1, "cpu").compiler_options(
        "cpu"
    ) == {option: 128}
    assert Performance(scalarize=True, vector_width=512).compiler_options("gpu") == {}
    for bad in (384, 0, True):  # (non-integers: the test suite's type checker refuses them first)
        with pytest.raises(ValueError, match="`vector_width` must be None or one of 128, 256, 512"):
            Performance(vector_width=bad)


def test_small_products_stay_out_of_the_library_by_default():
    # jaxatt's CPU programs compile XLA's small dot products themselves (`NO_LIBRARY_FUSIONS`);
    # `library_fusions=True` gives XLA's default back. The option must reach XLA and do what
    # it says: a batched 3x3 product compiles to a YNNPACK fusion without it, and not with it.
    # An XLA without YNNPACK (jaxlib 0.6.2's, the floor `.ci/oldest` runs) refuses the option:
    # it is passed only where this XLA compiles a program with it.
    assert NO_LIBRARY_FUSIONS == {"xla_cpu_experimental_ynn_fusion_type": ""}
    inertia = jnp.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])
    lowered = jax.jit(jax.vmap(lambda w: inertia @ w)).lower(jnp.ones((32, 3)))
    try:
        lowered.compile(NO_LIBRARY_FUSIONS)
        known = True
    except Exception:  # XLA's error types differ between jaxlib versions
        known = False
    expected = NO_LIBRARY_FUSIONS if known else {}
    for performance in (Performance(), Performance().resolve(1000, "cpu")):
        options = performance.compiler_options("cpu")
        assert {k: options[k] for k in options if k in NO_LIBRARY_FUSIONS} == expected
    assert Performance(library_fusions=True).compiler_options("cpu") == {}
    assert Performance().compiler_options("gpu") == {}
    if known:
        library = lowered.compile().as_text()
        own = lowered.compile(Performance().compiler_options("cpu")).as_text()
        assert "__ynn_fusion" not in own
        # jaxlib 0.9's XLA knows the option but leaves this product out of YNNPACK anyway
        # (measured with jaxlib 0.9.2, the newest pip installs beside SciPy 1.13).
        if jax.__version_info__ >= (0, 10):
            assert "__ynn_fusion" in library


@pytest.mark.parametrize("bad", [None, 1, "False"])
def test_library_fusions_must_be_a_flag(bad, no_jaxtyping):
    # (The suite's type checking rejects these first; users meet this.)
    with pytest.raises(ValueError, match="`library_fusions` must be True or False"):
        Performance(library_fusions=bad)


def test_compiler_options_reach_xla(monkeypatch):
    # `simulate` and `monte_carlo` compile with the options their Performance asks for: an
    # option XLA does not know is refused by XLA's compiler, so it got there.
    monkeypatch.setattr(
        Performance, "compiler_options", lambda self, backend=None: {"xla_no_such_option": 1}
    )
    loop, x0s = mrp_pd_loop(), MRPState(jnp.full((2, 3), 0.1), jnp.zeros((2, 3)))
    with pytest.raises(Exception, match="xla_no_such_option"):
        mc.monte_carlo(loop, x0s, 0.0, 0.01, dt=1e-3)
    with pytest.raises(Exception, match="xla_no_such_option"):
        jaxatt.simulate(loop, _index(x0s, 0), 0.0, 0.01, dt=1e-3)


def test_entry_points_with_compiler_options_work_inside_user_programs():
    # JAX refuses compiler options on a nested `jit`: inside the caller's `jit` or `grad`,
    # `simulate` and `monte_carlo` become part of the caller's program and pass none.
    loop, x0s = mrp_pd_loop(), MRPState(jnp.full((2, 3), 0.1), jnp.zeros((2, 3)))
    performance = Performance(vector_width=256)  # options even for the plain program
    assert performance.resolve(2, "cpu").compiler_options("cpu")

    def effort(x0s):
        result = mc.monte_carlo(loop, x0s, 0.0, 0.01, dt=1e-3, performance=performance)
        return result.metrics["effort"].sum()

    def final(x0):
        traj = jaxatt.simulate(loop, x0, 0.0, 0.01, dt=1e-3, performance=performance)
        return traj.states.plant.sigma[-1].sum()

    eager = effort(x0s)
    np.testing.assert_allclose(jax.jit(effort)(x0s), eager, rtol=1e-12)
    assert np.all(np.isfinite(jax.grad(effort)(x0s).sigma))
    x0 = _index(x0s, 0)
    np.testing.assert_allclose(jax.jit(final)(x0), final(x0), rtol=1e-12)
    assert np.all(np.isfinite(jax.grad(final)(x0).sigma))
    assert np.all(np.isfinite(jax.vmap(final)(x0s)))


def test_batched_fields_really_differ_between_samples(chen_batch):
    # Guard for the test above: with one shared inertia the loop comparison would be vacuous.
    _, _, inertias, _, result = chen_batch
    assert not np.allclose(inertias[0], inertias[1])
    effort = np.asarray(result.metrics["effort"])[np.asarray(result.successful)]
    assert len(set(np.round(effort, 6))) == N - 1


def test_a_diverging_sample_is_failed_never_fastest_and_the_others_finish(chen_batch):
    # Regression: safe_norm returned 0 for a NaN vector, so a diverged sample got a settling
    # time near 0 (the fastest of the batch) in the raw metrics, the plots and the objective.
    *_, result = chen_batch
    ok = np.asarray(result.successful)
    assert not ok[BAD] and ok.sum() == N - 1
    assert int(result.status[BAD]) == Status.nonfinite_state
    assert float(result.failure_time[BAD]) == pytest.approx(DT)  # the first step
    settling = np.asarray(result.metrics["settling_time"])
    assert settling[BAD] == math.inf  # failed: infinite, in the raw metrics too
    assert np.isnan(np.asarray(result.metrics["effort"])[BAD])
    assert np.argmin(settling) != BAD
    assert np.all(settling[ok] > 0.5) and np.all(settling[ok] < HORIZON)
    assert np.all(np.isfinite(np.asarray(result.metrics["effort"])[ok]))
    summary = result.summary("settling_time")
    assert summary["failed"] == 1
    assert summary["status"] == {
        "successful": 4,
        "nonfinite_state": 1,
        "constraint_violated": 0,
        "invalid_plant": 0,
    }
    assert summary["finite"] == N - 1
    assert summary["worst"] == math.inf and summary["worst_index"] == BAD
    assert summary["success_rate"] == pytest.approx((N - 1) / N)
    good = settling[ok]
    assert summary["mean"] == pytest.approx(good.mean(), rel=1e-14)
    assert summary["std"] == pytest.approx(good.std(ddof=1), rel=1e-12)
    assert summary["max"] == pytest.approx(good.max(), rel=1e-14)


def test_summary_time_limit(chen_batch):
    *_, result = chen_batch
    limit = float(np.median(np.asarray(result.metrics["settling_time"])[:BAD]))
    limited = result.summary("settling_time", time_limit=limit)
    settling = np.asarray(result.metrics["settling_time"])
    expected = np.mean(np.asarray(result.successful) & (settling <= limit))
    assert limited["success_rate"] == pytest.approx(expected)


def test_summary_statistics_on_a_hand_made_result():
    values = jnp.array([1.0, 2.0, jnp.inf, 4.0, 8.0, jnp.nan])
    failed = jnp.array([False, False, False, False, True, False])
    result = mc.MonteCarloResult(
        metrics={"settling_time": values, "peak_torque": jnp.arange(6.0)},
        status=jnp.where(failed, int(Status.nonfinite_state), 0).astype(jnp.int32),
        failure_time=jnp.where(failed, 0.5, jnp.inf),
    )
    s = result.summary(quantiles=(0.0, 0.5, 1.0), time_limit=3.0)
    assert (s["count"], s["failed"], s["nonfinite"], s["finite"]) == (6, 1, 2, 3)
    assert s["mean"] == pytest.approx(7 / 3)
    assert s["std"] == pytest.approx(np.std([1.0, 2.0, 4.0], ddof=1))
    # Quantiles over every sample, the unsettled, NaN and failed ones as never settling.
    assert s["quantiles"] == {0.0: 1.0, 0.5: math.inf, 1.0: math.inf}
    assert s["worst"] == math.inf and s["worst_index"] == 2
    assert s["success_rate"] == pytest.approx(2 / 6)
    d = result.to_dict()
    assert d["metrics"]["settling_time"]["worst"] is None  # JSON-safe
    assert d["failed"] == 1
    table = result.table()
    assert "| settling_time | 6 | 1 | 2 |" in table
    compare = mc.summary_table({"A": result, "B": result})
    assert compare.count("\n") == 3
    with pytest.raises(ValueError, match="metric"):
        result.summary("overshoot")
    with pytest.raises(ValueError, match="quantiles"):
        result.summary(quantiles=(1.5,))


def test_a_failed_sample_never_reports_a_plausible_flag_or_count():
    # Regression (audit): a metric with boolean or integer values kept them for a failed sample
    # (NaN cast to a boolean is True: "the constraint was respected"; an integer count was
    # kept by a metric function, and a metric object's integer raised instead).
    class Respected(AbstractMetric):
        def __call__(self, traj):
            return jnp.all(traj.signals["x"] < 1.0)

    class Count(AbstractMetric):
        def __call__(self, traj):
            return jnp.sum(traj.signals["x"] > 0.5)

    def stand_in(status):
        return Trajectory(
            ts=jnp.arange(3.0),
            states=None,
            signals={"x": jnp.zeros(3)},
            status=jnp.asarray(int(status)),
            failure_time=jnp.asarray(1.0 if status else jnp.inf),
            events={},
        )

    objects = {"respected": Respected(), "count": Count()}
    function = lambda traj: {"respected": Respected()(traj), "count": Count()(traj)}
    for metrics in (objects, function):
        failed = mc.evaluate_metrics(metrics, stand_in(Status.nonfinite_state))
        assert all(np.isnan(failed[name]) for name in ("respected", "count"))
        good = mc.evaluate_metrics(metrics, stand_in(Status.successful))
        assert (float(good["respected"]), float(good["count"])) == (1.0, 0.0)
    stream = mc.MetricStream({"peak": Peak("x")})
    flag = jnp.asarray(True)
    assert np.isnan(stream.values({"peak": flag}, jnp.asarray(False))["peak"])


def test_a_boolean_time_limit_is_refused(no_jaxtyping):
    # Regression (audit): time_limit=True was a limit of 1 s.
    result = mc.MonteCarloResult(
        metrics={"settling_time": jnp.ones(2)},
        status=jnp.zeros(2, jnp.int32),
        failure_time=jnp.full(2, jnp.inf),
    )
    with pytest.raises(ValueError, match="`time_limit` must be a number"):
        result.summary(time_limit=True)


def test_an_empty_result_is_refused_by_name():
    # Regression (review): a result of no samples raised NumPy's "attempt to get argmax of an
    # empty sequence" from summary, table and to_dict.
    empty = mc.MonteCarloResult(
        metrics={"settling_time": jnp.zeros(0)},
        status=jnp.zeros(0, jnp.int32),
        failure_time=jnp.zeros(0),
    )
    for report in (empty.summary, empty.table, empty.to_dict):
        with pytest.raises(ValueError, match="MonteCarloResult.summary: the result has no"):
            report()


def test_a_margins_worst_case_is_its_smallest_value_and_time_limits_reach_every_time():
    # Regression (review): "worst" was the largest value for every metric, so the summary of a
    # MinimumMargin reported the safest run as the worst; and to_dict/table applied
    # `time_limit` to a metric named settling_time only (the pose plants' settle_time_* were
    # never limited).
    margins = jnp.array([0.30, 0.02, 0.25, jnp.nan])
    times = jnp.array([1.0, 50.0, 2.0, jnp.inf])
    failed = jnp.array([False, False, False, True])
    result = mc.MonteCarloResult(
        metrics={"margin": margins, "settle_time_position": times},
        status=jnp.where(failed, int(Status.constraint_violated), 0).astype(jnp.int32),
        failure_time=jnp.where(failed, 0.5, jnp.inf),
        smallest_is_worst=("margin",),
        time_metrics=("settle_time_position",),
    )
    s = result.summary("margin")
    assert (s["worst_is"], s["worst"], s["worst_index"]) == ("smallest", -math.inf, 3)
    assert result.summary("margin", worst="largest")["worst"] == math.inf
    successful = mc.MonteCarloResult(
        metrics={"margin": margins[:3]},
        status=jnp.zeros(3, jnp.int32),
        failure_time=jnp.full(3, jnp.inf),
        smallest_is_worst=("margin",),
    )
    s = successful.summary("margin")
    assert (s["worst"], s["worst_index"]) == (pytest.approx(0.02), 1)  # the closest call
    assert successful.summary("margin", worst="largest")["worst_index"] == 0
    with pytest.raises(ValueError, match="`worst` must be"):
        successful.summary("margin", worst="max")
    limited = result.to_dict(time_limit=10.0)["metrics"]
    assert limited["settle_time_position"]["success_rate"] == 0.5
    assert limited["margin"]["time_limit"] is None  # not a time
    assert "| settle_time_position | 4 | 1 | 0 |" in result.table(time_limit=10.0)
    assert "50.0 %" in result.table(["settle_time_position"], time_limit=10.0)


def test_quantiles_count_unsettled_and_failed_samples_at_the_worst_end():
    # Regression (audit): quantiles were over the settled samples only, so a batch where 7 of
    # 10 samples never settled reported a median settling time of 1.5 s (the median of the 3
    # that did), and a q95 of 1.95 s; a failed margin did not lower a margin's q5.
    times = jnp.array([1.0, 1.5, 2.0] + [jnp.inf] * 6 + [jnp.nan])
    margins = jnp.array([0.5, 0.4, 0.3, 0.2, 0.1, 0.6, 0.7, 0.8, 0.9, 1.0])
    failed = jnp.arange(10) == 9
    result = mc.MonteCarloResult(
        metrics={"settling_time": times, "margin": margins},
        status=jnp.where(failed, int(Status.constraint_violated), 0).astype(jnp.int32),
        failure_time=jnp.where(failed, 0.5, jnp.inf),
        smallest_is_worst=("margin",),
    )
    s = result.summary(quantiles=(0.0, 0.1, 0.2, 0.25, 0.5, 0.95))["quantiles"]
    assert (s[0.0], s[0.1], s[0.2]) == (1.0, pytest.approx(1.45), pytest.approx(1.9))
    assert s[0.25] == s[0.5] == s[0.95] == math.inf  # interpolated towards a sample at inf
    s = result.summary()
    assert s["mean"] == pytest.approx(1.5)  # the mean stays the settled samples', labelled so
    m = result.summary("margin", quantiles=(0.0, 0.05, 0.5, 1.0))["quantiles"]
    assert m[0.0] == m[0.05] == -math.inf and m[0.5] == pytest.approx(0.45)
    assert m[1.0] == pytest.approx(0.9)
    # All finite: NumPy's quantiles exactly. None settled, or one unsettled sample: all inf.
    settled = mc.MonteCarloResult(
        metrics={"settling_time": times[:3]},
        status=jnp.zeros(3, jnp.int32),
        failure_time=jnp.full(3, jnp.inf),
    )
    for q in (0.0, 0.3, 0.5, 0.95, 1.0):
        expected = float(np.quantile(np.asarray(times[:3]), q))
        assert settled.summary(quantiles=(q,))["quantiles"][q] == expected
    for values in (times[3:], times[3:4]):
        none = mc.MonteCarloResult(
            metrics={"settling_time": values},
            status=jnp.zeros(values.size, jnp.int32),
            failure_time=jnp.full(values.size, jnp.inf),
        )
        assert set(none.summary(quantiles=(0.0, 0.5, 1.0))["quantiles"].values()) == {math.inf}
    assert "| 10 | 1 | 6 | 1.5 | 0.5 | 1.225 | inf | inf | inf | 30.0 % |" in result.table(
        ["settling_time"]
    )


def test_a_success_rate_short_of_all_never_reads_100_percent():
    # Regression (audit): the table's '{:.1f} %' showed one unsettled sample in 10000 as a
    # success rate of '100.0 %' (and one success in 10000 as '0.0 %').
    n = 10000
    one_unsettled = jnp.ones(n).at[0].set(jnp.inf)
    one_settled = jnp.full(n, jnp.inf).at[0].set(1.0)
    result = mc.MonteCarloResult(
        metrics={"settling_time": one_unsettled, "other": one_settled},
        status=jnp.zeros(n, jnp.int32),
        failure_time=jnp.full(n, jnp.inf),
    )
    table = result.table()
    assert "| 99.99 % |" in table and "| 0.01 % |" in table and "100.0 %" not in table
    done = mc.MonteCarloResult(
        metrics={"settling_time": jnp.ones(3)},
        status=jnp.zeros(3, jnp.int32),
        failure_time=jnp.full(3, jnp.inf),
    )
    assert "| 100.0 % |" in done.table()


def test_run_batch_records_which_metrics_are_margins_and_which_are_times():
    loop = mrp_pd_loop(k1=60.0, k2=50.0)
    x0s = MRPState(jnp.full((2, 3), 0.1), jnp.zeros((2, 3)))
    sim = jaxatt.simulation.Simulation(0.0, 0.05, 1e-2)
    sim = sim.with_performance(sim.performance.resolve(2))
    metrics = {
        "peak": Peak("u"),
        "margin": MinimumMargin("u"),
        "settling": SettlingTime("attitude_error_vector", 1e-2),
        "outside": TimeOutside("attitude_error_vector", 1e-2),
        "convergence": ConvergenceTime("attitude_error_vector", 1e-2),
    }
    # Traced only (no compilation): the two lists are static fields of the result.
    shape = jax.eval_shape(lambda x: mc.run_batch(loop, x, sim, metrics), x0s)
    assert shape.smallest_is_worst == ("margin",)
    assert shape.time_metrics == ("settling", "outside", "convergence")


@pytest.fixture(scope="module")
def pd_batch():
    loop = mrp_pd_loop(k1=60.0, k2=50.0)
    n = 6
    sigma = mrps_from_quats(mc.uniform_attitudes(jr.key(5), n))
    x0s = MRPState(sigma, mc.rates_in_box(jr.key(6), n, 0.05))
    return loop, x0s


def test_batch_size_chunks_equal_the_unchunked_run(pd_batch):
    loop, x0s = pd_batch
    whole = mc.monte_carlo(loop, x0s, 0.0, 30.0, dt=1e-2)
    chunked = mc.monte_carlo(loop, x0s, 0.0, 30.0, dt=1e-2, batch_size=3, keep_trajectories=True)
    assert np.all(np.isfinite(whole.metrics["settling_time"]))
    for name in whole.metrics:
        np.testing.assert_allclose(chunked.metrics[name], whole.metrics[name], rtol=1e-12)
    np.testing.assert_array_equal(chunked.successful, whole.successful)
    # MRP plant: the default settling time uses ||sigma_e|| (all three components).
    traj = _index(chunked.trajectories, 2)
    error = np.linalg.norm(np.asarray(traj.signals["attitude_error"]), axis=-1)
    ts = np.asarray(traj.ts)
    k = np.flatnonzero(error > 1e-2)[-1]  # last sample outside the band, then interpolate
    expected = ts[k] + (error[k] - 1e-2) / (error[k] - error[k + 1]) * (ts[k + 1] - ts[k])
    np.testing.assert_allclose(whole.metrics["settling_time"][2], expected, rtol=1e-12)


def test_4096_samples_in_one_compiled_call():
    loop = mrp_pd_loop(uncertain=False)
    n = 4096
    traces = []

    def probe(traj):
        traces.append(1)  # runs at trace time only
        return {"final_error": jnp.linalg.norm(traj.signals["attitude_error"][-1])}

    def draw(key):
        k1, k2 = jr.split(key)
        sigma = mrps_from_quats(mc.attitudes_within(k1, n, 1.0))
        return MRPState(sigma, mc.rates_in_ball(k2, n, 0.05))

    first = mc.monte_carlo(loop, draw(jr.key(1)), 0.0, 0.03, dt=1e-2, metrics=probe, solver=Euler())
    second = mc.monte_carlo(
        loop, draw(jr.key(2)), 0.0, 0.03, dt=1e-2, metrics=probe, solver=Euler()
    )
    assert len(traces) == 1
    assert first.metrics["final_error"].shape == (n,)
    assert bool(jnp.all(first.successful))
    assert not np.allclose(first.metrics["final_error"], second.metrics["final_error"])


def test_streamed_metrics_under_a_zero_order_hold_equal_the_saved_ones(pd_batch):
    # Under a delayed zero-order hold the saved signals are the right-continuous outputs of
    # each sample instant; the stream must see exactly those, every step and every 3rd step.
    loop, x0s = pd_batch
    objects = {
        "settling": SettlingTime("attitude_error_vector", 0.3),
        "peak": Peak("u", Absolute()),
        "effort": Effort(),
        "chattering": Chattering("u"),
        "final_u": Final("u", Absolute()),
    }
    hold = jaxatt.simulation.ZeroOrderHold(0.04, delay=True)
    run = ft.partial(mc.monte_carlo, loop, x0s, 0.0, 0.6, dt=1e-2, sampling=hold, metrics=objects)
    trajs = run(keep_trajectories=True).trajectories
    for every in (1, 3):
        streamed = run(save_every=every)
        sub = jax.tree.map(lambda x: x[:, ::every], (trajs.ts, trajs.signals))
        saved = eqx.tree_at(lambda tr: (tr.ts, tr.signals), trajs, sub)
        for name, metric in objects.items():
            np.testing.assert_allclose(
                streamed.metrics[name], jax.vmap(metric)(saved), rtol=1e-12, err_msg=name
            )
    u = np.asarray(trajs.signals["u"])
    assert np.all(u[:, :4] == 0) and np.any(u[:, 5] != 0)  # the delay is exercised


def test_streaming_is_chosen_only_when_every_metric_streams():
    # A metric function (or an object without a streaming form) falls back to the saved
    # trajectory; run_batch refuses to stream what cannot stream instead of guessing.
    objects = {"settling": SettlingTime("attitude_error_vector", 1e-2), "peak": Peak("u")}
    assert mc.streamable(objects)
    assert not mc.streamable(lambda traj: {})
    assert not mc.streamable(dict(objects, margin=jaxatt.performance.MinimumMargin()))
    sim = jaxatt.simulation.Simulation(0.0, 0.1, 1e-2)
    with pytest.raises(ValueError, match="stream=True"):
        mc.run_batch(mrp_pd_loop(), None, sim, lambda traj: {}, stream=True)
    with pytest.raises(ValueError, match="stream=True"):
        mc.run_batch(mrp_pd_loop(), None, sim, objects, stream=True, keep_trajectories=True)


def test_batch_field_in_axes():
    loop = mrp_pd_loop()
    inertias = jnp.stack([loop.plant.body.inertia] * 3)
    batched, axes = mc.batch_field(loop, lambda m: m.plant.body.inertia, inertias)
    assert batched.plant.body.inertia.shape == (3, 3, 3)
    assert axes.plant.body.inertia == 0
    assert [leaf for leaf in jax.tree.leaves(axes)] == [0]
    signal = mc.sinusoid_dispersion(
        jr.key(0), 3, loop.plant.body.disturbance, amplitude_scale=0.1, phase_spread=0.1
    )
    batched, axes = mc.batch_field(batched, lambda m: m.plant.body.disturbance, signal, axes)
    assert jax.tree.leaves(axes) == [0, 0]
    assert axes.plant.body.disturbance == 0
    # The in_axes drive eqx.filter_vmap directly.
    values = eqx.filter_vmap(lambda m: m.plant.body.disturbance(1.0), in_axes=(axes,))(batched)
    assert values.shape == (3, 3)
    with pytest.raises(ValueError, match="already batched"):
        mc.batch_field(batched, lambda m: m.plant.body.inertia, inertias, axes)
    with pytest.raises(ValueError, match="shape"):
        mc.batch_field(loop, lambda m: m.plant.body.inertia, jnp.ones((3, 2, 2)))
    with pytest.raises(ValueError, match="structure"):
        mc.batch_field(loop, lambda m: m.plant.body.disturbance, jnp.ones((3, 3)))


def test_batch_field_checks_every_sample_like_the_owners_constructor():
    # Regression: only finiteness was checked, so a negative gain or an indefinite inertia ran
    # and gave plausible metrics although the constructors refuse them.
    loop = mrp_pd_loop()
    with pytest.raises(
        ValueError, match=r"values\[1\] for `controller.k1` .*`k1` must be positive"
    ):
        mc.batch_field(loop, "controller.k1", jnp.array([60.0, -60.0]))
    with pytest.raises(
        ValueError, match=r"values\[2\] for `controller.k2` .*`k2` must be positive"
    ):
        mc.batch_field(loop, lambda m: m.controller.k2, jnp.array([1.0, 2.0, 0.0]))
    indefinite = jnp.stack([loop.plant.body.inertia, jnp.diag(jnp.array([20.0, -17.0, 15.0]))])
    with pytest.raises(ValueError, match=r"values\[1\] for `plant.body.inertia` .*positive-def"):
        mc.batch_field(loop, "plant.body.inertia", indefinite)
    # A cross-field rule: the perturbed inertia J0 + dJ(0) must stay positive definite.
    perturbations = mc.sinusoid_dispersion(
        jr.key(0), 2, loop.plant.body.inertia_perturbation, amplitude_scale=0.1, phase_spread=0.1
    )
    bad = eqx.tree_at(lambda s: s.offset, perturbations, perturbations.offset.at[1].add(-100.0))
    with pytest.raises(ValueError, match=r"values\[1\] for `plant.body.inertia_perturbation`"):
        mc.batch_field(loop, lambda m: m.plant.body.inertia_perturbation, bad)
    batched, _ = mc.batch_field(loop, "controller.k1", jnp.array([60.0, 70.0]))
    assert batched.controller.k1.shape == (2,)


def test_a_chattering_window_without_a_save_interval_is_refused_before_compiling():
    # Regression (audit): a window past the horizon, or between two saves, measured nothing
    # and reported a chattering of 0 for every sample ("no chattering").
    loop = mrp_pd_loop()
    x0s = MRPState(jnp.full((2, 3), 0.1), jnp.zeros((2, 3)))
    run = ft.partial(mc.monte_carlo, loop, x0s, 0.0, 1.0, dt=1e-2)
    for window in ((2.0, 3.0), (0.991, 0.999)):
        with pytest.raises(ValueError, match="'late' holds no interval between two save"):
            run(metrics={"late": Chattering("u", *window)})
    with pytest.raises(ValueError, match="saved every 0.5 s"):
        run(metrics={"late": Chattering("u", 0.2, 0.8)}, save_every=50)


def test_monte_carlo_configuration_errors(pd_batch):
    loop, x0s = pd_batch
    run = lambda **kw: mc.monte_carlo(
        kw.pop("loop", loop), kw.pop("x0s", x0s), 0.0, 1.0, dt=1e-2, **kw
    )
    with pytest.raises(ValueError, match="batch_size"):
        run(batch_size=0)
    with pytest.raises(ValueError, match="save_every"):
        run(save_every=0)
    with pytest.raises(ValueError, match="x0s"):
        run(x0s=(jnp.zeros((6, 3)), jnp.zeros((5, 3))))
    batched, axes = mc.batch_field(
        loop, lambda m: m.plant.body.inertia, jnp.stack([loop.plant.body.inertia] * 4)
    )
    with pytest.raises(ValueError, match="leading axis n = 6"):
        run(loop=batched, loop_axes=axes)
    with pytest.raises(ValueError, match="loop_axes"):
        run(loop_axes=eqx.tree_at(lambda a: a.plant.body.inertia, axes, 1))
    with pytest.raises(ValueError, match="unit quaternions"):
        mc.monte_carlo(
            chen.build("M1"),
            QuaternionState(jnp.ones((2, 4)), jnp.zeros((2, 3))),
            0.0,
            1.0,
            dt=1e-2,
        )
    # (The annotation says it too, so runtime type checking, on in this suite, would reject the
    # call itself; without it the check below catches the mistake.)
    from jaxatt.montecarlo._batch import _check_metrics

    with pytest.raises(ValueError, match="must be a jaxatt.metrics metric object"):
        _check_metrics("monte_carlo", {"u": lambda traj: traj.signals["u"][-1]})
    with pytest.raises(ValueError, match="`x0s.omega` must be finite"):
        run(x0s=eqx.tree_at(lambda x: x.omega, x0s, x0s.omega.at[2, 0].set(jnp.nan)))
    with pytest.raises(ValueError, match="`x0s.sigma` is float32 but the closed loop computes"):
        run(x0s=jax.tree.map(lambda x: x.astype(jnp.float32), x0s))
    with pytest.raises(ValueError, match="batch_field: `values` must be finite"):
        mc.batch_field(loop, "plant.body.inertia", jnp.full((6, 3, 3), jnp.nan))


def test_metrics_with_one_value_per_component(pd_batch):
    loop, x0s = pd_batch
    result = mc.monte_carlo(
        loop,
        x0s,
        0.0,
        10.0,
        dt=1e-2,
        metrics={
            "settling_axis": SettlingTime("attitude_error_vector", 1e-2, Absolute()),
            "peak_axis": Peak("u", Absolute()),
            "peak": Peak("u"),
        },
        keep_trajectories=True,
    )
    assert result.metrics["settling_axis"].shape == (6, 3)
    u = np.abs(np.asarray(result.trajectories.signals["u"]))
    np.testing.assert_allclose(result.metrics["peak_axis"], u.max(axis=1), rtol=1e-14)
    np.testing.assert_allclose(result.metrics["peak"], u.max(axis=(1, 2)), rtol=1e-14)
    with pytest.raises(ValueError, match="pass `component=`"):
        result.summary("peak_axis")
    s = result.summary("peak_axis", component=1)
    assert s["max"] == pytest.approx(u[:, :, 1].max())
    assert "| peak_axis[2] |" in result.table()
    assert set(result.to_dict()["metrics"]) >= {"peak_axis[0]", "peak_axis[1]", "peak_axis[2]"}
