"""The controller interface."""

import abc

import equinox as eqx
from jaxtyping import Array, Float, PyTree

from .._custom_types import RealScalarLike


class AbstractController(eqx.Module):
    """A feedback law with optional internal state integrated alongside the plant.

    - `init(t0, measurement, reference) -> state`: internal state at `t0` (`None` if none).
    - `__call__(t, measurement, reference, state) -> (control, state_dot)`: the commanded
      control and the derivative of the internal state (`None` if none). Under sampled
      (zero-order-hold) control both are held over each controller period, i.e. internal
      states are advanced by forward Euler at the controller rate, as on a flight computer.
    - `diagnostics(t, measurement, reference, state) -> dict`: named signals recorded in the
      trajectory (e.g. the sliding variable `"s"`); `{}` when there are none. The reserved key
      `"violation"` (a boolean scalar) marks states outside the law's admissible set, e.g. a
      crossed barrier; `simulate` then reports `RESULTS.constraint_violated` (checked at the
      saved times, so save every step when it matters).

    `measurement` is the plant state (full-state feedback) and `reference` an
    [`jaxatt.references.AttitudeReference`][]. `measurement_type` is the plant-state class the
    law needs (`object` when any will do); [`jaxatt.simulation.ClosedLoop`][] checks it.
    """

    measurement_type: eqx.AbstractClassVar[type]

    @abc.abstractmethod
    def init(self, t0: RealScalarLike, measurement: PyTree[Array], reference) -> PyTree[Array]:
        """Internal state at the initial time."""

    @abc.abstractmethod
    def __call__(
        self, t: RealScalarLike, measurement: PyTree[Array], reference, state: PyTree[Array]
    ) -> tuple[Float[Array, " m"], PyTree[Array]]:
        """Commanded control and internal-state derivative."""

    @abc.abstractmethod
    def diagnostics(
        self, t: RealScalarLike, measurement: PyTree[Array], reference, state: PyTree[Array]
    ) -> dict[str, Array]:
        """Named internal signals to record."""
