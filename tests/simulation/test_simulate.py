"""`simulate`: accuracy against SciPy, batching, compilation, sampling, errors."""

import re
from typing import ClassVar

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest
from scipy.integrate import solve_ivp

import jaxatt
from jaxatt.controllers import MRPPD, AbstractController, QuaternionPD
from jaxatt.plants import (
    Constant,
    MRPState,
    QuaternionState,
    RigidBodyMRP,
    RigidBodyQuaternion,
    Sinusoid,
)
from jaxatt.references import ConstantAttitude, IntegratedReference
from jaxatt.simulation import (
    ClosedLoop,
    Euler,
    FirstOrderLag,
    NormSaturation,
    Saturation,
    Simulation,
    ZeroOrderHold,
)

from ..helpers import D_AMPLITUDE, D_FREQUENCY, J0, Q0, mrp_pd_loop, mrp_x0, quat_pd_loop, quat_x0


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _true_inertia(t):
    return J0 + np.diag([np.sin(0.1 * t), 2 * np.sin(0.2 * t), 3 * np.sin(0.3 * t)])


def _disturbance(t):
    return D_AMPLITUDE * np.sin(D_FREQUENCY * t)


def test_mrp_pd_matches_scipy_with_time_varying_inertia_and_disturbance():
    k1, k2 = 17.0, 15.0
    x0 = mrp_x0()
    traj = jaxatt.simulate(mrp_pd_loop(k1, k2), x0, 0.0, 20.0, dt=1e-3, save_every=500)

    def rhs(t, x):  # written out independently of the library
        s, w = x[:3], x[3:]
        G = 0.25 * ((1 - s @ s) * np.eye(3) + 2 * _skew(s) + 2 * np.outer(s, s))
        u = -k1 * s - k2 * w
        J = _true_inertia(t)
        return np.concatenate(
            [G @ w, np.linalg.solve(J, -np.cross(w, J @ w) + u + _disturbance(t))]
        )

    y0 = np.concatenate([np.asarray(x0.sigma), np.asarray(x0.omega)])
    ref = solve_ivp(
        rhs, (0, 20), y0, t_eval=np.asarray(traj.ts), rtol=1e-11, atol=1e-13, method="DOP853"
    )
    ours = np.concatenate([traj.plant_states.sigma, traj.plant_states.omega], axis=1)
    np.testing.assert_allclose(ours, ref.y.T, atol=1e-8, rtol=0)
    assert np.max(np.abs(ours[-1] - ours[0])) > 0.05  # the run actually moved


def test_quaternion_tracking_matches_scipy():
    """Quaternion PD tracking Chen 2022's integrated reference, against SciPy (eqs 5-10 by hand)."""
    kp, kd, wd_amp = 20.0, 40.0, 0.05
    omega_d = Sinusoid(wd_amp * jnp.ones(3), jnp.pi * jnp.array([0.01, 0.02, 0.03]))
    reference = IntegratedReference(jnp.array([1.0, 0, 0, 0]), omega_d)
    loop = ClosedLoop(quat_pd_loop(kp, kd).plant, QuaternionPD(kp, kd), reference)
    x0 = quat_x0()
    traj = jaxatt.simulate(loop, x0, 0.0, 15.0, dt=1e-3, save_every=500)

    def wd(t):
        return wd_amp * np.sin(np.pi * np.array([0.01, 0.02, 0.03]) * t)

    def quat_dot(q, w):
        q0, qv = q[0], q[1:]
        return 0.5 * np.concatenate([[-qv @ w], q0 * w + np.cross(qv, w)])

    def rhs(t, x):
        q, w, qd = x[:4], x[4:7], x[7:]
        e0 = qd[1:] @ q[1:] + q[0] * qd[0]  # Chen eq (7)
        ev = qd[0] * q[1:] - _skew(qd[1:]) @ q[1:] - q[0] * qd[1:]  # eq (8)
        C = (1 - 2 * ev @ ev) * np.eye(3) + 2 * np.outer(ev, ev) - 2 * e0 * _skew(ev)  # eq (10)
        ew = w - C @ wd(t)  # eq (9)
        u = -kp * ev - kd * ew
        J = _true_inertia(t)
        w_dot = np.linalg.solve(J, -np.cross(w, J @ w) + u + _disturbance(t))
        return np.concatenate([quat_dot(q, w), w_dot, quat_dot(qd, wd(t))])

    y0 = np.concatenate([np.asarray(x0.q), np.asarray(x0.omega), [1.0, 0, 0, 0]])
    ref = solve_ivp(
        rhs, (0, 15), y0, t_eval=np.asarray(traj.ts), rtol=1e-11, atol=1e-13, method="DOP853"
    )
    ours = np.concatenate(
        [traj.plant_states.q, traj.plant_states.omega, traj.reference_states], axis=1
    )
    np.testing.assert_allclose(ours, ref.y.T, atol=1e-8, rtol=0)


