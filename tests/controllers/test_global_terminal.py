"""Feedback linearisation of the Euler-angle body and the global terminal sliding mode (001(b))."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.controllers import (
    DecoupledPD,
    DecoupledSlidingMode,
    FeedbackLinearization,
    decoupling_drift,
    decoupling_matrix,
)
from jaxatt.plants import Constant, EulerAngleState, RigidBodyEuler, Sinusoid
from jaxatt.reaching import Exponential, Tanh
from jaxatt.references import EulerAngleTrajectory
from jaxatt.simulation import ClosedLoop, simulate
from jaxatt.sliding import (
    ExponentialDecay,
    FractionalSurface,
    GlobalSurface,
    PolynomialDecay,
    TerminalSurface,
)

from ..helpers import J0


# The documented example of docs/generic_attitude_laws.md.
INERTIA = np.diag([10.0, 12.0, 14.0])
TARGET = np.array([0.1, -0.2, 0.3])
X0 = EulerAngleState(jnp.array([0.5, 0.3, -0.4]), jnp.array([0.05, -0.02, 0.1]))


def _gtsm(a=1.0, b=0.5, ratio=0.6, time_constant=1.0, k1=2.0, k2=0.05):
    surface = GlobalSurface(TerminalSurface(a, b, ratio), ExponentialDecay(time_constant))
    return DecoupledSlidingMode(surface, Exponential(k1, k2, switching=Tanh(0.01)))


def _loop(outer, inertia=INERTIA, reference=None):
    if reference is None:
        reference = EulerAngleTrajectory(Constant(jnp.asarray(TARGET)))
    inertia = jnp.asarray(inertia)
    return ClosedLoop(RigidBodyEuler(inertia), FeedbackLinearization(inertia, outer), reference)


def _moving_reference():
    return EulerAngleTrajectory(
        Sinusoid(jnp.array([0.2, 0.1, 0.3]), jnp.array([0.5, 0.7, 0.3]), jnp.array([0.0, 1, 2]))
    )


def _random_state(loop, seed, t):
    k1, k2 = jax.random.split(jax.random.key(seed))
    angles = jax.random.uniform(k1, (3,), minval=-1.2, maxval=1.2)
    x = EulerAngleState(angles, 0.3 * jax.random.normal(k2, (3,)))
    # Controller state as if the run had started at t - 0.4 from a different state.
    y_start = loop.init(t - 0.4, EulerAngleState(angles + 0.3, x.omega - 0.1))
    return eqx.tree_at(lambda y: y.plant, y_start, x)


@eqx.filter_jit
def _output_acceleration_and_v(loop, t, y):
    """y'' along the closed loop by jax.jvp of the plant's angle rates, and the law's v."""
    y_dot = loop(t, y, None)
    _, y_ddot = jax.jvp(
        lambda y: loop.plant.angle_rates(y.plant.angles, y.plant.omega), (y,), (y_dot,)
    )
    return y_ddot, loop.signals(t, y, None)["v"]


@eqx.filter_jit
def _sliding_variable_and_rate(loop, t, y):
    """s and ds/dt along the closed loop (jax.jvp in t and the state), and the angle errors."""
    y_dot = loop(t, y, None)
    s, s_dot = jax.jvp(
        lambda t, y: loop.signals(t, y, None)["s"], (t, y), (jnp.ones_like(t), y_dot)
    )
    return s, s_dot, loop.signals(t, y, None)["angle_error"]


@pytest.mark.parametrize("inertia", [INERTIA, J0], ids=["diagonal", "full"])
@pytest.mark.parametrize("outer", [DecoupledPD(4.0, 3.0), _gtsm()], ids=["pd", "gtsm"])
def test_decoupling_makes_output_acceleration_equal_v(inertia, outer):
    loop = _loop(outer, inertia, _moving_reference())
    for seed in range(3):
        t = jnp.asarray(1.3 + seed)
        y = _random_state(loop, seed, t)
        y_ddot, v = _output_acceleration_and_v(loop, t, y)
        np.testing.assert_allclose(y_ddot, v, rtol=0, atol=1e-12)


def test_decoupling_terms_match_the_plant_by_autodiff():
    """A(x) = d y''/dM and b(x) = y''(M = 0) from the plant's vector field."""
    plant = RigidBodyEuler(jnp.asarray(J0))
    x = EulerAngleState(jnp.array([0.4, -0.7, 2.0]), jnp.array([0.2, -0.1, 0.3]))

    def y_ddot(torque):
        x_dot = plant.vector_field(0.0, x, torque)
        return jax.jvp(plant.angle_rates, (x.angles, x.omega), (x_dot.angles, x_dot.omega))[1]

    np.testing.assert_allclose(decoupling_drift(J0, x.angles, x.omega), y_ddot(jnp.zeros(3)))
    np.testing.assert_allclose(
        decoupling_matrix(J0, x.angles), jax.jacfwd(y_ddot)(jnp.zeros(3)), rtol=1e-13
    )


