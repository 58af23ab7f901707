"""The closed-loop contract's pieces: sampling with a delay, stateful actuators, the observer
slot, construction-time checks, dotted paths, and the library / applications split."""

import json
import re
import subprocess
import sys

import jax.numpy as jnp
import numpy as np
import pytest

import jaxatt
from jaxatt._paths import get_path, parse_path
from jaxatt.controllers import MRPPD, OpenLoop, QuaternionPD
from jaxatt.plants import MRPState, Pulse, QuaternionState, RigidBodyMRP, RigidBodyQuaternion
from jaxatt.references import NoReference
from jaxatt.signals import Constant, Sinusoid
from jaxatt.simulation import (
    ClosedLoop,
    Euler,
    FirstOrderLag,
    HeldOutputs,
    Saturation,
    ZeroOrderHold,
)

from ..helpers import J0, mrp_x0


def _open_loop(command, actuator=None):
    return ClosedLoop(RigidBodyMRP(J0), OpenLoop(command), actuator=actuator)


def test_zero_order_hold_with_a_one_period_delay():
    """The command computed at t_k acts over [t_{k+1}, t_{k+2}) (Basilisk's timing); over the
    first period the actuator receives zeros. An open-loop command is an oracle: the applied
    control at t is the command sampled one period before the start of t's period."""
    command = Sinusoid(jnp.array([1.0, -2.0, 0.5]), 3.0)
    loop = _open_loop(command)
    period, dt = 0.05, 0.01
    kwargs = dict(dt=dt, solver=Euler())
    held = jaxatt.simulate(loop, mrp_x0(), 0.0, 1.0, sampling=ZeroOrderHold(period), **kwargs)
    late = jaxatt.simulate(
        loop, mrp_x0(), 0.0, 1.0, sampling=ZeroOrderHold(period, delay=True), **kwargs
    )
    ts = np.asarray(held.ts)
    sample_start = np.floor(ts / period + 1e-9) * period
    expected_now = np.stack([np.asarray(command(t)) for t in sample_start])
    expected_late = np.stack(
        [np.asarray(command(t - period)) if t >= period else np.zeros(3) for t in sample_start]
    )
    np.testing.assert_allclose(held.signals["u"], expected_now, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(late.signals["u"], expected_late, rtol=1e-14, atol=1e-15)
    assert np.all(np.asarray(late.signals["u"])[ts < period] == 0)


def test_a_delayed_command_reaches_a_lag_one_period_late():
    """Under delay=True the actuator receives zeros over the first period: a lag starts at rest
    and follows the first command from t_1 (Euler, tau = dt = period: u_2 = u_cmd(t_0))."""
    # Regression: the lag's state started at the command computed at t_0, so the full torque
    # was applied over the first period, before that command had reached the actuator.
    command = Constant(jnp.array([1.0, -2.0, 0.5]))
    loop = _open_loop(command, FirstOrderLag(0.1))
    hold = ZeroOrderHold(0.1, delay=True)
    traj = jaxatt.simulate(loop, mrp_x0(), 0.0, 0.2, dt=0.1, sampling=hold, solver=Euler())
    np.testing.assert_allclose(traj.signals["u"], [[0.0] * 3, [0.0] * 3, [1.0, -2.0, 0.5]])


def test_first_order_lag_actuator_state_lives_in_the_loop():
    """tau u' = u_cmd - u from u(0) = u_cmd(0): a step of the command at t = 0.5 s is followed
    exponentially (RK4 at dt = 1e-3: error ~ 1e-12); the lag's state is the applied control."""
    tau = 0.2
    step = Pulse(jnp.array([1.0, 0.0, -2.0]), start=0.5, width=10.0)
    loop = _open_loop(step, FirstOrderLag(tau))
    traj = jaxatt.simulate(loop, mrp_x0(), 0.0, 1.5, dt=1e-3)
    ts = np.asarray(traj.ts)
    gain = np.where(ts >= 0.5, 1 - np.exp(-(ts - 0.5) / tau), 0.0)
    expected = gain[:, None] * np.array([1.0, 0.0, -2.0])
    # The step falls inside an RK4 step (the signal is discontinuous at 0.5): first-order
    # error there, about dt / tau.
    np.testing.assert_allclose(traj.signals["u"], expected, atol=5e-3)
    np.testing.assert_allclose(traj.actuator_states, traj.signals["u"], rtol=0, atol=0)
    on = ts >= 0.5
    np.testing.assert_array_equal(traj.signals["u_cmd"][on], [[1.0, 0.0, -2.0]] * int(on.sum()))


def test_a_chain_refuses_two_stages_recording_one_signal():
    # Regression: Chain.signals merged the stages' signals with dict.update, so with two
    # EnergyMeter stages "energy" silently held the last one's value. Eager: nothing compiles.
    from jaxatt.simulation import Chain, EnergyMeter

    chain = Chain(EnergyMeter(), EnergyMeter(Saturation(1.0)))
    command = jnp.array([2.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="Chain: two stages record the signal 'energy'"):
        chain.signals(0.0, command, chain.init(0.0, command))


def test_lag_then_saturation_in_a_chain():
    loop = ClosedLoop(
        RigidBodyMRP(J0),
        MRPPD(600.0, 500.0),
        actuator=jaxatt.simulation.Chain(FirstOrderLag(0.1), Saturation(30.0)),
    )
    traj = jaxatt.simulate(loop, mrp_x0(), 0.0, 1.0, dt=1e-3)
    assert np.max(np.abs(traj.signals["u"])) <= 30.0
    lagged, _ = traj.actuator_states
    assert np.max(np.abs(lagged)) > 30.0  # the lag's state is the unsaturated command


def test_the_held_outputs_hold_the_command_and_the_flight_derivatives():
    loop = jaxatt.scenarios.yu2022_ftac_mrp.build("FTAC", allow_inadmissible=False)
    y0 = loop.init(0.0, jaxatt.scenarios.yu2022_ftac_mrp.initial_state("admissible"))
    held = loop.hold(0.0, y0)
    assert isinstance(held, HeldOutputs)
    assert held.observer_dot is not None and held.command.shape == (3,)
    # With a hold, the observer's derivative is the held one: flight software at its rate.
    np.testing.assert_array_equal(
        loop.vector_field(0.0, y0, held).observer.d_hat, held.observer_dot.d_hat
    )


@pytest.mark.parametrize(
    "build, needle",
    [
        (
            lambda: ClosedLoop(RigidBodyQuaternion(J0), QuaternionPD(1.0, 1.0), NoReference()),
            "QuaternionPD reads AttitudeReference references, but NoReference produces NoneType",
        ),
        (
            lambda: ClosedLoop(RigidBodyMRP(J0), QuaternionPD(1.0, 1.0)),
            "QuaternionPD reads QuaternionState measurements, but the plant measures MRPState",
        ),
    ],
)
def test_construction_checks_name_the_components(build, needle):
    with pytest.raises(ValueError) as info:
        build()
    assert needle in str(info.value)


def test_a_signal_name_used_twice_is_an_error():
    class Shadowing(MRPPD):
        def signals(self, t, measurement, reference, state):
            return {"rate_error": measurement.omega}

    loop = ClosedLoop(RigidBodyMRP(J0), Shadowing(1.0, 1.0))
    with pytest.raises(ValueError, match="'rate_error' from the controller is already used"):
        jaxatt.simulate(loop, mrp_x0(), 0.0, 0.1, dt=0.05)


def test_dotted_paths():
    assert parse_path("controller.reaching_law.rho") == (
        ("attr", "controller"),
        ("attr", "reaching_law"),
        ("attr", "rho"),
    )
    assert parse_path("terms[1]['a'].x") == (
        ("attr", "terms"),
        ("item", 1),
        ("item", "a"),
        ("attr", "x"),
    )
    loop = ClosedLoop(RigidBodyMRP(J0), MRPPD(1.0, 2.0))
    assert float(get_path(loop, "controller.k2")) == 2.0
    for bad, why in (
        ("", "must be a non-empty string"),
        ("a..b", "empty segment in 'a..b'"),
        ("a.[0]", "cannot parse 'a.[0]' at character 2"),
        ("a.b[x]", "cannot parse 'a.b[x]' at character 3"),
        ("1a", "cannot parse '1a' at character 0"),
    ):
        with pytest.raises(ValueError, match=re.escape(why)):
            parse_path(bad)


def test_import_jaxatt_loads_the_core_only():
    code = (
        "import sys, json, jaxatt; "
        "print(json.dumps({m: m in sys.modules for m in "
        "('optax', 'matplotlib', 'jaxatt.scenarios', 'jaxatt.tune', 'jaxatt.plot')}))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {
        "optax": False,
        "matplotlib": False,
        "jaxatt.scenarios": False,
        "jaxatt.tune": False,
        "jaxatt.plot": False,
    }
    assert jaxatt.tune.tune is not None  # and they load on first use


def test_scenarios_follow_one_typed_protocol():
    from jaxatt.scenarios import REGISTRY, TUNING, Scenario, TuningProblem

    assert set(REGISTRY) == {
        "rigid_body_pd",
        "chen2022",
        "yu2022",
        "zhang2021",
        "duan2024",
        "shi2024",
        "zhang2017",
        "yue2018",
        "flyaround",
        "wu2018",
    }
    for name, scenario in REGISTRY.items():
        assert isinstance(scenario, Scenario) and scenario.name == name and scenario.title
        loop = scenario.build()
        assert isinstance(loop, jaxatt.AbstractClosedLoop)
        assert callable(scenario.reproduce) and callable(scenario.metrics)
    assert set(TUNING) == {"chen2022", "zhang2021", "zhang2021-finite-time", "shi2024"}
    assert all(isinstance(problem, TuningProblem) for problem in TUNING.values())
    assert "jaxatt.bench" not in sys.modules
    with pytest.raises(ImportError):  # benchmark kernels live in benchmarks/, not the wheel
        __import__("jaxatt.bench")


def test_mrp_and_quaternion_states_are_the_plant_measurements():
    assert RigidBodyMRP.measurement_type is MRPState
    assert RigidBodyQuaternion.measurement_type is QuaternionState
    loop = ClosedLoop(RigidBodyMRP(J0), MRPPD(1.0, 1.0))
    traj = jaxatt.simulate(loop, mrp_x0(), 0.0, 0.1, dt=0.05, solver=Euler())
    assert set(traj.signals) >= {
        "u",
        "u_cmd",
        "attitude_error",
        "attitude_error_vector",
        "attitude_error_angle",
        "rate_error",
        "disturbance",
    }
    angle = np.asarray(traj.signals["attitude_error_angle"])
    sigma = np.linalg.norm(np.asarray(traj.signals["attitude_error_vector"]), axis=1)
    np.testing.assert_allclose(angle, 4 * np.arctan(sigma), rtol=1e-12)  # phi = 4 atan |s|