@pytest.fixture(scope="module")
def batch_inputs():
    rng = np.random.default_rng(0)
    axes = rng.normal(size=(64, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = rng.uniform(0, 2.5, size=64)
    q = np.concatenate([np.cos(angles / 2)[:, None], np.sin(angles / 2)[:, None] * axes], axis=1)
    sigma = q[:, 1:] / (1 + q[:, :1])
    omega = rng.uniform(-0.05, 0.05, size=(64, 3))
    return MRPState(jnp.asarray(sigma), jnp.asarray(omega))


def test_vmap_over_initial_conditions_equals_loop(batch_inputs):
    loop = mrp_pd_loop(17.0, 15.0)

    def run(x0):
        return jaxatt.simulate(loop, x0, 0.0, 5.0, dt=0.01, save_every=50, throw=False)

    batched = jax.vmap(run)(batch_inputs)
    assert batched.ts.shape == (64, 11)
    assert bool(jnp.all(batched.successful))
    for i in range(0, 64, 7):
        single = run(jax.tree_util.tree_map(lambda x: x[i], batch_inputs))
        np.testing.assert_allclose(
            batched.plant_states.sigma[i], single.plant_states.sigma, rtol=1e-12, atol=1e-14
        )
        np.testing.assert_allclose(
            batched.signals["u"][i], single.signals["u"], rtol=1e-12, atol=1e-14
        )


class _TraceCounting(AbstractController):
    """Wraps a controller and counts how often JAX traces it (a test-only probe)."""

    inner: AbstractController
    counter: list = eqx.field(static=True)
    measurement_type: ClassVar[type] = object

    def init(self, t0, measurement, reference):
        return self.inner.init(t0, measurement, reference)

    def __call__(self, t, measurement, reference, state):
        self.counter.append(1)
        return self.inner(t, measurement, reference, state)

    def signals(self, t, measurement, reference, state):
        return self.inner.signals(t, measurement, reference, state)


def test_changing_gain_values_does_not_recompile():
    counter: list = []
    plant = mrp_pd_loop().plant

    def run(k1, k2):
        loop = ClosedLoop(plant, _TraceCounting(MRPPD(k1, k2), counter))
        return jaxatt.simulate(loop, mrp_x0(), 0.0, 1.0, dt=0.1)

    a = run(1.0, 2.0)
    traces_first = len(counter)
    assert traces_first > 0
    b = run(3.0, 5.0)
    assert len(counter) == traces_first  # same compiled program, new gain values
    assert not np.allclose(a.plant_states.omega, b.plant_states.omega)


def _settling_loss(loop, x0):
    traj = jaxatt.simulate(loop, x0, 0.0, 30.0, dt=0.01)
    error = jaxatt.numerics.safe_norm(traj.signals["attitude_error"])
    return jaxatt.metrics.settling_time(traj.ts, error, 1e-3)


def test_gradient_of_settling_time_matches_finite_differences():
    # Without d(t) (whose steady error d/k1 would keep the error above 1e-3 forever).
    loop = mrp_pd_loop(17.0, 15.0, uncertain=False)
    x0 = mrp_x0()
    loss = eqx.filter_jit(_settling_loss)
    grads = eqx.filter_grad(loss)(loop, x0)
    t_settle = float(loss(loop, x0))
    assert 5.0 < t_settle < 29.0

    def fd(where, direction, h):
        plus = eqx.tree_at(where, loop, where(loop) + h * direction)
        minus = eqx.tree_at(where, loop, where(loop) - h * direction)
        return (float(loss(plus, x0)) - float(loss(minus, x0))) / (2 * h)

    for where, direction, h in [
        (lambda m: m.controller.k1, 1.0, 1e-4),
        (lambda m: m.controller.k2, 1.0, 1e-4),
        (lambda m: m.plant.body.inertia, jnp.array([[1.0, 0, 0], [0, 0, 0], [0, 0, 0]]), 1e-4),
        (lambda m: m.plant.body.inertia, jnp.array([[0.0, 1, 0], [1, 0, 0], [0, 0, 0]]), 1e-4),
    ]:
        analytic = float(jnp.sum(where(grads) * direction))
        numeric = fd(where, direction, h)
        assert np.isfinite(analytic)
        assert abs(analytic - numeric) <= 1e-5 * abs(numeric), (analytic, numeric)


def test_zero_order_hold_converges_to_continuous_at_first_order():
    loop = mrp_pd_loop(17.0, 15.0)
    x0 = mrp_x0()

    def final_state(sampling):
        traj = jaxatt.simulate(loop, x0, 0.0, 4.0, dt=1e-3, sampling=sampling, save_every=100)
        return np.concatenate([traj.plant_states.sigma, traj.plant_states.omega], axis=1)

    continuous = final_state(jaxatt.simulation.Continuous())
    errors = [
        np.max(np.abs(final_state(ZeroOrderHold(p)) - continuous)) for p in (0.04, 0.02, 0.01)
    ]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    # A zero-order hold is a first-order approximation: halving the period halves the error.
    assert all(1.8 < r < 2.2 for r in ratios), (errors, ratios)


def test_zero_order_hold_holds_the_control():
    traj = jaxatt.simulate(
        mrp_pd_loop(17.0, 15.0), mrp_x0(), 0.0, 1.0, dt=0.01, sampling=ZeroOrderHold(0.1)
    )
    u = np.asarray(traj.signals["u"])
    for k in range(10):  # constant inside each period, changing between periods
        block = u[10 * k : 10 * k + 10]
        assert np.allclose(block, block[0], atol=0, rtol=0)
    assert not np.allclose(u[0], u[10])


def test_saturation_limits_applied_control():
    loop = mrp_pd_loop(170.0, 150.0)
    sat = ClosedLoop(loop.plant, loop.controller, actuator=Saturation(0.5))
    traj = jaxatt.simulate(sat, mrp_x0(), 0.0, 2.0, dt=0.01)
    assert np.max(np.abs(traj.signals["u"])) <= 0.5 + 1e-15
    assert np.max(np.abs(traj.signals["u_cmd"])) > 1.0
    norm_limited = ClosedLoop(loop.plant, loop.controller, actuator=NormSaturation(0.5))
    traj = jaxatt.simulate(norm_limited, mrp_x0(), 0.0, 2.0, dt=0.01)
    assert np.max(np.linalg.norm(traj.signals["u"], axis=1)) <= 0.5 + 1e-12


def test_diffrax_solver_and_euler_agree_with_rk4():
    loop = mrp_pd_loop(17.0, 15.0)

    def final(solver, dt):
        traj = jaxatt.simulate(
            loop, mrp_x0(), 0.0, 2.0, dt=dt, solver=solver, save_every=round(2 / dt)
        )
        return np.asarray(traj.plant_states.omega[-1])

    rk4 = final(jaxatt.simulation.RK4(), 1e-3)
    np.testing.assert_allclose(final(dfx.Tsit5(), 1e-2), rk4, atol=1e-9)
    euler_error = [np.max(np.abs(final(Euler(), dt) - rk4)) for dt in (2e-3, 1e-3)]
    assert 1.8 < euler_error[0] / euler_error[1] < 2.2  # first order


def test_nonfinite_state_is_reported_not_silent():
    # A stiff rate gain with a step far beyond RK4's stability limit: the state blows up.
    loop = ClosedLoop(RigidBodyMRP(jnp.asarray(J0)), MRPPD(1.0, 1e5))
    traj = jaxatt.simulate(loop, mrp_x0(), 0.0, 20.0, dt=0.1, throw=False)
    assert traj.status == jaxatt.Status.nonfinite_state
    # The failure is timed: the first completed step whose state is not finite.
    first_bad = np.flatnonzero(~np.all(np.isfinite(np.asarray(traj.plant_states.omega)), axis=1))
    assert float(traj.failure_time) == pytest.approx(float(traj.ts[first_bad[0]]))
    with pytest.raises(jaxatt.SimulationFailed, match="nonfinite_state at t = .* NaN or infinite"):
        jaxatt.simulate(loop, mrp_x0(), 0.0, 20.0, dt=0.1)


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        (dict(dt=0.0), "`dt` must be positive"),
        (dict(dt=-0.1), "`dt` must be positive"),
        (dict(t1=0.0), "`t1` must be greater than `t0`"),
        (dict(t1=1.05), "whole multiple of `dt`"),
        (dict(save_every=3), "`save_every` must divide"),
        (dict(sampling=ZeroOrderHold(0.15)), "`period` must be a whole multiple of `dt`"),
        # Built with tree_at: runtime type checking (on in this suite) would reject the
        # constructor call itself; without it, `simulate` must catch the mistake.
        (
            dict(x0=eqx.tree_at(lambda s: s.sigma, mrp_x0(), jnp.zeros(4))),
            "`x0.sigma` must have shape (3,)",
        ),
        (
            dict(x0=eqx.tree_at(lambda s: s.omega, mrp_x0(), jnp.zeros(2))),
            "`x0.omega` must have shape (3,)",
        ),
        (dict(x0=QuaternionState(jnp.array([1.0, 0, 0, 0]), jnp.zeros(3))), "must be an MRPState"),
        # Regression: a NaN initial state ran the whole horizon and was then reported as
        # "the loop diverged or dt is too large".
        (
            dict(x0=eqx.tree_at(lambda s: s.omega, mrp_x0(), jnp.array([0.0, jnp.nan, 0.0]))),
            "`x0.omega` must be finite",
        ),
        (
            dict(x0=eqx.tree_at(lambda s: s.sigma, mrp_x0(), jnp.array([jnp.inf, 0.0, 0.0]))),
            "`x0.sigma` must be finite",
        ),
    ],
)
def test_bad_simulation_arguments_raise(kwargs, needle):
    args = dict(x0=mrp_x0(), t1=1.0, dt=0.1)
    args.update(kwargs)
    x0, t1 = args.pop("x0"), args.pop("t1")
    with pytest.raises(ValueError) as info:
        jaxatt.simulate(mrp_pd_loop(), x0, 0.0, t1, **args)
    assert needle in str(info.value)


