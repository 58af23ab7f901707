r"""An actuator wrapper that integrates the control energy of the applied control."""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array

from ._actuators import AbstractActuator, Ideal


class EnergyMeterState(eqx.Module):
    """The wrapped actuator's state and the accumulated energy $\\int_{t_0}^t\\|u\\|^2 d\\tau$."""

    inner: object
    energy: Array


class EnergyMeter(AbstractActuator):
    r"""Apply `inner` and integrate $E(t) = \int_{t_0}^{t}\|u(\tau)\|_2^2\,d\tau$ of the applied
    control as part of the closed-loop state (signal `"energy"`).

    With a zero-order hold and a stateless `inner` (ideal, saturations) the applied control is
    constant over each step, so a Runge-Kutta solver integrates $E$ exactly
    ($h\sum_k\|u_k\|^2$), whatever the save interval: use it where the trajectory is saved
    sparsely (e.g. controllers with long memories) or the control chatters between saves,
    where a trapezoid rule on the saved `u` would be wrong.
    """

    inner: AbstractActuator

    def __init__(self, inner: AbstractActuator | None = None):
        if inner is not None and not isinstance(inner, AbstractActuator):
            raise ValueError(
                f"EnergyMeter: `inner` must be an actuator model (e.g. Saturation(limit)) or "
                f"None, got {type(inner).__name__}."
            )
        self.inner = Ideal() if inner is None else inner

    def init(self, t0, command) -> EnergyMeterState:
        command = jnp.asarray(command)
        return EnergyMeterState(self.inner.init(t0, command), jnp.zeros((), command.dtype))

    def __call__(self, t, command, state: EnergyMeterState):
        applied, inner_dot = self.inner(t, command, state.inner)
        return applied, EnergyMeterState(inner_dot, jnp.sum(applied**2))

    def update(self, t, state: EnergyMeterState) -> EnergyMeterState:
        return EnergyMeterState(self.inner.update(t, state.inner), state.energy)

    def signals(self, t, command, state: EnergyMeterState) -> dict[str, Array]:
        return {**self.inner.signals(t, command, state.inner), "energy": state.energy}
