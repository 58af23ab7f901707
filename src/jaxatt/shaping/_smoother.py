r"""The zero-vibration command smoother of Shi & Song (2024), eq. (41).

For a mode $(\omega_k, \zeta_k)$ with damped period $T = 2\pi/(\omega_k\sqrt{1 - \zeta_k^2})$
and $a = \zeta_k\omega_k$:

$$u(\tau) = \begin{cases}u_0\,\tau\,e^{-a\tau} & 0 \le \tau \le T\\
u_0(2T - \tau)\,e^{-a\tau} & T \le \tau \le 2T\\ 0 & \text{otherwise}\end{cases},\qquad
u_0 = \frac{\zeta_k^2\omega_k^2}{(1 - e^{-2\pi\zeta_k/\sqrt{1 - \zeta_k^2}})^2}.$$

$u(\tau)e^{a\tau}$ is a triangle (the convolution of two boxes of length $T$), so every
integral has a closed form: $\int u = u_0(1 - e^{-aT})^2/a^2 = 1$ exactly, and for a mode
$(\omega, \zeta)$, with $z = \zeta\omega - a + i\omega\sqrt{1 - \zeta^2}$,

$$\int_0^{2T} u(\tau)\,e^{(\zeta\omega + i\omega_d)\tau}\,d\tau = u_0\,\frac{(e^{zT} - 1)^2}{z^2},$$

which vanishes together with its derivative in $z$ at the design mode ($e^{zT} = e^{2\pi i}$):
conditions (37)-(40) of the paper. The residual vibration is
$V = e^{-2\zeta\omega T}\,u_0|e^{zT} - 1|^2/|z|^2$ ($u_0T^2e^{-2\zeta\omega T}$ in the limit
$z = 0$: a rigid mode against an undamped design, or $\zeta = 1$ at $\omega = a$).

The step response $S(t) = \int_0^t u$ is, with $h(x) = (1 - e^{-x}(1 + x))/x^2$
($h(0) = 1/2$, evaluated by its series near 0),

$$S(t) = u_0t^2h(at)\ (0 \le t \le T),\qquad
S(t) = 1 - u_0e^{-2aT}r^2h(-ar),\ r = 2T - t\ (T \le t \le 2T).$$
"""

import math

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from ..numerics import clip, minimum
from ._base import AbstractShaper, check_evaluation_mode, check_mode, damped_period


_SERIES = tuple((-1) ** n * (n - 1) / float(math.factorial(n)) for n in range(2, 13))
"""Coefficients of $h(x) = \\sum_{n\\ge2}(-1)^n(n - 1)x^{n-2}/n!$."""
_SERIES_RADIUS = 0.1


def _series_near_zero(x: Array, coefficients: tuple[float, ...], direct) -> Array:
    """`direct(x)`, by the power series with `coefficients` (Horner) for $|x| < 0.1$, where
    the direct form loses digits to cancellation or divides 0 by 0 (double `where`: finite
    gradients at 0). Real or complex `x`."""
    small = jnp.abs(x) < _SERIES_RADIUS
    xs = jnp.where(small, x, 0.0)
    series = jnp.zeros_like(x)
    for coefficient in reversed(coefficients):
        series = series * xs + coefficient
    return jnp.where(small, series, direct(jnp.where(small, 1.0, x)))


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _h(x: Array) -> Array:
    r"""$h(x) = (1 - e^{-x}(1 + x))/x^2$, by its series for $|x| < 0.1$ (error < 1e-16)."""
    return _series_near_zero(x, _SERIES, lambda x: (-jnp.expm1(-x) - x * jnp.exp(-x)) / x**2)


_EXPM1_SERIES = tuple(1 / float(math.factorial(n + 1)) for n in range(13))
"""Coefficients of $(e^w - 1)/w = \\sum_{n\\ge0} w^n/(n + 1)!$."""


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _expm1_ratio(w: Array) -> Array:
    r"""$(e^w - 1)/w$ for complex $w$, 1 at $w = 0$ (its series for $|w| < 0.1$, error
    < 1e-16; the direct form loses digits to cancellation there)."""
    return _series_near_zero(w, _EXPM1_SERIES, lambda w: (jnp.exp(w) - 1) / w)