@pytest.mark.parametrize(
    "kwargs, needle",
    [
        (dict(throw="False"), "simulate: `throw` must be True or False, got 'False'"),
        (dict(throw=None), "simulate: `throw` must be True or False, got None"),
        (dict(checkpoint=1.0), "`checkpoint` must be True, False or 'recursive', got 1.0"),
        (dict(checkpoint=0), "`checkpoint` must be True, False or 'recursive', got 0"),
    ],
)
def test_flags_must_be_booleans(kwargs, needle, no_jaxtyping):
    # Regression: the flags were read with `bool` and `in`: throw="False" threw, throw=None did
    # not, and checkpoint=1, 0 or 1.0 passed as True or False. (The suite's type checking
    # rejects them at the annotation; users meet these checks, before anything is compiled.)
    with pytest.raises(ValueError, match=re.escape(needle)):
        jaxatt.simulate(mrp_pd_loop(), mrp_x0(), 0.0, 1.0, dt=0.1, **kwargs)


@pytest.mark.parametrize(
    "solver, needle",
    [
        (dfx.ImplicitEuler(), "ImplicitEuler's root finder takes its tolerances from an adaptive"),
        (dfx.Kvaerno5(), "Kvaerno5's root finder takes its tolerances from an adaptive"),
        (dfx.KenCarp3(), "KenCarp3 integrates several terms"),
        (dfx.SemiImplicitEuler(), "SemiImplicitEuler integrates several terms"),
        (dfx.EulerHeun(), "EulerHeun integrates several terms"),
    ],
)
def test_diffrax_solvers_that_cannot_run_at_a_fixed_step_are_refused(solver, needle):
    # Regression: they failed inside the trace with "Type of `other` not understood", a bare
    # AssertionError or an unpacking error. Now refused before anything is traced.
    with pytest.raises(ValueError, match=re.escape(needle)):
        Simulation(0.0, 1.0, 0.1, solver=solver)
    # With explicit tolerances an implicit solver runs (constructing is enough here).
    Simulation(0.0, 1.0, 0.1, solver=dfx.ImplicitEuler(root_finder=optx.Chord(1e-8, 1e-8)))


