"""The reference (desired attitude) interface."""

import abc

import equinox as eqx
from jaxtyping import Array, PyTree

from .._custom_types import Quaternion, RealScalarLike, Vec3


class AttitudeReference(eqx.Module):
    """Desired attitude at one instant.

    - `q_d`: desired attitude quaternion (scalar first, desired frame relative to inertial).
    - `omega_d`: desired angular velocity in desired-frame components [rad/s].
    - `omega_d_dot`: its time derivative [rad/s^2].
    """

    q_d: Quaternion
    omega_d: Vec3
    omega_d_dot: Vec3


class AbstractReference(eqx.Module):
    """A desired trajectory, possibly with an internal state integrated with the plant.

    - `init(t0) -> state`: the reference's own state at `t0` (`None` when it has none);
    - `__call__(t, state) -> (AttitudeReference, state_dot)`.
    """

    @abc.abstractmethod
    def init(self, t0: RealScalarLike) -> PyTree[Array]:
        """Internal state at the initial time."""

    @abc.abstractmethod
    def __call__(
        self, t: RealScalarLike, state: PyTree[Array]
    ) -> tuple[AttitudeReference, PyTree[Array]]:
        """The reference at `t` and the time derivative of its internal state."""
