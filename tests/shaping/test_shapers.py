"""Zero-vibration smoother (41) and ZV/ZVD input shapers.

Oracles independent of the closed forms under test: Gauss-Legendre quadrature of the kernel
(200 points per smooth piece, exact to rounding), the conditions (37)-(40) as integrals, and a
second-order mode driven by the shaped step (RK4 in `lax.scan`).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.references import AttitudeReference
from jaxatt.shaping import (
    ShapedAttitude,
    ZeroVibration,
    ZeroVibrationDerivative,
    ZeroVibrationSmoother,
    damped_period,
)


NODES, WEIGHTS = np.polynomial.legendre.leggauss(200)


def quad(f, a, b):
    y = 0.5 * (b - a) * (NODES + 1) + a
    return 0.5 * (b - a) * np.sum(WEIGHTS * f(y))


def kernel_nodes(smoother):
    """Quadrature nodes over [0, T] and [T, 2T] and the weights times the kernel there."""
    period = float(smoother.period)
    t = np.concatenate([0.5 * period * (NODES + 1), 0.5 * period * (NODES + 1) + period])
    w = np.concatenate([WEIGHTS, WEIGHTS]) * 0.5 * period
    return t, w * np.asarray(smoother.kernel(jnp.asarray(t)))


def smoother_integral(smoother, g, nodes=None):
    t, wk = kernel_nodes(smoother) if nodes is None else nodes
    return np.sum(wk * g(t))


@pytest.mark.parametrize(("frequency", "damping"), [(0.0996, 0.01), (1.0087, 0.0), (3.0, 0.3)])
def test_smoother_unit_integral_and_zero_vibration_conditions(frequency, damping):
    """int u = 1 and (37)-(40) to 1e-12 (relative to the unweighted magnitudes)."""
    s = ZeroVibrationSmoother(frequency, damping)
    nodes = kernel_nodes(s)
    np.testing.assert_allclose(float(s.duration), 4 * np.pi / (frequency * np.sqrt(1 - damping**2)))
    assert abs(smoother_integral(s, lambda t: 1.0, nodes) - 1) < 1e-12
    a, wd = damping * frequency, frequency * np.sqrt(1 - damping**2)
    for weight in (
        lambda t: np.exp(a * t) * np.sin(wd * t),
        lambda t: np.exp(a * t) * np.cos(wd * t),
        lambda t: t * np.exp(a * t) * np.sin(wd * t),
        lambda t: t * np.exp(a * t) * np.cos(wd * t),
    ):
        scale = smoother_integral(s, lambda t, w=weight: np.abs(w(t)), nodes)
        assert abs(smoother_integral(s, weight, nodes)) < 1e-12 * scale
    assert float(s.residual_vibration(frequency, damping)) < 1e-12
    # Step response = running integral of the kernel, at points on both pieces.
    period = float(s.period)
    points = np.array([0.3 * period, period, 1.4 * period, 2 * period])
    responses = np.asarray(s.step_response(jnp.asarray(points)))
    for t, response in zip(points, responses):
        head = quad(lambda x: np.asarray(s.kernel(jnp.asarray(x))), 0.0, min(t, period))
        tail = quad(lambda x: np.asarray(s.kernel(jnp.asarray(x))), period, t) if t > period else 0
        assert abs(response - head - tail) < 1e-13
    assert float(s.step_response(-1.0)) == 0 and float(s.step_response(3 * period)) == 1


def test_residual_vibration_sweep_against_quadrature_and_shapers():
    """Sensitivity curve: closed form = quadrature over a frequency sweep; ZV and ZVD vanish at
    the design mode; ZVD is flat there (robust), the smoother suppresses high frequencies."""
    s = ZeroVibrationSmoother(1.0, 0.01)
    ratios = np.array([0.3, 0.7, 0.95, 1.0, 1.05, 1.5, 2.0, 3.0])
    closed = np.asarray(s.residual_vibration(jnp.asarray(ratios), 0.02))
    nodes = kernel_nodes(s)
    for r, v in zip(ratios, closed):
        wd, a = r * np.sqrt(1 - 0.02**2), 0.02 * r
        c = smoother_integral(s, lambda t: np.exp(a * t) * np.cos(wd * t), nodes)
        si = smoother_integral(s, lambda t: np.exp(a * t) * np.sin(wd * t), nodes)
        expected = np.exp(-a * float(s.duration)) * np.hypot(c, si)
        assert abs(v - expected) < 1e-12
    zv, zvd = ZeroVibration(1.0, 0.01), ZeroVibrationDerivative(1.0, 0.01)
    for shaper in (zv, zvd):
        amplitudes, _ = shaper.impulses()
        np.testing.assert_allclose(float(jnp.sum(amplitudes)), 1.0, rtol=1e-15)
        assert float(shaper.residual_vibration(1.0, 0.01)) < 1e-12
    near = jnp.asarray([0.9, 1.1])
    assert np.all(
        np.asarray(zvd.residual_vibration(near, 0.01))
        < np.asarray(zv.residual_vibration(near, 0.01))
    )
    slope = jax.grad(lambda w: zvd.residual_vibration(w, 0.01) ** 2)(1.0)
    assert abs(float(slope)) < 1e-12
    assert float(s.residual_vibration(3.0, 0.01)) < 0.02 < float(zv.residual_vibration(3.0, 0.01))
    unshaped_like = np.asarray(s.residual_vibration(jnp.asarray([1e-3]), 0.0))
    assert abs(unshaped_like[0] - 1) < 1e-3  # a very slow mode sees an unshaped step


def test_smoother_residual_vibration_at_its_removable_singularities():
    """z = 0 in V = e^{-2 zeta w T} u0 |e^{zT} - 1|^2 / |z|^2 (a rigid mode against an undamped
    design; a critically damped mode at w = a) is the limit u0 T^2 e^{-2 zeta w T}, and
    continuous with its neighbours (the direct form gave 0/0 = NaN there, and lost 8 digits
    to cancellation next to it), with a finite gradient."""
    rigid = ZeroVibrationSmoother(1.0, 0.0)
    np.testing.assert_allclose(float(rigid.residual_vibration(0.0, 0.0)), 1.0, rtol=1e-15)
    critical = ZeroVibrationSmoother(1.0, 0.5)
    a, period, u0 = (float(x) for x in (critical.decay, critical.period, critical.amplitude))
    limit = u0 * period**2 * np.exp(-2 * a * period)
    at = float(critical.residual_vibration(a, 1.0))
    np.testing.assert_allclose(at, limit, rtol=1e-14)
    # next to it, against the closed form in exact arithmetic: |e^{zT} - 1| / |z| for real z
    for w in (a * (1 + 1e-9), a * (1 - 1e-6)):
        zt = (w - a) * period
        exact = u0 * period**2 * (np.expm1(zt) / zt) ** 2 * np.exp(-2 * w * period)
        np.testing.assert_allclose(float(critical.residual_vibration(w, 1.0)), exact, rtol=1e-14)
    slope = jax.grad(lambda w: rigid.residual_vibration(w, 0.0))(0.0)
    assert np.isfinite(float(slope))


def _mode_response(shaper, frequency, damping, t_end, dt=2e-3):
    """x'' + 2 z w x' + w^2 x = w^2 S(t): residual amplitude |x - 1| + |x'|/w after t_end."""

    def f(t, y):
        x, v = y
        return jnp.stack(
            [v, frequency**2 * (shaper.step_response(t) - x) - 2 * damping * frequency * v]
        )

    def step(y, t):
        k1 = f(t, y)
        k2 = f(t + dt / 2, y + dt / 2 * k1)
        k3 = f(t + dt / 2, y + dt / 2 * k2)
        k4 = f(t + dt, y + dt * k3)
        return y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4), None

    ts = jnp.arange(round(t_end / dt)) * dt
    y, _ = jax.lax.scan(step, jnp.zeros(2), ts)
    return float(jnp.hypot(y[0] - 1, y[1] / frequency))


def test_shaped_step_leaves_no_residual_vibration_in_a_simulated_mode():
    """The design mode driven by the smoothed step ends at rest; an undamped mode detuned by
    30 % keeps the amplitude the sensitivity curve predicts (relative to an unshaped step's 1)."""
    s = ZeroVibrationSmoother(2.0, 0.05)
    t_end = float(s.duration)
    assert _mode_response(s, 2.0, 0.05, t_end) < 1e-8
    detuned = _mode_response(s, 2.6, 0.0, t_end)
    np.testing.assert_allclose(detuned, float(s.residual_vibration(2.6, 0.0)), rtol=1e-6)
    assert detuned > 1e-3


def test_smoother_gradient_matches_finite_differences():
    mode = 1.3

    def residual(w):
        return ZeroVibrationSmoother(w, 0.01).residual_vibration(mode, 0.01)

    for w in (1.0, 1.6):
        g = float(jax.grad(residual)(w))
        h = 1e-6
        fd = (float(residual(w + h)) - float(residual(w - h))) / (2 * h)
        assert np.isfinite(g) and abs(g - fd) < 1e-6 * max(1.0, abs(fd))


@pytest.mark.parametrize("cls", [ZeroVibrationSmoother, ZeroVibration, ZeroVibrationDerivative])
def test_bad_modes_are_refused(cls):
    with pytest.raises(ValueError, match="damping"):
        cls(1.0, 1.0)
    with pytest.raises(ValueError, match="damping"):
        cls(1.0, -0.1)
    with pytest.raises(ValueError, match="frequency"):
        cls(0.0, 0.01)


@pytest.mark.parametrize(
    ("call", "needle"),
    [
        # Each returned NaN (an overdamped mode has an imaginary damped frequency) or inf.
        (lambda: ZeroVibration(1.0, 0.01).residual_vibration(1.0, 1.5), "`damping` must lie"),
        (lambda: ZeroVibrationDerivative(1.0).residual_vibration(-1.0, 0.0), "`frequency` must"),
        (
            lambda: ZeroVibrationSmoother(1.0, 0.01).residual_vibration(jnp.array([1.0, 1.5]), 2.0),
            "ZeroVibrationSmoother.residual_vibration: `damping` must lie in",
        ),
        (lambda: damped_period(0.0, 0.0), "damped_period: `frequency` must be positive"),
        (lambda: damped_period(1.0, 1.5), "damped_period: `damping` must lie in"),
    ],
)
def test_modes_outside_the_formulas_domain_are_refused(call, needle):
    with pytest.raises(ValueError, match=needle):
        call()


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize(
    ("t_start", "needle"),
    [
        (float("nan"), "`t_start` must be finite"),  # made every command NaN
        (float("inf"), "`t_start` must be finite"),  # a step that never happened
        (-float("inf"), "`t_start` must be finite"),  # a step that was always over
        (jnp.ones(3), r"`t_start` must be a scalar"),  # a broadcasting error in `command`
    ],
)
def test_shaped_attitude_refuses_a_bad_start_time(t_start, needle):
    q0, q1 = jnp.array([1.0, 0.0, 0.0, 0.0]), jnp.array([0.0, 1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=f"ShapedAttitude: {needle}"):
        ShapedAttitude(ZeroVibrationSmoother(1.0, 0.01), q0, q1, t_start)


@pytest.mark.parametrize("shaper", [ZeroVibration(1.0), ZeroVibrationSmoother(1.0, 0.01)])
def test_shaped_attitude_refuses_a_target_opposite_to_the_start(shaper):
    # q_target = -q_start (the same attitude): the interpolation passed through 0 at S = 1/2
    # and the command was NaN there (for half a period behind a ZV shaper).
    q0 = jnp.array([0.8832, 0.3, -0.2, -0.3])
    q0 = q0 / jnp.linalg.norm(q0)
    with pytest.raises(ValueError, match=r"ShapedAttitude: `q_target` must not be -q_start"):
        ShapedAttitude(shaper, q0, -q0)
    # a traced pair is checked when the program runs
    build = eqx.filter_jit(lambda q: ShapedAttitude(shaper, q0, q)(0.0, None)[0].q_d)
    with pytest.raises(Exception, match="must not be -q_start"):
        build(-q0)
    np.testing.assert_allclose(build(q0), q0, atol=1e-15)  # a step to itself is fine


def test_shaped_attitude_command():
    """Unit norm throughout, q(0) at t = 0, the target after 2T; omega_d = 2 [q^* q']_v
    against a central difference."""
    q0 = jnp.array([0.8832, 0.3, -0.2, -0.3])
    q0 = q0 / jnp.linalg.norm(q0)
    ref = ShapedAttitude(ZeroVibrationSmoother(0.5, 0.01), q0, jnp.array([1.0, 0, 0, 0]))
    duration = float(ref.shaper.duration)
    call = jax.jit(jax.vmap(lambda t: ref(t, None)[0]))
    outs = call(jnp.array([0.0, 0.4 * duration, 0.5 * duration, duration + 1.0, 1.1 * duration]))
    assert isinstance(outs, AttitudeReference)
    assert np.all(np.abs(np.linalg.norm(np.asarray(outs.q_d), axis=1) - 1) < 1e-14)
    np.testing.assert_allclose(outs.q_d[0], q0, atol=1e-15)
    np.testing.assert_allclose(outs.q_d[3], [1, 0, 0, 0], atol=1e-15)
    t, h = 0.4 * duration, 1e-5
    qm, q, qp = jax.jit(jax.vmap(ref.command))(jnp.array([t - h, t, t + h]))
    q_dot = (qp - qm) / (2 * h)
    conj = q * jnp.array([1.0, -1, -1, -1])
    expected = 2 * (conj[0] * q_dot[1:] + q_dot[0] * conj[1:] + jnp.cross(conj[1:], q_dot[1:]))
    np.testing.assert_allclose(outs.omega_d[1], expected, atol=1e-9)