def test_energy_meter_needs_an_actuator(no_jaxtyping):
    # Regression: EnergyMeter(30.0) (a limit meant for Saturation) was accepted and failed
    # while tracing with "'float' object has no attribute 'init'".
    with pytest.raises(ValueError, match="EnergyMeter: `inner` must be an actuator model"):
        jaxatt.simulation.EnergyMeter(30.0)


def test_array_time_arguments_are_rejected_with_a_reason():
    # The annotation says `float`; without runtime type checking the check below catches it.
    from jaxatt.simulation._settings import _check_time

    with pytest.raises(ValueError, match="simulate: `dt` must be a Python number"):
        _check_time("simulate", "dt", jnp.array(0.1))


def test_non_unit_initial_quaternion_raises():
    with pytest.raises(ValueError, match="`x0.q` must be a unit quaternion"):
        jaxatt.simulate(
            quat_pd_loop(),
            QuaternionState(jnp.array([0.8832, 0.3, -0.2, -0.3]) * 1.01, jnp.zeros(3)),
            0.0,
            1.0,
            dt=0.1,
        )
    # Chen 2022's printed q(0) (norm 1.000021) is outside the 1e-6 tolerance too: normalize it.
    with pytest.raises(ValueError, match="normalize it first"):
        RigidBodyQuaternion(jnp.asarray(J0)).check_state(
            QuaternionState(jnp.array([0.8832, 0.3, -0.2, -0.3]), jnp.zeros(3))
        )
    assert np.isclose(np.linalg.norm(Q0), 1)


