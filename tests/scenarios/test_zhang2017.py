"""Zhang 2017 (SPEC 001(e)): PD reaching times against the closed form of the reaching law,
the short reproduction's metrics, gradients of the convergence time, bad input."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.metrics import settling_time
from jaxatt.reaching import Saturation
from jaxatt.scenarios import zhang2017
from jaxatt.simulation import Continuous, Status, ZeroOrderHold, simulate


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    out = tmp_path_factory.mktemp("zhang2017")
    metrics = zhang2017.reproduce(out, short=True)
    return out, metrics


def test_short_reproduction_writes_metrics_and_figures(short):
    out, metrics = short
    on_disk = json.loads((out / "metrics.json").read_text())
    # The returned dict is the file (scenarios/_io.py): the ratio of a time that never came
    # (PD^alpha is not inside 1 m by 20 s) was inf in the dict and null in the file.
    assert on_disk == metrics
    assert metrics["claims"]["undisturbed"]["settle_time_ratio_pd_alpha_over_pd"] is None
    for case in zhang2017.CASES:
        for name in zhang2017.CONTROLLERS:
            m = on_disk[case][name]
            for key in (
                "settle_time_10m",
                "settle_time_1m",
                "final_position_norm",
                "energy",
                "peak_control",
            ):
                assert key in m
            assert m["status"] == 0
    # Both laws bring the chaser inside 10 m; PD inside 1 m within the 20 s, PD^alpha only at
    # 101.5 s. The short run is the full one cut at 20 s (same step, hold and full memory), so
    # its times are the gallery's (docs/gallery/zhang2017.md, undisturbed / disturbed), printed
    # to 2 decimals; the width 0.01 s is that rounding plus as much again, as notebook 07
    # asserts the undisturbed ones. Last exits interpolated between saves (0.01 s for PD,
    # 0.5 s for PD^alpha), so the values are deterministic to rounding.
    expected = {
        "undisturbed": {"pd": (5.74, 10.35), "pd_alpha": 10.74},
        "disturbed": {"pd": (5.73, 10.34), "pd_alpha": 10.77},
    }
    for case, e in expected.items():
        pd, fr = on_disk[case]["pd"], on_disk[case]["pd_alpha"]
        assert pd["settle_time_10m"] == pytest.approx(e["pd"][0], abs=0.01), case
        assert pd["settle_time_1m"] == pytest.approx(e["pd"][1], abs=0.01), case
        assert fr["settle_time_10m"] == pytest.approx(e["pd_alpha"], abs=0.01), case
        assert fr["settle_time_1m"] is None, case  # not inside 1 m by 20 s
    # SPEC 001(e)'s claims. Reproduced: PD^alpha consumes more energy (1.41x / 1.38x over
    # 200 s; notebook 07 asserts it in short mode too). Not reproduced: "PD^alpha needs much
    # less control time": it is slower to 10 m and never inside 1 m in the 20 s (the gallery
    # explains why: the Mittag-Leffler tail of the fractional surface).
    for case in zhang2017.CASES:
        claims = on_disk["claims"][case]
        assert claims["pd_alpha_consumes_more_energy"], case
        assert not claims["pd_alpha_needs_less_control_time"], case
        pd, fr = on_disk[case]["pd"], on_disk[case]["pd_alpha"]
        assert fr["settle_time_10m"] > pd["settle_time_10m"], case  # 10.7 against 5.7 s
    assert sorted(p.name for p in out.glob("*.png")) == [
        "fig_control_disturbed.png",
        "fig_control_undisturbed.png",
        "fig_state_disturbed.png",
        "fig_state_undisturbed.png",
    ]


def test_held_control_reaching_times_within_the_discretisation_bound(short):
    """Under the paper's held control (h = 0.01 s) the reaching law is followed in its
    sampled form: |T_held - T| <= T k h / 2 + h (forward Euler's rate error plus one step)."""
    _, metrics = short
    m = metrics["undisturbed"]["pd"]
    closed = np.asarray(m["reaching_time_closed_form"])
    measured = np.asarray(m["reaching_time_axis"])
    # s = c e + e' with jaxatt's e = rho (SPEC writes e = -rho; the module docstring says why
    # only the sign of s differs)
    np.testing.assert_allclose(m["s0"], [-35.0, 27.5, -33.0])
    bound = closed * zhang2017.K * zhang2017.STEP / 2 + zhang2017.STEP
    assert np.all(np.abs(measured - closed) <= bound)
    assert np.all(np.abs(measured - closed) > 1e-4)  # the hold does change them


def test_continuous_control_reaching_times_match_the_closed_form_to_1e_6():
    loop = zhang2017.build("pd")
    dt = 5e-4
    traj = simulate(loop, zhang2017.initial_state(), 0.0, 5.0, dt=dt, sampling=Continuous())
    # Under continuous control RK4 holds |s| near 1e-5 after reaching (the stages straddle
    # s = 0): the crossing is extrapolated from the two samples before a band of eps dt / 2;
    # that errs by about 2 k dt^2 = 5e-7 s.
    band = zhang2017.EPS * dt / 2
    measured = zhang2017.first_zero_times(traj.ts, traj.signals["s"], band)
    closed = zhang2017.reaching_time_closed_form(traj.signals["s"][0])
    np.testing.assert_allclose(measured, closed, rtol=0, atol=1e-6)


def _settle(controller, horizon, tol, **gains):
    loop = zhang2017.build(controller, horizon=horizon, switching=Saturation(0.05), **gains)
    traj = simulate(
        loop,
        zhang2017.initial_state(),
        0.0,
        horizon,
        dt=0.01,
        sampling=ZeroOrderHold(0.01),
        save_every=1,
        throw=False,
    )
    return settling_time(traj.ts, traj.signals["position_norm"], tol)


@pytest.mark.parametrize(
    ("controller", "horizon", "tol", "names"),
    [("pd", 6.5, 10.0, ("slope", "k", "eps")), ("pd_alpha", 4.0, 40.0, ("alpha",))],
)
def test_gradients_of_the_convergence_time_match_finite_differences(
    controller, horizon, tol, names
):
    base = {"slope": 0.5, "k": 1.0, "eps": 0.3, "alpha": 0.8}

    def time(values):
        return _settle(controller, horizon, tol, **{**base, **dict(zip(names, values))})

    # One compiled program gives both the value and the derivative along a direction.
    value_and_derivative = jax.jit(lambda x, v: jax.jvp(time, (x,), (v,)))
    x = jnp.array([base[n] for n in names])
    for i in range(len(names)):
        direction = jnp.eye(len(names))[i]
        _, derivative = value_and_derivative(x, direction)
        plus, _ = value_and_derivative(x + 1e-5 * direction, direction)
        minus, _ = value_and_derivative(x - 1e-5 * direction, direction)
        assert np.isfinite(derivative)
        np.testing.assert_allclose(derivative, (plus - minus) / 2e-5, rtol=1e-3, atol=1e-6)


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"alpha": 1.0}, r"`alpha` must lie in \(0.0, 1.0\)"),
        ({"alpha": 0.0}, r"`alpha` must lie in \(0.0, 1.0\)"),
        ({"memory": 300.0}, "`memory` must not exceed the horizon"),
        ({"memory": 0.001}, "`memory` must be at least one step"),
    ],
)
def test_bad_fractional_options_are_refused(options, match):
    with pytest.raises(ValueError, match=match):
        zhang2017.build("pd_alpha", **options)


