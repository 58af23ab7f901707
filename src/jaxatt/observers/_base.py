"""The observer interface, and the measurement a controller sees when a loop has an observer."""

import abc

import equinox as eqx
from jaxtyping import Array, Float, PyTree

from .._custom_types import RealScalarLike


class ObservedMeasurement(eqx.Module):
    """What a controller reads in a closed loop with an observer, if it asks for it.

    - `measurement`: the plant's measurement.
    - `estimate`: the observer's current estimate (e.g. a disturbance torque [N m]).

    Controllers whose `measurement_type` is `ObservedMeasurement` (e.g.
    [`jaxatt.controllers.ObserverCompensated`][]) receive this; every other controller
    receives the plant's measurement alone.
    """

    measurement: PyTree[Array]
    estimate: PyTree[Array]


class AbstractObserver(eqx.Module):
    """A state observer whose internal state is integrated alongside the plant.

    It lives in its own slot of the closed loop (`ClosedLoop(..., observer=...)`), reads the
    plant's measurement and the commanded control, and publishes an estimate.

    **Required:**
    - `init(t0, measurement) -> state`: the observer's state at `t0`;
    - `estimate(t, measurement, state) -> estimate`: the current estimate (e.g. a disturbance
      torque [N m]), handed to controllers that ask for it (see [`ObservedMeasurement`][]);
    - `__call__(t, measurement, control, state) -> state_dot`: the state derivative, given the
      measurement and the commanded control;
    - `measurement_type`: the measurement class it reads.

    **Optional hooks** (defaults do nothing): `update(t, measurement, state) -> state` after
    each completed step (or sample instant, under a zero-order hold), and
    `signals(t, measurement, state) -> dict` recorded at the save times.

    Under a zero-order hold the observer is part of the sampled flight software: its
    derivative is held over each period with the controller's.
    """

    measurement_type: eqx.AbstractClassVar[type]

    @abc.abstractmethod
    def init(self, t0: RealScalarLike, measurement: PyTree[Array]) -> PyTree[Array]:
        """Internal state at the initial time."""

    @abc.abstractmethod
    def estimate(
        self, t: RealScalarLike, measurement: PyTree[Array], state: PyTree[Array]
    ) -> PyTree[Array]:
        """The estimate carried by `state`."""

    @abc.abstractmethod
    def __call__(
        self,
        t: RealScalarLike,
        measurement: PyTree[Array],
        control: Float[Array, " m"],
        state: PyTree[Array],
    ) -> PyTree[Array]:
        """Time derivative of the internal state."""

    def update(
        self, t: RealScalarLike, measurement: PyTree[Array], state: PyTree[Array]
    ) -> PyTree[Array]:
        """Discrete map after each completed step or sample instant (default: none)."""
        del t, measurement
        return state

    def signals(
        self, t: RealScalarLike, measurement: PyTree[Array], state: PyTree[Array]
    ) -> dict[str, Array]:
        """Named internal signals to record (default: none)."""
        del t, measurement, state
        return {}
