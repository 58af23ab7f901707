"""`monte_carlo` and `batch_field`: equal to a Python loop of `simulate`, failures counted,
chunking, batched closed-loop fields, one compilation for 4096 samples, and the summaries."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest

import jaxatt
from jaxatt import montecarlo as mc
from jaxatt.plants import MRPState, QuaternionState
from jaxatt.scenarios import chen2022_two_phase_power as chen
from jaxatt.simulation import RESULTS, Euler

from ..helpers import mrp_pd_loop


N = 5
HORIZON, DT, SAVE_EVERY = 3.0, 5e-3, 4
BAD = 3  # the sample with a NaN initial rate


mrps_from_quats = jax.jit(jax.vmap(jaxatt.rotations.mrp_from_quat))


def _index(tree, k):
    return jax.tree.map(lambda x: x[k], tree)


@pytest.fixture(scope="module")
def chen_batch():
    """Chen 2022 M1 with dispersed inertia and disturbance, one sample with a NaN rate."""
    loop = chen.build("M1")
    keys = jr.split(jr.key(0), 4)
    x0s = QuaternionState(
        mc.attitudes_within(keys[0], N, jnp.pi / 3), mc.rates_in_ball(keys[1], N, 0.05)
    )
    x0s = eqx.tree_at(lambda x: x.omega, x0s, x0s.omega.at[BAD, 1].set(jnp.nan))
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
        assert int(traj.result._value) == int(result.result._value[k])
        if k == BAD:
            continue
        expected = mc.default_metrics(traj)
        for name, value in expected.items():
            np.testing.assert_allclose(result.metrics[name][k], value, rtol=1e-10, err_msg=name)
        np.testing.assert_allclose(
            result.trajectories.states.plant.q[k], traj.states.plant.q, rtol=1e-10, atol=1e-13
        )


def test_scalarized_batch_equals_the_plain_batch(chen_batch):
    # scalarize=True (the default for large batches) changes the layout, not the numbers:
    # batched loop fields, the failing sample and the metrics must all come out the same.
    loop, x0s, inertias, disturbances, plain = chen_batch
    batched, axes = mc.batch_field(loop, lambda m: m.plant.body.inertia, inertias)
    batched, axes = mc.batch_field(batched, lambda m: m.plant.body.disturbance, disturbances, axes)
    fast = mc.monte_carlo(
        batched, x0s, 0.0, HORIZON, dt=DT, loop_axes=axes, save_every=SAVE_EVERY, scalarize=True
    )
    np.testing.assert_array_equal(fast.result._value, plain.result._value)
    ok = np.asarray(plain.successful)
    for name, value in plain.metrics.items():
        np.testing.assert_allclose(
            np.asarray(fast.metrics[name])[ok], np.asarray(value)[ok], rtol=1e-9, err_msg=name
        )


def test_default_scalarization_rule():
    assert mc.SCALARIZE_FROM == 1000
    assert not mc.default_scalarize(999) and mc.default_scalarize(1000)
    assert not mc.default_scalarize(4000, batch_size=500)  # lax.map runs 500 at a time
    assert not mc.default_scalarize(1500, devices=2) and mc.default_scalarize(2000, devices=2)


def test_batched_fields_really_differ_between_samples(chen_batch):
    # Guard for the test above: with one shared inertia the loop comparison would be vacuous.
    _, _, inertias, _, result = chen_batch
    assert not np.allclose(inertias[0], inertias[1])
    effort = np.asarray(result.metrics["effort"])[np.asarray(result.successful)]
    assert len(set(np.round(effort, 6))) == N - 1


def test_a_failing_sample_is_counted_and_the_others_finish(chen_batch):
    *_, result = chen_batch
    ok = np.asarray(result.successful)
    assert not ok[BAD] and ok.sum() == N - 1
    assert int(result.result._value[BAD]) == int(RESULTS.nonfinite_state._value)
    settling = np.asarray(result.metrics["settling_time"])
    assert np.all(settling[ok] > 0.5) and np.all(settling[ok] < HORIZON)
    assert np.all(np.isfinite(np.asarray(result.metrics["effort"])[ok]))
    summary = result.summary("settling_time")
    assert summary["failed"] == 1
    assert summary["results"] == {"successful": 4, "nonfinite_state": 1, "constraint_violated": 0}
    assert summary["finite"] == N - 1
    assert summary["worst"] == math.inf and summary["worst_index"] == BAD
    assert summary["success_rate"] == pytest.approx((N - 1) / N)
    good = settling[ok]
    assert summary["mean"] == pytest.approx(good.mean(), rel=1e-14)
    assert summary["std"] == pytest.approx(good.std(ddof=1), rel=1e-12)
    assert summary["max"] == pytest.approx(good.max(), rel=1e-14)


def test_summary_tolerance_recomputes_settling_from_trajectories(chen_batch):
    *_, result = chen_batch
    same = result.summary("settling_time", tolerance=1e-2)  # default_metrics' tolerance
    assert same["mean"] == pytest.approx(result.summary("settling_time")["mean"], rel=1e-12)
    tighter = result.summary("settling_time", tolerance=1e-3)
    assert tighter["min"] > same["min"]
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
        result=jax.vmap(lambda f: RESULTS.where(f, RESULTS.nonfinite_state, RESULTS.successful))(
            failed
        ),
    )
    s = result.summary(quantiles=(0.0, 0.5, 1.0), time_limit=3.0)
    assert (s["count"], s["failed"], s["nonfinite"], s["finite"]) == (6, 1, 2, 3)
    assert s["mean"] == pytest.approx(7 / 3)
    assert s["std"] == pytest.approx(np.std([1.0, 2.0, 4.0], ddof=1))
    assert s["quantiles"] == {0.0: 1.0, 0.5: 2.0, 1.0: 4.0}
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
    with pytest.raises(ValueError, match="keep_trajectories"):
        result.summary(tolerance=1e-3)
    with pytest.raises(ValueError, match="quantiles"):
        result.summary(quantiles=(1.5,))


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
    with pytest.raises(ValueError, match="scalar"):
        run(metrics=lambda traj: {"u": traj.signals["u"][-1]})
