"""The observer interface."""

import abc

import equinox as eqx
from jaxtyping import Array, Float, PyTree

from .._custom_types import RealScalarLike


class AbstractObserver(eqx.Module):
    """A disturbance observer whose internal state is integrated alongside the plant.

    The same shape as a controller ([`jaxatt.controllers.AbstractController`][]):

    - `init(t0, measurement) -> state`: the observer's state at `t0`;
    - `__call__(t, measurement, control, state) -> state_dot`: the state derivative, given the
      measurement (the plant state) and the control torque applied to the plant;
    - `estimate(state) -> d_hat`: the current disturbance-torque estimate [N m], the quantity a
      composite controller subtracts;
    - `diagnostics(t, measurement, state) -> dict`: named signals to record (`{}` if none).

    `measurement_type` is the plant-state class the observer reads (`object` when any state
    with the fields it uses will do). Observers are combined with any attitude controller by
    [`jaxatt.controllers.ObserverCompensated`][], which integrates the observer state as part
    of the controller state.
    """

    measurement_type: eqx.AbstractClassVar[type]

    @abc.abstractmethod
    def init(self, t0: RealScalarLike, measurement: PyTree[Array]) -> PyTree[Array]:
        """Internal state at the initial time."""

    @abc.abstractmethod
    def __call__(
        self,
        t: RealScalarLike,
        measurement: PyTree[Array],
        control: Float[Array, " m"],
        state: PyTree[Array],
    ) -> PyTree[Array]:
        """Time derivative of the internal state."""

    @abc.abstractmethod
    def estimate(self, state: PyTree[Array]) -> Float[Array, " m"]:
        """The disturbance estimate carried by `state`, in the units of the control."""

    @abc.abstractmethod
    def diagnostics(
        self, t: RealScalarLike, measurement: PyTree[Array], state: PyTree[Array]
    ) -> dict[str, Array]:
        """Named internal signals to record."""