def test_running_past_a_full_memory_is_reported_not_truncated_silently():
    loop = zhang2017.build("pd_alpha", horizon=0.05)
    traj = simulate(
        loop,
        zhang2017.initial_state(),
        0.0,
        0.1,
        dt=0.01,
        sampling=ZeroOrderHold(0.01),
        throw=False,
    )
    assert int(traj.status) == Status.constraint_violated
    # Memory for t = 0 ... 0.05 s (6 samples); the 7th is pushed at the sample instant
    # t = 0.06 s, and the status is checked at the end of that step.
    assert float(traj.failure_time) == pytest.approx(0.07)


def test_a_failed_run_supports_no_comparison():
    # Regression (review): a failed PD run (its settle time never: None) made PD^alpha "need
    # less control time" (ratio 0) instead of supporting no claim; and the ratios themselves
    # (0.0 for the time, 2.0 for the energy) were written as numbers (audit, stop 49): None.
    pd = {"settle_time_1m": None, "energy": 10.0, "status": 1}
    fr = {"settle_time_1m": 8.0, "energy": 20.0, "status": 0}
    claims = zhang2017.claims({case: {"pd": pd, "pd_alpha": fr} for case in zhang2017.CASES})
    for case in zhang2017.CASES:
        assert claims[case]["settle_time_ratio_pd_alpha_over_pd"] is None
        assert claims[case]["energy_ratio_pd_alpha_over_pd"] is None
        assert not claims[case]["pd_alpha_needs_less_control_time"]
        assert not claims[case]["pd_alpha_consumes_more_energy"]
