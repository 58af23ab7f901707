"""A constant desired attitude (regulation)."""

from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import ArrayLike, Float

from .._custom_types import Quaternion, RealScalarLike
from .._validation import check_unit_quaternion
from ._base import AbstractReference, AttitudeReference


class ConstantAttitude(AbstractReference):
    """Hold the attitude `q_d` at rest: $\\omega_d = \\dot\\omega_d = 0$. No internal state.

    **Arguments:**
    - `q_d`: unit quaternion (scalar first); default the identity `[1, 0, 0, 0]`.
    """

    q_d: Quaternion
    output_type: ClassVar[type] = AttitudeReference

    def __init__(self, q_d: Float[ArrayLike, "4"] | None = None):
        if q_d is None:
            q_d = jnp.array([1.0, 0.0, 0.0, 0.0])
        self.q_d = check_unit_quaternion("ConstantAttitude", "q_d", q_d)

    def init(self, t0: RealScalarLike) -> None:
        del t0
        return None

    def __call__(self, t: RealScalarLike, state: None) -> tuple[AttitudeReference, None]:
        del t, state
        zero = jnp.zeros(3, self.q_d.dtype)
        return AttitudeReference(q_d=self.q_d, omega_d=zero, omega_d_dot=zero), None
