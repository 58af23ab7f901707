r"""Classical input shapers: trains of impulses (Singer & Seering 1990).

For a mode $(\omega_k, \zeta_k)$, $K = \exp(-\zeta_k\pi/\sqrt{1 - \zeta_k^2})$ and the damped
period $T_d = 2\pi/(\omega_k\sqrt{1 - \zeta_k^2})$:

- ZV: amplitudes $(1, K)/(1 + K)$ at $(0, T_d/2)$;
- ZVD: amplitudes $(1, 2K, K^2)/(1 + K)^2$ at $(0, T_d/2, T_d)$ (zero vibration and zero
  derivative of it with respect to the frequency, so more robust and twice as long).

The shaped step is a staircase; its residual vibration is
$V = e^{-\zeta\omega t_N}|\sum_j A_je^{(\zeta\omega + i\omega_d)t_j}|$.
"""

import abc

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from ._base import AbstractShaper, check_evaluation_mode, check_mode, damped_period


class AbstractImpulseShaper(AbstractShaper):
    """A shaper made of impulses: `impulses() -> (amplitudes, times)`; the rest follows."""

    @abc.abstractmethod
    def impulses(self) -> tuple[Float[Array, " m"], Float[Array, " m"]]:
        """(amplitudes summing to 1, times [s] starting at 0)."""

    @property
    def duration(self) -> Float[Array, ""]:
        return self.impulses()[1][-1]

    def step_response(self, t: RealScalarLike | Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        """A staircase: $\\sum_j A_j H(t - t_j)$ with $H(0) = 1$."""
        amplitudes, times = self.impulses()
        t = jnp.asarray(t)[..., None]
        shape = (1,) * (t.ndim - 1) + (-1,)
        amplitudes, times = amplitudes.reshape(shape), times.reshape(shape)
        return jnp.sum(amplitudes * (t >= times), axis=-1)

    def residual_vibration(self, frequency, damping) -> Float[Array, "..."]:
        frequency, damping = check_evaluation_mode(
            f"{type(self).__name__}.residual_vibration", frequency, damping
        )
        amplitudes, times = self.impulses()
        frequency, damping = jnp.broadcast_arrays(frequency, damping)
        frequency, damping = frequency[..., None], damping[..., None]
        shape = (1,) * (frequency.ndim - 1) + (-1,)
        amplitudes, times = amplitudes.reshape(shape), times.reshape(shape)
        decay = damping * frequency
        damped = frequency * jnp.sqrt(1 - damping**2)
        weight = jnp.exp(decay * (times - times[..., -1:]))
        c = jnp.sum(amplitudes * weight * jnp.cos(damped * times), axis=-1)
        s = jnp.sum(amplitudes * weight * jnp.sin(damped * times), axis=-1)
        return jnp.sqrt(c**2 + s**2)


class ZeroVibration(AbstractImpulseShaper):
    """ZV shaper for the mode (`frequency` [rad/s] > 0, `damping` in [0, 1))."""

    frequency: Float[Array, ""]
    damping: Float[Array, ""]

    def __init__(self, frequency: RealScalarLike, damping: RealScalarLike = 0.0):
        self.frequency, self.damping = check_mode("ZeroVibration", frequency, damping)

    def impulses(self):
        z = self.damping
        k = jnp.exp(-z * jnp.pi / jnp.sqrt(1 - z**2))
        half = 0.5 * damped_period(self.frequency, z)
        return jnp.stack([1 / (1 + k), k / (1 + k)]), jnp.stack([jnp.zeros_like(half), half])


class ZeroVibrationDerivative(AbstractImpulseShaper):
    """ZVD shaper for the mode (`frequency` [rad/s] > 0, `damping` in [0, 1))."""

    frequency: Float[Array, ""]
    damping: Float[Array, ""]

    def __init__(self, frequency: RealScalarLike, damping: RealScalarLike = 0.0):
        self.frequency, self.damping = check_mode("ZeroVibrationDerivative", frequency, damping)

    def impulses(self):
        z = self.damping
        k = jnp.exp(-z * jnp.pi / jnp.sqrt(1 - z**2))
        half = 0.5 * damped_period(self.frequency, z)
        norm = (1 + k) ** 2
        amplitudes = jnp.stack([1 / norm, 2 * k / norm, k**2 / norm])
        return amplitudes, jnp.stack([jnp.zeros_like(half), half, 2 * half])
