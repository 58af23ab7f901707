"""Zero-vibration smoother (41) and ZV/ZVD input shapers.

Oracles independent of the closed forms under test: Gauss-Legendre quadrature of the kernel
(200 points per smooth piece, exact to rounding), the conditions (37)-(40) as integrals, and a
second-order mode driven by the shaped step (RK4 in `lax.scan`).
"""

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
)


NODES, WEIGHTS = np.polynomial.legendre.leggauss(200)


def quad(f, a, b):
    y = 0.5 * (b - a) * (NODES + 1) + a
    return 0.5 * (b - a) * np.sum(WEIGHTS * f(y))


def smoother_integral(smoother, g):
    period = float(smoother.period)
    kernel = lambda t: np.asarray(smoother.kernel(jnp.asarray(t))) * g(t)  # noqa: E731
    return quad(kernel, 0.0, period) + quad(kernel, period, 2 * period)


@pytest.mark.parametrize(("frequency", "damping"), [(0.0996, 0.01), (1.0087, 0.0), (3.0, 0.3)])
def test_smoother_unit_integral_and_zero_vibration_conditions(frequency, damping):
    """int u = 1 and (37)-(40) to 1e-12 (relative to the unweighted magnitudes)."""
    s = ZeroVibrationSmoother(frequency, damping)
    np.testing.assert_allclose(float(s.duration), 4 * np.pi / (frequency * np.sqrt(1 - damping**2)))
    assert abs(smoother_integral(s, lambda t: 1.0) - 1) < 1e-12
    a, wd = damping * frequency, frequency * np.sqrt(1 - damping**2)
    for weight in (
        lambda t: np.exp(a * t) * np.sin(wd * t),
        lambda t: np.exp(a * t) * np.cos(wd * t),
        lambda t: t * np.exp(a * t) * np.sin(wd * t),
        lambda t: t * np.exp(a * t) * np.cos(wd * t),
    ):
        scale = smoother_integral(s, lambda t, w=weight: np.abs(w(t)))
        assert abs(smoother_integral(s, weight)) < 1e-12 * scale
    assert float(s.residual_vibration(frequency, damping)) < 1e-12
    # Step response = running integral of the kernel, at points on both pieces.
    period = float(s.period)
    for t in (0.3 * period, period, 1.4 * period, 2 * period):
        head = quad(lambda x: np.asarray(s.kernel(jnp.asarray(x))), 0.0, min(t, period))
        tail = quad(lambda x: np.asarray(s.kernel(jnp.asarray(x))), period, t) if t > period else 0
        assert abs(float(s.step_response(t)) - head - tail) < 1e-13
    assert float(s.step_response(-1.0)) == 0 and float(s.step_response(3 * period)) == 1


def test_residual_vibration_sweep_against_quadrature_and_shapers():
    """Sensitivity curve: closed form = quadrature over a frequency sweep; ZV and ZVD vanish at
    the design mode; ZVD is flat there (robust), the smoother suppresses high frequencies."""
    s = ZeroVibrationSmoother(1.0, 0.01)
    ratios = np.array([0.3, 0.7, 0.95, 1.0, 1.05, 1.5, 2.0, 3.0])
    closed = np.asarray(s.residual_vibration(jnp.asarray(ratios), 0.02))
    for r, v in zip(ratios, closed):
        wd, a = r * np.sqrt(1 - 0.02**2), 0.02 * r
        c = smoother_integral(s, lambda t: np.exp(a * t) * np.cos(wd * t))
        si = smoother_integral(s, lambda t: np.exp(a * t) * np.sin(wd * t))
        expected = np.exp(-a * float(s.duration)) * np.hypot(c, si)
        assert abs(v - expected) < 1e-12
    zv, zvd = ZeroVibration(1.0, 0.01), ZeroVibrationDerivative(1.0, 0.01)
    for shaper in (zv, zvd):
        amplitudes, _ = shaper.impulses()
        np.testing.assert_allclose(float(jnp.sum(amplitudes)), 1.0, rtol=1e-15)
        assert float(shaper.residual_vibration(1.0, 0.01)) < 1e-12
    near = jnp.asarray([0.9, 1.1])
    assert np.all(np.asarray(zvd.residual_vibration(near, 0.01)) < np.asarray(zv.residual_vibration(near, 0.01)))
    slope = jax.grad(lambda w: zvd.residual_vibration(w, 0.01) ** 2)(1.0)
    assert abs(float(slope)) < 1e-12
    assert float(s.residual_vibration(3.0, 0.01)) < 0.02 < float(zv.residual_vibration(3.0, 0.01))
    unshaped_like = np.asarray(s.residual_vibration(jnp.asarray([1e-3]), 0.0))
    assert abs(unshaped_like[0] - 1) < 1e-3  # a very slow mode sees an unshaped step


def _mode_response(shaper, frequency, damping, t_end, dt=2e-3):
    """x'' + 2 z w x' + w^2 x = w^2 S(t): residual amplitude |x - 1| + |x'|/w after t_end."""

    def f(t, y):
        x, v = y
        return jnp.stack([v, frequency**2 * (shaper.step_response(t) - x) - 2 * damping * frequency * v])

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


def test_shaped_attitude_command():
    """Unit norm throughout, q(0) at t = 0, the target after 2T; omega_d = 2 [q^* q']_v
    against a central difference."""
    q0 = jnp.array([0.8832, 0.3, -0.2, -0.3])
    q0 = q0 / jnp.linalg.norm(q0)
    ref = ShapedAttitude(ZeroVibrationSmoother(0.5, 0.01), q0, jnp.array([1.0, 0, 0, 0]))
    duration = float(ref.shaper.duration)
    for t in np.linspace(0.0, duration * 1.1, 7):
        out, _ = ref(t, None)
        assert isinstance(out, AttitudeReference)
        assert abs(float(jnp.linalg.norm(out.q_d)) - 1) < 1e-14
    np.testing.assert_allclose(ref(0.0, None)[0].q_d, q0, atol=1e-15)
    np.testing.assert_allclose(ref(duration + 1.0, None)[0].q_d, [1, 0, 0, 0], atol=1e-15)
    t, h = 0.4 * duration, 1e-5
    qm, qp = ref.command(t - h), ref.command(t + h)
    q = ref.command(t)
    q_dot = (qp - qm) / (2 * h)
    conj = q * jnp.array([1.0, -1, -1, -1])
    expected = 2 * (conj[0] * q_dot[1:] + q_dot[0] * conj[1:] + jnp.cross(conj[1:], q_dot[1:]))
    np.testing.assert_allclose(ref(t, None)[0].omega_d, expected, atol=1e-9)
    with pytest.raises(ValueError, match="shaper"):
        ShapedAttitude(object(), q0, q0)
