r"""A shaped attitude command: a shaper applied to a step from $q(0)$ to $\bar q_c$.

Shi & Song (2024) eq. (33), $q_c(t) = q(0) + (\bar q_c - q(0))\,S(t)$ with $S = $ the shaped
step ("the convolution of the step command with the smoother"), normalised so that it stays a
unit quaternion (SPEC: component-wise interpolation is not unit-norm). The controller then
uses $q_e = q_c^{-1}\otimes q$ (34, whose printed row 4 has a typo).
"""

from typing import ClassVar

import jax
import jax.numpy as jnp
from jaxtyping import ArrayLike, Float

from .._custom_types import Quaternion, RealScalarLike
from .._validation import check_finite, check_scalar, check_unit_quaternion
from ..references import AbstractReference, AttitudeReference
from ..rotations import quat_conjugate, quat_multiply
from ._base import AbstractShaper


class ShapedAttitude(AbstractReference):
    r"""$q_c(t) = \mathrm{normalise}\big(q_0 + (\bar q_c - q_0)S(t - t_s)\big)$.

    **Arguments:**
    - `shaper`: an [`AbstractShaper`][] (e.g. [`ZeroVibrationSmoother`][]).
    - `q_start`: $q_0$, the attitude the manoeuvre starts from (unit quaternion).
    - `q_target`: $\bar q_c$, the commanded attitude (unit quaternion).
    - `t_start`: $t_s$ [s], when the step is applied (a finite scalar, default 0).

    The output's $\omega_d = 2[q_c^*\otimes\dot q_c]_v$ and $\dot\omega_d$ are exact time
    derivatives (`jax.jvp`); a staircase (impulse shaper) has $\omega_d = 0$ between its
    jumps. No internal state.
    """

    shaper: AbstractShaper
    q_start: Quaternion
    q_target: Quaternion
    t_start: Float[jax.Array, ""]
    output_type: ClassVar[type] = AttitudeReference

    def __init__(
        self,
        shaper: AbstractShaper,
        q_start: Float[ArrayLike, "4"],
        q_target: Float[ArrayLike, "4"],
        t_start: RealScalarLike = 0.0,
    ):
        if not isinstance(shaper, AbstractShaper):
            raise ValueError(
                f"ShapedAttitude: `shaper` must be an AbstractShaper, got {type(shaper).__name__}."
            )
        self.shaper = shaper
        self.q_start = check_unit_quaternion("ShapedAttitude", "q_start", q_start)
        self.q_target = check_unit_quaternion("ShapedAttitude", "q_target", q_target)
        # A NaN start made every command NaN, and an infinite one a step that never (or always)
        # happened; a (3,) start failed in `command` with a broadcasting error.
        t_start = check_finite(
            "ShapedAttitude", "t_start", check_scalar("ShapedAttitude", "t_start", t_start)
        )
        self.t_start = jnp.asarray(t_start, self.q_start.dtype)

    def command(self, t: RealScalarLike) -> Quaternion:
        """$q_c(t)$, a unit quaternion."""
        fraction = self.shaper.step_response(t - self.t_start)
        q = self.q_start + (self.q_target - self.q_start) * fraction
        return q / jnp.sqrt(jnp.sum(q**2))

    def _rate(self, t):
        q, q_dot = jax.jvp(self.command, (t,), (jnp.ones_like(t),))
        return 2 * quat_multiply(quat_conjugate(q), q_dot)[1:]

    def init(self, t0: RealScalarLike) -> None:
        del t0
        return None

    def __call__(self, t: RealScalarLike, state: None) -> tuple[AttitudeReference, None]:
        del state
        t = jnp.asarray(t, self.q_start.dtype)
        omega_d, omega_d_dot = jax.jvp(self._rate, (t,), (jnp.ones_like(t),))
        return AttitudeReference(self.command(t), omega_d, omega_d_dot), None