@pytest.mark.parametrize(
    "build, needle",
    [
        (lambda: MRPPD(-1.0, 1.0), "MRPPD: `k1` must be positive"),
        (lambda: MRPPD(1.0, 0.0), "MRPPD: `k2` must be positive"),
        (
            lambda: QuaternionPD(1.0, jnp.array([1.0, -2.0, 1.0])),
            "QuaternionPD: `kd` must be positive",
        ),
        (lambda: Saturation(0.0), "Saturation: `limit` must be positive"),
        # Regression: a gain of the wrong shape was accepted and failed deep inside the trace
        # with a broadcasting error that named nothing.
        (
            lambda: MRPPD(jnp.ones(2), 1.0),
            "MRPPD: `k1` must be a scalar or shape (3,), got shape (2,)",
        ),
        (lambda: QuaternionPD(1.0, jnp.ones((3, 3))), "`kd` must be a scalar or shape (3,)"),
        (
            lambda: jaxatt.sliding.LinearSurface(jnp.ones(4)),
            "LinearSurface: `slope` must be a scalar or shape (3,)",
        ),
        (
            lambda: jaxatt.controllers.NormRobustTerm(jnp.ones(3), 0.01),
            "NormRobustTerm: `sigma` must be a scalar",
        ),
        (lambda: ZeroOrderHold(0.0), "`period` must be positive"),
        # an infinite limit was refused as "must be positive, got limit=inf": the rule is finite
        (lambda: Saturation(jnp.inf), "Saturation: `limit` must be positive and finite"),
        (
            lambda: NormSaturation(jnp.inf),
            "NormSaturation: `max_norm` must be positive and finite",
        ),
        # Regression: limits of more than one dimension failed inside the trace naming nothing.
        (
            lambda: Saturation(30.0 * jnp.ones((3, 3))),
            "Saturation: `limit` must be a scalar or a 1-D array",
        ),
        (
            lambda: jaxatt.simulation.FirstOrderLag(jnp.ones((3, 1))),
            "FirstOrderLag: `time_constant` must be a scalar or a 1-D array",
        ),
        (
            lambda: ClosedLoop(mrp_pd_loop().plant, QuaternionPD(1.0, 1.0)),
            "QuaternionPD reads QuaternionState measurements, but the plant measures MRPState",
        ),
    ],
)
def test_bad_controller_configuration_raises(build, needle):
    with pytest.raises(ValueError) as info:
        build()
    assert needle in str(info.value)