def _g(x: Array) -> Array:
    """$(1 - e^{-x})/x$ with $g(0) = 1$."""
    small = jnp.abs(x) < 1e-8
    xl = jnp.where(small, 1.0, x)
    return jnp.where(small, 1 - 0.5 * x, -jnp.expm1(-xl) / xl)


class ZeroVibrationSmoother(AbstractShaper):
    r"""The zero-vibration smoother (41) for the mode $(\omega_k, \zeta_k)$ (module docstring).

    **Arguments:**
    - `frequency`: $\omega_k > 0$ [rad/s] (the paper prints 0.0996).
    - `damping`: $\zeta_k \in [0, 1)$ (the paper: 0.01); $\zeta_k \ge 1$ is refused (the mode
      does not oscillate, and $T$ is undefined).

    Duration $2T$ (126.17 s for the paper's $\omega_k = 0.0996$, $\zeta_k = 0.01$).
    Differentiable in both parameters.
    """

    frequency: Float[Array, ""]
    damping: Float[Array, ""]

    def __init__(
        self, frequency: float | Float[ArrayLike, ""], damping: float | Float[ArrayLike, ""] = 0.0
    ):
        self.frequency, self.damping = check_mode("ZeroVibrationSmoother", frequency, damping)

    @property
    def period(self) -> Float[Array, ""]:
        """$T = 2\\pi/(\\omega_k\\sqrt{1 - \\zeta_k^2})$ [s]."""
        return damped_period(self.frequency, self.damping)

    @property
    def duration(self) -> Float[Array, ""]:
        return 2 * self.period

    @property
    def decay(self) -> Float[Array, ""]:
        """$a = \\zeta_k\\omega_k$ [1/s]."""
        return self.damping * self.frequency

    @property
    def amplitude(self) -> Float[Array, ""]:
        """$u_0$ [1/s^2] (the paper's formula, written as $1/(T^2g(aT)^2)$, $g(x) = (1 -
        e^{-x})/x$, so that $\\zeta_k = 0$ gives its limit $1/T^2$)."""
        period = self.period
        return 1 / (period**2 * _g(self.decay * period) ** 2)

    def kernel(self, t: RealScalarLike | Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        """$u(t)$ [1/s] of (41)."""
        t = jnp.asarray(t)
        period = self.period
        triangle = clip(minimum(t, 2 * period - t), 0.0, None)
        return self.amplitude * triangle * jnp.exp(-self.decay * t)

    def step_response(self, t: RealScalarLike | Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        t = jnp.asarray(t)
        period, a, u0 = self.period, self.decay, self.amplitude
        rising = clip(t, 0.0, period)
        first = u0 * rising**2 * _h(a * rising)
        r = clip(2 * period - t, 0.0, period)
        second = 1 - u0 * jnp.exp(-2 * a * period) * r**2 * _h(-a * r)
        return jnp.where(t <= period, first, second)

    def residual_vibration(self, frequency, damping) -> Float[Array, "..."]:
        frequency, damping = check_evaluation_mode(
            "ZeroVibrationSmoother.residual_vibration", frequency, damping
        )
        period = self.period
        damped = frequency * jnp.sqrt(1 - damping**2)
        z = (damping * frequency - self.decay) + 1j * damped
        # u0 (e^{zT} - 1)^2 / z^2, written with (e^w - 1)/w so that z = 0 (a rigid mode
        # against an undamped design, or a critically damped mode at omega = a) gives its
        # limit u0 T^2 instead of 0/0.
        transform = self.amplitude * (period * _expm1_ratio(z * period)) ** 2
        return jnp.exp(-2 * damping * frequency * period) * jnp.abs(transform)