def test_global_sliding_variable_follows_the_reaching_law():
    """ds_g/dt = r(s_g) along the loop, including the decaying offset's derivative."""
    outer = _gtsm()
    loop = _loop(outer, J0, _moving_reference())
    for seed in range(3):
        t = jnp.asarray(0.7 + seed)
        y = _random_state(loop, seed, t)
        s, s_dot, angle_error = _sliding_variable_and_rate(loop, t, y)
        assert np.min(np.abs(np.asarray(angle_error))) > 1e-3  # outside the guarded floor
        np.testing.assert_allclose(s_dot, outer.reaching_law.rate(s), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("decay", [ExponentialDecay(2.0), PolynomialDecay(2.0)])
def test_decays_start_at_one_and_their_rates_are_exact(decay):
    f0, _ = decay(0.0)
    assert float(f0) == 1.0
    for tau in (0.3, 1.1, 1.9):
        (_, f_dot), (f_rate, _) = jax.jvp(decay, (jnp.asarray(tau),), (jnp.asarray(1.0),))
        np.testing.assert_allclose(f_dot, f_rate, rtol=1e-14)
    if isinstance(decay, PolynomialDecay):
        assert decay(2.0) == (0.0, 0.0) and decay(5.0)[0] == 0.0


# --- The documented example: one compiled program gives the run and its gradients -----------

HORIZON = 10.0


@pytest.fixture(scope="module")
def example_run():
    loop = _loop(_gtsm())

    def gains(loop):
        law = loop.controller.outer
        surface = law.surface
        return (
            surface.surface.k1,
            surface.surface.k2,
            surface.decay.time_constant,
            law.reaching_law.k1,
        )

    def cost(params):
        tuned = eqx.tree_at(gains, loop, tuple(params))
        traj = simulate(tuned, X0, 0.0, HORIZON, dt=0.01, save_every=10)
        error = traj.signals["angle_error"]
        return jnp.mean(jnp.sum(error**2, axis=-1)), traj

    # Forward mode (4 parameters): one program gives the run and the gradient, and compiles
    # in about 60 % of the time of reverse mode through the checkpointed loop (measured).
    grads, traj = eqx.filter_jit(jax.jacfwd(cost, has_aux=True))(jnp.stack(gains(loop)))
    error = traj.signals["angle_error"]
    return jnp.mean(jnp.sum(error**2, axis=-1)), traj, grads


def test_global_surface_starts_on_the_surface(example_run):
    _, traj, _ = example_run
    s = np.asarray(traj.signals["s"])
    assert np.all(s[0] == 0.0)  # exactly: s(t0) - s(t0) f(0), f(0) = 1
    # The plain terminal surface at the same start is far from 0 (the reaching phase removed).
    surface = TerminalSurface(1.0, 0.5, 0.6)
    e0 = X0.angles - TARGET
    e0_dot = RigidBodyEuler(jnp.asarray(INERTIA)).angle_rates(X0.angles, X0.omega)
    assert np.max(np.abs(surface(jnp.asarray(e0), e0_dot))) > 0.3
    # No reaching phase: |s_g| stays at the level of the guarded-floor mismatch (measured 2.4e-4).
    assert np.max(np.abs(s)) < 1e-3


def test_all_three_angles_converge(example_run):
    _, traj, _ = example_run
    error = np.abs(np.asarray(traj.signals["angle_error"]))
    assert np.all(error[0] > 0.3)
    assert np.max(error[-1]) < 1e-5  # measured 1.5e-7 at t = 10 s
    assert int(traj.status) == 0


def test_gradients_with_respect_to_gains_are_finite(example_run):
    value, _, grads = example_run
    assert np.isfinite(float(value))
    grads = np.asarray(grads)
    assert np.all(np.isfinite(grads))
    # The surface gains a, b act (a larger a or b converges faster: the cost decreases); the
    # decay T too (a slower offset decay delays convergence). The reaching gain k1 hardly
    # matters (measured 4e-10): s_g starts at 0 and stays near it, which is the point of the
    # global surface.
    assert grads[0] < 0 and grads[1] < 0 and grads[2] > 0
    assert abs(grads[3]) < 1e-6 * abs(grads[0])


@pytest.mark.parametrize(
    "build, needle",
    [
        (lambda: TerminalSurface(1.0, 0.5, 1.2), "TerminalSurface: `exponent` must lie in (0.0"),
        (lambda: TerminalSurface(-1.0, 0.5, 0.6), "TerminalSurface: `k1` must be positive"),
        (lambda: TerminalSurface(1.0, 0.0, 0.6), "TerminalSurface: `k2` must be positive"),
        (lambda: ExponentialDecay(0.0), "ExponentialDecay: `time_constant` must be positive"),
        (lambda: PolynomialDecay(-1.0), "PolynomialDecay: `horizon` must be positive"),
        # (3, 1) parameters broadcast against the (3,) error into a (3, 3) sliding variable
        (
            lambda: TerminalSurface(1.0, 0.5, jnp.full((3, 1), 0.6)),
            "TerminalSurface: `exponent` must be a scalar or shape (3,), got shape (3, 1)",
        ),
        (
            lambda: TerminalSurface(1.0, 0.5, 0.6, jnp.full((3, 1), 1e-3)),
            "TerminalSurface: `floor` must be a scalar or shape (3,), got shape (3, 1)",
        ),
        (
            lambda: ExponentialDecay(jnp.ones((3, 1))),
            "ExponentialDecay: `time_constant` must be a scalar, got shape (3, 1)",
        ),
        (
            lambda: PolynomialDecay(jnp.ones(3)),
            "PolynomialDecay: `horizon` must be a scalar, got shape (3,)",
        ),
        (  # a (3,) order failed in the first evaluation with a broadcasting error
            lambda: FractionalSurface(1.0, jnp.full(3, 0.5), 0.1, 10),
            "FractionalSurface: `order` must be a scalar, got shape (3,)",
        ),
        (lambda: DecoupledPD(-1.0, 1.0), "DecoupledPD: `kp` must be positive"),
        (
            lambda: FeedbackLinearization(-jnp.eye(3), DecoupledPD(1.0, 1.0)),
            "FeedbackLinearization: `inertia` must be a symmetric positive-definite",
        ),
        (  # a (2,) margin broadcast in the kinematics: a shape error deep in the run
            lambda: FeedbackLinearization(
                jnp.eye(3), DecoupledPD(1.0, 1.0), gimbal_margin=jnp.array([0.1, 0.2])
            ),
            "FeedbackLinearization: `gimbal_margin` must be a scalar",
        ),
        (
            lambda: simulate(
                _loop(DecoupledPD(1.0, 1.0)),
                EulerAngleState(jnp.array([0.0, np.pi / 2, 0.0]), jnp.zeros(3)),
                0.0,
                1.0,
                dt=0.1,
            ),
            "RigidBodyEuler: `x0.angles` has the pitch theta at or beyond",
        ),
    ],
)
def test_bad_input_raises(build, needle, no_jaxtyping):
    with pytest.raises(ValueError) as info:
        build()
    assert needle in str(info.value)


def test_wrong_component_types_are_type_errors(no_jaxtyping):
    # The constructors' own TypeErrors (what users meet; under the suite's hook the
    # annotations answered first, and a bare TypeError would also pass on a wrong call).
    with pytest.raises(TypeError, match="FeedbackLinearization: `outer` must be an Abstract"):
        FeedbackLinearization(jnp.eye(3), "pd")
    with pytest.raises(TypeError, match="GlobalSurface: `decay` must be an AbstractDecay"):
        GlobalSurface(TerminalSurface(1.0, 0.5, 0.6), 1.0)