def test_norm_saturation_needs_a_scalar(no_jaxtyping):
    # Regression: a per-axis max_norm ran and turned the torque's direction. (The suite's type
    # checking rejects it at the annotation; users meet this check.)
    with pytest.raises(ValueError, match=re.escape("`max_norm` must be a scalar, got shape (3,)")):
        NormSaturation(jnp.array([1.0, 5.0, 9.0]))


@pytest.mark.parametrize("period", [True, None, "0.1"])
def test_a_hold_period_that_is_not_a_number_is_refused(period, no_jaxtyping):
    # ZeroOrderHold(True) was a 1 s period; None and strings failed inside `float`.
    with pytest.raises(ValueError, match="ZeroOrderHold: `period` must be a number"):
        ZeroOrderHold(period)
    assert ZeroOrderHold(jnp.asarray(0.1)).period == pytest.approx(0.1)


@pytest.mark.parametrize(
    "actuator, needle",
    [
        (Saturation(jnp.array([30.0, 30.0])), "Saturation: `limit` has shape (2,)"),
        (
            jaxatt.simulation.FirstOrderLag(jnp.array([0.1, 0.1])),
            "FirstOrderLag: `time_constant` has shape (2,)",
        ),
    ],
)
def test_per_axis_actuator_values_must_match_the_command(actuator, needle):
    # Regression: a per-axis limit of the wrong length failed with a broadcasting error deep
    # in the trace. The command's shape is known when the loop is traced, before compiling.
    loop = mrp_pd_loop()
    loop = ClosedLoop(loop.plant, loop.controller, actuator=actuator)
    with pytest.raises(ValueError, match=re.escape(needle + " (one value per axis) but the")):
        jaxatt.simulate(loop, mrp_x0(), 0.0, 0.1, dt=0.05)


def test_jit_of_simulate_equals_eager_call():
    loop, x0 = mrp_pd_loop(), mrp_x0()
    direct = jaxatt.simulate(loop, x0, 0.0, 1.0, dt=0.05)
    jitted = eqx.filter_jit(lambda m, x: jaxatt.simulate(m, x, 0.0, 1.0, dt=0.05))(loop, x0)
    np.testing.assert_allclose(direct.plant_states.sigma, jitted.plant_states.sigma, rtol=1e-14)


def test_float32_runs_stay_float32():
    # With x64 enabled every array must be built as float32 (defaults would be float64).
    loop = ClosedLoop(
        RigidBodyMRP(
            jnp.asarray(J0, jnp.float32),
            Constant(jnp.zeros((3, 3), jnp.float32)),
            Constant(jnp.zeros(3, jnp.float32)),
        ),
        MRPPD(jnp.float32(17.0), jnp.float32(15.0)),
        ConstantAttitude(jnp.array([1.0, 0, 0, 0], jnp.float32)),
    )
    x0 = MRPState(jnp.asarray(mrp_x0().sigma, jnp.float32), jnp.zeros(3, jnp.float32))
    traj = jaxatt.simulate(loop, x0, 0.0, 1.0, dt=0.01)
    assert traj.plant_states.sigma.dtype == jnp.float32
    assert traj.signals["u"].dtype == jnp.float32
    assert traj.ts.dtype == jnp.float32


