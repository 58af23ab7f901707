"""A constant desired attitude (regulation)."""

from typing import ClassVar

import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from .._custom_types import Quaternion, RealScalarLike
from .._validation import check_unit_quaternion
from ._base import AbstractReference, AttitudeReference


class ConstantAttitude(AbstractReference):
    """Hold the attitude `q_d` at rest: $\\omega_d = \\dot\\omega_d = 0$. No internal state.

    **Arguments:**
    - `q_d`: unit quaternion (scalar first); default the identity `[1, 0, 0, 0]`.

    The zero rates are NumPy constants, known when the closed loop is traced: the rate errors
    of [`jaxatt.rotations`][] ([`rate_error`][jaxatt.rotations.rate_error],
    [`rate_error_mrp`][jaxatt.rotations.rate_error_mrp]) are then the body rate itself, and
    the finite-time MRP laws leave out their feed-forward's reference terms, with no rotation
    of a zero vector computed at every stage (a rigid body under an MRP PD law ran 1.5-2.7x
    faster from 1 to 10 000 samples, Yu et al. (2022)'s loop 1.13-1.36x; benchmarks/README.md,
    "Zero reference rates known when the program is traced"). `q_d` is an array, a leaf of
    the closed loop like any gain.
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
        zero = np.zeros(3, self.q_d.dtype)
        return AttitudeReference(q_d=self.q_d, omega_d=zero, omega_d_dot=zero), None
