"""Open-loop torque commands."""

from typing import ClassVar

from .._custom_types import RealScalarLike, Vec3
from ..plants._signals import AbstractSignal, check_signal_shape
from ._base import AbstractController


class OpenLoop(AbstractController):
    """Apply a known torque history $u(t)$, ignoring the measurement.

    **Arguments:**
    - `torque`: a signal of shape (m,) [N m] (e.g. `Constant(jnp.zeros(3))` for torque-free
      motion, or a sum of [`jaxatt.plants.Pulse`][]s for a slew command).
    """

    torque: AbstractSignal
    measurement_type: ClassVar[type] = object

    def __init__(self, torque: AbstractSignal):
        check_signal_shape("OpenLoop", "torque", torque, (3,))
        self.torque = torque

    def init(self, t0: RealScalarLike, measurement, reference) -> None:
        del t0, measurement, reference
        return None

    def __call__(self, t: RealScalarLike, measurement, reference, state: None) -> tuple[Vec3, None]:
        del measurement, reference, state
        return self.torque(t), None

    def diagnostics(self, t, measurement, reference, state) -> dict:
        del t, measurement, reference, state
        return {}
