"""The plant interface."""

import abc

import equinox as eqx
from jaxtyping import Array, Float, PyTree

from .._custom_types import RealScalarLike


class AbstractPlant(eqx.Module):
    """A physical system $\\dot x = f(t, x, u)$ with a named pytree state.

    Concrete plants define:
    - `vector_field(t, state, control, args) -> state_dot` (same pytree structure as `state`);
    - `post_step(state) -> state`: a map applied after every *completed* integration step
      (never between Runge-Kutta stages), e.g. the MRP shadow-set switch; identity when the
      plant needs none;
    - `check_state(state) -> state`: validates a user-supplied initial state (shapes, unit
      norm) and returns it converted to arrays, raising `ValueError` with the argument named;
    - `tracking_error(state, reference) -> (attitude_error, rate_error)`: the errors recorded
      in a [`jaxatt.Trajectory`][] (for attitude plants).
    - `state_type`: the class of its state (checked against the controller's
      `measurement_type` when a closed loop is built).
    """

    state_type: eqx.AbstractClassVar[type]

    @abc.abstractmethod
    def vector_field(
        self, t: RealScalarLike, state: PyTree[Array], control: Float[Array, " m"], args
    ) -> PyTree[Array]:
        """Time derivative of `state` under the applied `control` at time `t`."""

    @abc.abstractmethod
    def post_step(self, state: PyTree[Array]) -> PyTree[Array]:
        """Map applied to the state after each completed step."""

    @abc.abstractmethod
    def check_state(self, state: PyTree, name: str = "x0") -> PyTree[Array]:
        """Validate and convert a user-supplied state."""

    @abc.abstractmethod
    def tracking_error(self, state: PyTree[Array], reference) -> tuple[Array, Array]:
        """Attitude and rate errors of `state` relative to `reference`."""

    @abc.abstractmethod
    def disturbance_at(self, t: RealScalarLike) -> Float[Array, " m"]:
        """The external disturbance acting at time `t` (recorded; observers estimate it)."""