def test_float32_clock_that_cannot_resolve_dt_is_refused():
    """At t0 = 1e5 s the spacing of float32 is 7.8 ms: the clock t0 + i dt stalled (every
    recorded step 0 or 7.8 ms at dt = 1 ms) and time-varying references were evaluated at
    wrong times with no error. The check refuses it before compiling; float64 and float32
    near t = 0 run, from the same loop."""
    f32 = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    loop = ClosedLoop(
        RigidBodyMRP(f32(J0), Constant(f32(jnp.zeros((3, 3)))), Constant(f32(jnp.zeros(3)))),
        MRPPD(f32(17.0), f32(15.0)),
        ConstantAttitude(f32([1.0, 0, 0, 0])),
    )
    x0 = MRPState(f32(mrp_x0().sigma), f32(jnp.zeros(3)))
    with pytest.raises(ValueError, match=r"in float32 the loop's clock cannot resolve dt=0.001"):
        jaxatt.simulate(loop, x0, 1e5, 1e5 + 0.01, dt=1e-3)
    with pytest.raises(ValueError, match=r"near t=200 s"):  # 15 us spacing > 1 % of 1 ms
        jaxatt.simulate(loop, x0, 0.0, 200.0, dt=1e-3)
    steps = np.diff(np.asarray(jaxatt.simulate(loop, x0, 0.0, 0.01, dt=1e-3).ts, np.float64))
    np.testing.assert_allclose(steps, 1e-3, rtol=1e-4)
    Simulation(1e5, 1e5 + 0.01, 1e-3).check_clock(jnp.float64)  # float64 resolves it


def test_initial_state_in_another_precision_than_the_loop_is_refused():
    # Regression: a float32 state (or one float32 leaf) in a float64 loop failed deep inside the
    # time loop with "scan body function carry input and carry output must have equal types".
    loop, x0 = mrp_pd_loop(), mrp_x0()
    x32 = MRPState(jnp.asarray(x0.sigma, jnp.float32), jnp.asarray(x0.omega, jnp.float32))
    with pytest.raises(ValueError, match=r"`x0.sigma` is float32 but the closed loop computes in"):
        jaxatt.simulate(loop, x32, 0.0, 0.1, dt=0.05)
    mixed = MRPState(x0.sigma, jnp.zeros(3, jnp.float32))
    with pytest.raises(ValueError, match=r"`x0.omega` is float32 .* in one precision"):
        jaxatt.simulate(loop, mixed, 0.0, 0.1, dt=0.05)
    # Arrays of JAX's default float pass.
    loop.check_state(MRPState(jnp.array([0.1, 0.0, 0.0]), jnp.zeros(3)))


class _FlagsLargeRates(AbstractController):
    """A PD law that declares |omega_i| >= 0.05 inadmissible (a test-only probe)."""

    inner: MRPPD
    measurement_type: ClassVar[type] = MRPState

    def init(self, t0, measurement, reference):
        return None

    def __call__(self, t, measurement, reference, state):
        return self.inner(t, measurement, reference, state)

    def admissible(self, t, measurement, reference, state):
        return ~jnp.any(jnp.abs(measurement.omega) >= 0.05)


def test_controller_admissibility_sets_the_status_at_the_first_bad_step():
    plant = mrp_pd_loop().plant
    fast = ClosedLoop(plant, _FlagsLargeRates(MRPPD(17.0, 15.0)))
    traj = jaxatt.simulate(fast, mrp_x0(), 0.0, 2.0, dt=0.01, throw=False)
    assert traj.status == jaxatt.Status.constraint_violated
    # Checked after every step (not only at the saves): the failure time is the first step at
    # which some |omega_i| >= 0.05.
    fine = jaxatt.simulate(fast, mrp_x0(), 0.0, 2.0, dt=0.01, throw=False, save_every=1)
    omega = np.asarray(fine.plant_states.omega)
    first = np.flatnonzero(np.any(np.abs(omega) >= 0.05, axis=1))[0]
    assert float(traj.failure_time) == pytest.approx(float(fine.ts[first]))
    with pytest.raises(jaxatt.SimulationFailed, match="admissible"):
        jaxatt.simulate(fast, mrp_x0(), 0.0, 2.0, dt=0.01)
    slow = ClosedLoop(plant, _FlagsLargeRates(MRPPD(0.01, 15.0)))
    traj = jaxatt.simulate(slow, mrp_x0(), 0.0, 2.0, dt=0.01, throw=False)
    assert traj.status == jaxatt.Status.successful
    assert float(traj.failure_time) == np.inf


