"""Open-loop torque commands."""

from typing import ClassVar

from jaxtyping import Array

from .._custom_types import RealScalarLike
from ..signals import AbstractSignal
from ._base import AbstractController


class OpenLoop(AbstractController):
    """Apply a known command history $u(t)$, ignoring the measurement and the reference.

    **Arguments:**
    - `torque`: a signal of the control's shape, e.g. (3,) [N m] for a rigid body
      (`Constant(jnp.zeros(3))` for torque-free motion, or a sum of
      [`jaxatt.signals.Pulse`][]s for a slew command), or a force for a translational plant.
    """

    torque: AbstractSignal
    measurement_type: ClassVar[type] = object

    def __init__(self, torque: AbstractSignal):
        if not isinstance(torque, AbstractSignal):
            raise ValueError(
                "OpenLoop: `torque` must be a jaxatt.signals signal (Constant, Sinusoid, Pulse, "
                f"Sum, ...), got {type(torque).__name__}."
            )
        self.torque = torque

    def init(self, t0: RealScalarLike, measurement, reference) -> None:
        del t0, measurement, reference
        return None

    def __call__(
        self, t: RealScalarLike, measurement, reference, state: None
    ) -> tuple[Array, None]:
        del measurement, reference, state
        return self.torque(t), None
