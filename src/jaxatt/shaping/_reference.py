r"""A shaped attitude command: a shaper applied to a step from $q(0)$ to $\bar q_c$.

Shi & Song (2024) eq. (33), $q_c(t) = q(0) + (\bar q_c - q(0))\,S(t)$ with $S = $ the shaped
step ("the convolution of the step command with the smoother"), normalised so that it stays a
unit quaternion (SPEC: component-wise interpolation is not unit-norm). The controller then
uses $q_e = q_c^{-1}\otimes q$ (34, whose printed row 4 has a typo).
"""

from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from .._custom_types import Quaternion, RealScalarLike
from .._validation import (
    check,
    check_finite,
    check_scalar,
    check_unit_quaternion,
    describe,
    is_traced,
)
from ..references import AbstractReference, AttitudeReference
from ..rotations import quat_conjugate, quat_multiply
from ._base import AbstractShaper


ANTIPODAL_TOLERANCE = 1e-6
r"""Smallest accepted $\|q_0 + \bar q_c\|$: the shaped command passes through
$(q_0 + \bar q_c)/2$, which must not be (close to) 0 for the normalisation."""


def _check_not_antipodal(q_start, q_target):
    r"""`q_target`, checked to differ from $-q_0$: the interpolation $q_0 + (\bar q_c - q_0)S$
    passes through 0 at $S = 1/2$, where the normalised command was NaN (a ZV staircase sits
    there for half a period). A traced pair gets the check attached to `q_target` (run time)."""
    rule = (
        f"must not be -q_start (| q_start + q_target | > {ANTIPODAL_TOLERANCE:g}): it is the "
        "same attitude, and the interpolated command passes through 0; to stay put, pass "
        "q_target = q_start"
    )
    pair = jnp.stack([q_start, q_target])
    if is_traced(pair):
        return check("ShapedAttitude", "q_target", pair, _apart, rule)[1]
    if not bool(_apart(np, np.asarray(pair))):
        raise ValueError(
            f"ShapedAttitude: `q_target` {rule}, got q_start={describe(q_start)} and "
            f"q_target={describe(q_target)}."
        )
    return q_target


def _apart(xp, pair):
    return xp.sqrt(xp.sum((pair[0] + pair[1]) ** 2)) > ANTIPODAL_TOLERANCE


class ShapedAttitude(AbstractReference):
    r"""$q_c(t) = \mathrm{normalise}\big(q_0 + (\bar q_c - q_0)S(t - t_s)\big)$.

    **Arguments:**
    - `shaper`: an [`AbstractShaper`][] (e.g. [`ZeroVibrationSmoother`][]).
    - `q_start`: $q_0$, the attitude the manoeuvre starts from (unit quaternion).
    - `q_target`: $\bar q_c$, the commanded attitude (unit quaternion, not $-q_0$: the
      command would pass through 0).
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
        self.q_target = _check_not_antipodal(self.q_start, self.q_target)
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
