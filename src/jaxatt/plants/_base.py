"""The plant interface: any controlled system with a named pytree state."""

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Bool, PyTree

from .._custom_types import RealScalarLike
from ..metrics import AbstractMetric
from ..references import AbstractReference, NoReference


class AbstractPlant(eqx.Module):
    r"""A physical system $\dot x = f(t, x, u)$ with a named pytree state $x$.

    Any plant family fits: one rigid body, a relative pose, a relative orbit, a body with modal
    or slosh coordinates, a network of agents (the agent axis a leading array axis). Nothing in
    `simulate`, `monte_carlo` or the tuning objectives inspects a plant's state; they use only
    this interface.

    **Required** (abstract):
    - `vector_field(t, state, control) -> state_dot`, with `state`'s pytree structure;
    - `measure(t, state) -> measurement`: what a controller or observer sees (an instance of
      `measurement_type`). A rigid body with extra modal coordinates can measure only its
      attitude and rate, so that any attitude controller can fly it;
    - `signals(t, state, reference) -> dict[str, Array]`: named outputs of any shape, recorded
      at the save times (tracking errors, energies, constraint functions, disturbances).
      `reference` is the reference component's output at `t`;
    - `check_state(state, name, batch_shape) -> state`: validate and convert a user-supplied
      initial state (or a batch of them, with leading axes `batch_shape`), raising
      `ValueError` with the argument (and the bad samples) named;
    - `measurement_type`: the class `measure` returns (checked against the controller's when a
      closed loop is built).

    **Optional hooks** (defaults do nothing; override what the plant needs):
    - `update(t, state) -> state`: a discrete map applied after every *completed* integration
      step, never between Runge-Kutta stages (MRP shadow switch, quaternion renormalization);
    - `events(t, before, after) -> dict[str, Bool[]]`: named discrete events of that update,
      counted and timed in the trajectory (e.g. `"shadow_switch"`);
    - `valid(t, state) -> Bool[]`: whether the plant's parameters are physical at `t` (e.g. a
      time-varying inertia still positive definite); a False after a completed step makes the
      sample's status `invalid_plant`;
    - `default_reference()`: the reference a closed loop uses when none is given;
    - `default_metrics(tolerance)`: the metric objects `monte_carlo` records when given none
      (default: none, so `monte_carlo` asks for `metrics=`).

    The hooks have default implementations on purpose (a deviation from the "abstract or
    final" rule of STYLE.md): most plants need none of them, and a required no-op in every
    plant would say nothing.
    """

    measurement_type: eqx.AbstractClassVar[type]

    @abc.abstractmethod
    def vector_field(
        self, t: RealScalarLike, state: PyTree[Array], control: PyTree[Array]
    ) -> PyTree[Array]:
        """Time derivative of `state` under the applied `control` at time `t`."""

    @abc.abstractmethod
    def measure(self, t: RealScalarLike, state: PyTree[Array]) -> PyTree[Array]:
        """The measurement a controller reads (full-state feedback returns the state)."""

    @abc.abstractmethod
    def signals(
        self, t: RealScalarLike, state: PyTree[Array], reference: PyTree
    ) -> dict[str, Array]:
        """Named outputs recorded at the save times."""

    @abc.abstractmethod
    def check_state(
        self, state: PyTree, name: str = "x0", batch_shape: tuple[int, ...] = ()
    ) -> PyTree[Array]:
        """Validate and convert a user-supplied state (leading axes `batch_shape`)."""

    def update(self, t: RealScalarLike, state: PyTree[Array]) -> PyTree[Array]:
        """Discrete map after each completed step (default: none)."""
        del t
        return state

    def events(
        self, t: RealScalarLike, before: PyTree[Array], after: PyTree[Array]
    ) -> dict[str, Bool[Array, ""]]:
        """Named events of the discrete update `before -> after` (default: none)."""
        del t, before, after
        return {}

    def valid(self, t: RealScalarLike, state: PyTree[Array]) -> Bool[Array, ""]:
        """Whether the plant's parameters are physical at `t` (default: always)."""
        del t, state
        return jnp.array(True)

    def default_reference(self) -> AbstractReference:
        """The reference used when a closed loop is built without one (default: none)."""
        return NoReference()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """Metric objects for a Monte Carlo study of this plant (default: none)."""
        del tolerance
        return {}