def test_a_failure_of_the_initial_state_is_said_to_be_one():
    # Regression: the error said "constraint_violated at t = 0.5 s. ... its `admissible` check
    # failed after a completed step" for a state that failed before any step (the loop times
    # such a failure t0). A hand-made result: nothing to compile.
    from jaxatt.simulation._simulate import raise_on_failure

    def failed_at(time):
        ts = jnp.array([0.5, 0.51, 0.52])
        code = jnp.asarray(int(jaxatt.Status.constraint_violated), jnp.int32)
        return jaxatt.simulation.Trajectory(ts, None, {}, code, jnp.asarray(time), {})

    with pytest.raises(jaxatt.SimulationFailed, match="at t = 0.5 s.* on the initial state, at t0"):
        raise_on_failure(failed_at(0.5))
    with pytest.raises(jaxatt.SimulationFailed) as info:
        raise_on_failure(failed_at(0.51))
    assert "initial state" not in str(info.value)


@pytest.mark.parametrize(
    "t0, t1, dt, n_steps",
    [
        (0.0, 0.3, 0.1, 3),  # 0.3 / 0.1 = 2.9999999999999996
        (0.0, 1e6, 1e-3, 10**9),
        (1e6, 1e6 + 1.0, 1e-3, 1000),  # t1 - t0 carries the rounding of 1e6
        (0.0, 1e6 + 4e-4, 1e-3, None),
        (0.0, 1e5 + 3e-4, 1e-3, None),
    ],
)
def test_a_horizon_is_never_rounded_to_a_whole_step(t0, t1, dt, n_steps):
    # Regression: the tolerance was 1e-9 of the step count, so from 5e8 steps on any horizon
    # was accepted and silently shortened or lengthened to the nearest whole step (1e6 s +
    # 0.4 ms at dt = 1 ms ran to 1e6 s). Nothing is compiled here.
    if n_steps is None:
        with pytest.raises(ValueError, match="whole multiple of `dt`.*steps"):
            Simulation(t0, t1, dt)
    else:
        assert Simulation(t0, t1, dt).n_steps == n_steps


def test_a_limit_that_is_not_positive_at_run_time_fails_the_sample():
    # Regression: a limit reached by tracing (a sampled or tuned one, which the constructor
    # cannot refuse) was used as it was: Saturation(-1) applied -1 N m for every positive
    # command, NormSaturation(-1) turned the torque around; plausible runs. Now the applied
    # control is NaN (the sample fails). Eager calls: nothing is compiled.
    u = jnp.array([2.0, -0.5, 0.1])
    for actuator, name in ((Saturation(1.0), "limit"), (NormSaturation(1.0), "max_norm")):
        for bad in (-1.0, 0.0, jnp.nan):
            broken = eqx.tree_at(lambda a: getattr(a, name), actuator, jnp.asarray(bad))
            assert np.all(np.isnan(broken(0.0, u, None)[0])), (name, bad)
    np.testing.assert_allclose(Saturation(1.0)(0.0, u, None)[0], [1.0, -0.5, 0.1])
    np.testing.assert_allclose(NormSaturation(1.0)(0.0, u, None)[0], u / np.linalg.norm(u))
    # A lag's time constant: its state's derivative is NaN (a negative one grew exponentially).
    lag = eqx.tree_at(lambda a: a.time_constant, FirstOrderLag(0.1), jnp.asarray(-0.1))
    assert np.all(np.isnan(lag(0.0, u, jnp.zeros(3))[1]))
    per_axis = eqx.tree_at(lambda a: a.limit, Saturation(jnp.ones(3)), jnp.array([1.0, -1.0, 1.0]))
    np.testing.assert_array_equal(np.isnan(per_axis(0.0, u, None)[0]), [False, True, False])
