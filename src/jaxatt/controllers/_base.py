"""The controller interface."""

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, PyTree

from .._custom_types import RealScalarLike


class AbstractController(eqx.Module):
    """A feedback law with optional internal state, continuous and discrete.

    **Required:**
    - `init(t0, measurement, reference) -> state`: internal state at `t0` (`None` if none);
    - `__call__(t, measurement, reference, state) -> (control, state_dot)`: the commanded
      control and the derivative of the continuous internal state (`None` if none);
    - `measurement_type`: the measurement class the law reads (the plant's `measure` output,
      or [`jaxatt.observers.ObservedMeasurement`][] for laws that use an observer's estimate).

    **Optional hooks** (defaults do nothing; override what the law needs):
    - `update(t, measurement, reference, state) -> state`: the discrete part of the state,
      applied after every completed integration step under continuous control, and at every
      sample instant (before the control is computed) under a zero-order hold. Memories of
      past samples (fractional derivatives, integral surfaces, filters) live here;
    - `signals(t, measurement, reference, state) -> dict`: named signals recorded at the save
      times (e.g. the sliding variable `"s"`);
    - `admissible(t, measurement, reference, state) -> Bool[]`: whether the state is inside
      the set where the law's guarantees hold (e.g. inside a barrier). Checked after every
      completed step; a False makes the sample's status `constraint_violated`;
    - `check_initial(t0, measurement, reference)`: called by `simulate` on the *concrete*
      initial values, before anything is compiled, to refuse an inadmissible start with a
      `ValueError` that says why (see
      [`RateConstrainedFiniteTimeMRP`][jaxatt.controllers.RateConstrainedFiniteTimeMRP]).
      Inside a batch (`monte_carlo`, or your own `vmap`) nothing is raised, so one bad draw
      never aborts a study: `admissible` makes that sample `constraint_violated` at its first
      completed step;
    - `check_measurement(measurement_type, observed)`: the construction-time check that this
      law can read the plant's measurements (`observed`: the loop has an observer);
    - `reference_type`: the reference output class the law reads (default: any).

    Under a zero-order hold both the control and the continuous-state derivative are held over
    each controller period, i.e. continuous internal states advance by forward Euler at the
    controller rate, as on a flight computer.

    The hooks have default implementations on purpose (a deviation from the "abstract or
    final" rule of STYLE.md): most laws need none of them, and a required no-op in every law
    would say nothing.
    """

    measurement_type: eqx.AbstractClassVar[type]
    reference_type: ClassVar[type] = object

    @abc.abstractmethod
    def init(
        self, t0: RealScalarLike, measurement: PyTree[Array], reference: PyTree
    ) -> PyTree[Array]:
        """Internal state at the initial time."""

    @abc.abstractmethod
    def __call__(
        self, t: RealScalarLike, measurement: PyTree[Array], reference: PyTree, state: PyTree[Array]
    ) -> tuple[Float[Array, "..."], PyTree[Array]]:
        """Commanded control and continuous internal-state derivative."""

    def update(
        self, t: RealScalarLike, measurement: PyTree[Array], reference: PyTree, state: PyTree[Array]
    ) -> PyTree[Array]:
        """Discrete state update at completed steps or sample instants (default: none)."""
        del t, measurement, reference
        return state

    def signals(
        self, t: RealScalarLike, measurement: PyTree[Array], reference: PyTree, state: PyTree[Array]
    ) -> dict[str, Array]:
        """Named internal signals to record (default: none)."""
        del t, measurement, reference, state
        return {}

    def admissible(
        self, t: RealScalarLike, measurement: PyTree[Array], reference: PyTree, state: PyTree[Array]
    ) -> Bool[Array, ""]:
        """Whether the law's guarantees hold at this state (default: always)."""
        del t, measurement, reference, state
        return jnp.array(True)

    def check_initial(self, t0: float, measurement: PyTree[Array], reference: PyTree) -> None:
        """Refuse an inadmissible concrete initial state with a `ValueError` (default: accept)."""
        del t0, measurement, reference

    def check_measurement(self, measurement_type: type, observed: bool) -> None:
        """Raise `ValueError` unless this law can read measurements of `measurement_type`."""
        del observed
        if not issubclass(measurement_type, self.measurement_type):
            raise ValueError(
                f"ClosedLoop: {type(self).__name__} reads {self.measurement_type.__name__} "
                f"measurements, but the plant measures {measurement_type.__name__}; pair the "
                "controller with a plant whose `measure` returns what it reads "
                "(RigidBodyQuaternion -> QuaternionState, RigidBodyMRP -> MRPState)."
            )
