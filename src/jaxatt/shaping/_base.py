"""The shaper interface."""

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check, check_nonnegative, check_positive, is_traced


def damped_period(
    frequency: Float[ArrayLike, "..."], damping: Float[ArrayLike, "..."]
) -> Float[Array, "..."]:
    r"""$T = 2\pi/(\omega\sqrt{1 - \zeta^2})$ [s], the damped period of a mode.

    **Raises:** `ValueError` for a concrete `frequency <= 0` or `damping` outside [0, 1) (the
    period would be infinite or NaN). Traced values are not checked: the shapers call this on
    their own fields, which their constructors checked.
    """
    if not (is_traced(frequency) or is_traced(damping)):
        frequency, damping = check_mode_arrays("damped_period", frequency, damping)
    frequency = jnp.asarray(frequency)
    return 2 * jnp.pi / (frequency * jnp.sqrt(1 - jnp.asarray(damping) ** 2))


def check_mode_arrays(where: str, frequency, damping) -> tuple[Array, Array]:
    """Design modes of any shape: frequency > 0 [rad/s] and damping ratio in [0, 1)."""
    frequency = check_positive(where, "frequency", frequency)
    damping = check(
        where,
        "damping",
        damping,
        lambda xp, z: xp.isfinite(z) & (z >= 0) & (z < 1),
        "must lie in [0, 1) (an underdamped mode)",
    )
    return frequency, damping


def check_evaluation_mode(where: str, frequency, damping) -> tuple[Array, Array]:
    r"""A mode at which a residual vibration is evaluated: frequency >= 0 [rad/s] (0 gives the
    limit of a rigid mode) and damping ratio in [0, 1] (above 1 the damped frequency
    $\omega\sqrt{1 - \zeta^2}$ is imaginary and the formulas give NaN)."""
    frequency = check_nonnegative(where, "frequency", frequency)
    damping = check(
        where,
        "damping",
        damping,
        lambda xp, z: xp.isfinite(z) & (z >= 0) & (z <= 1),
        "must lie in [0, 1]",
    )
    return frequency, damping


def check_mode(where: str, frequency, damping) -> tuple[Array, Array]:
    """A design mode: frequency > 0 [rad/s] and damping ratio in [0, 1)."""
    frequency, damping = check_mode_arrays(where, frequency, damping)
    if frequency.shape != () or damping.shape != ():
        raise ValueError(f"{where}: `frequency` and `damping` must be scalars.")
    return frequency, damping


class AbstractShaper(eqx.Module):
    r"""A unit-integral shaping kernel $u(\tau) \ge 0$ supported on $[0, $ `duration` $]$.

    **Required:**
    - `step_response(t)`: $S(t) = \int_0^t u(\tau)\,d\tau$ (0 for $t \le 0$, 1 after
      `duration`), the shaped unit step;
    - `duration`: the kernel's length [s];
    - `residual_vibration(frequency, damping)`: the amplitude of the vibration a mode
      $(\omega, \zeta)$ keeps after the shaped step, relative to an unshaped step:
      $V = e^{-\zeta\omega t_f}\,\big|\int u(\tau)e^{(\zeta\omega + i\omega_d)\tau}d\tau\big|$,
      $\omega_d = \omega\sqrt{1 - \zeta^2}$, $t_f$ = `duration`.
    """

    @abc.abstractmethod
    def step_response(self, t: RealScalarLike | Float[ArrayLike, "..."]) -> Float[Array, "..."]:
        """$S(t) = \\int_0^t u$."""

    @property
    @abc.abstractmethod
    def duration(self) -> Float[Array, ""]:
        """Length of the kernel [s]."""

    @abc.abstractmethod
    def residual_vibration(
        self, frequency: Float[ArrayLike, "..."], damping: Float[ArrayLike, "..."]
    ) -> Float[Array, "..."]:
        """Residual vibration of the mode $(\\omega, \\zeta)$, relative to an unshaped step."""
