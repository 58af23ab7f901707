"""Translational and pose references: a desired position, velocity and acceleration (and an
attitude)."""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_finite, check_shape
from ._base import AbstractReference, AttitudeReference
from ._constant import ConstantAttitude


class TranslationReference(eqx.Module):
    """Desired translation at one instant (the output of translational references), in the
    frame of the plant's position (e.g. the target's Hill frame for relative orbits).

    - `position`: $\\rho_d$ [m]; `velocity`: $\\dot\\rho_d$ [m/s];
      `acceleration`: $\\ddot\\rho_d$ [m/s^2] (derivatives seen in that frame).
    """

    position: Float[Array, "3"]
    velocity: Float[Array, "3"]
    acceleration: Float[Array, "3"]


class ConstantPosition(AbstractReference):
    """Hold the position `position` at rest (regulation; default the origin). No state."""

    position: Float[Array, "3"]
    output_type: ClassVar[type] = TranslationReference

    def __init__(self, position: Float[ArrayLike, "3"] | None = None):
        position = jnp.zeros(3) if position is None else position
        position = check_shape("ConstantPosition", "position", position, (3,))
        self.position = check_finite("ConstantPosition", "position", position)

    def init(self, t0: RealScalarLike) -> None:
        del t0
        return None

    def __call__(self, t: RealScalarLike, state: None) -> tuple[TranslationReference, None]:
        del t, state
        zero = jnp.zeros_like(self.position)
        return TranslationReference(self.position, zero, zero), None


class PoseReference(eqx.Module):
    """Desired pose at one instant: a [`TranslationReference`][] and an
    [`jaxatt.references.AttitudeReference`][]."""

    translation: TranslationReference
    attitude: AttitudeReference


class ConstantPose(AbstractReference):
    """Hold `position` [m] and attitude `q_d` at rest (defaults: origin, identity)."""

    position: ConstantPosition
    attitude: ConstantAttitude
    output_type: ClassVar[type] = PoseReference

    def __init__(
        self,
        position: Float[ArrayLike, "3"] | None = None,
        q_d: Float[ArrayLike, "4"] | None = None,
    ):
        self.position = ConstantPosition(position)
        self.attitude = ConstantAttitude(q_d)

    def init(self, t0: RealScalarLike) -> None:
        del t0
        return None

    def __call__(self, t: RealScalarLike, state: None) -> tuple[PoseReference, None]:
        translation, _ = self.position(t, None)
        attitude, _ = self.attitude(t, None)
        return PoseReference(translation, attitude), None
