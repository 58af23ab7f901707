"""The reference interface: desired trajectories, possibly with a state of their own."""

import abc
from typing import ClassVar

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float, PyTree

from .._custom_types import Quaternion, RealScalarLike


class AttitudeReference(eqx.Module):
    """Desired attitude at one instant (the output of attitude references).

    - `q_d`: desired attitude quaternion (scalar first, desired frame relative to inertial).
    - `omega_d`: desired angular velocity in desired-frame components [rad/s].
    - `omega_d_dot`: its time derivative [rad/s^2].

    The rates may be NumPy arrays: constants known when the program is traced, such as
    [`ConstantAttitude`][jaxatt.references.ConstantAttitude]'s zeros, which the rate-error
    helpers of [`jaxatt.rotations`][] use to skip multiplying by zero.
    """

    q_d: Quaternion
    omega_d: Float[Array | np.ndarray, "3"]
    omega_d_dot: Float[Array | np.ndarray, "3"]


class AbstractReference(eqx.Module):
    """A desired trajectory, possibly with an internal state integrated with the plant.

    **Required:**
    - `init(t0) -> state`: the reference's own state at `t0` (`None` when it has none);
    - `__call__(t, state) -> (output, state_dot)`: the reference at `t` (any pytree, e.g. an
      [`AttitudeReference`][]) and the time derivative of its state;
    - `output_type`: the class of `output` (checked against the controller's
      `reference_type` when a closed loop is built).

    **Optional hooks** (defaults do nothing):
    - `update(t, state) -> state`: discrete map after each completed step (command shapers,
      sampled links);
    - `signals(t, state) -> dict`: named outputs recorded at the save times.
    """

    output_type: eqx.AbstractClassVar[type]

    @abc.abstractmethod
    def init(self, t0: RealScalarLike) -> PyTree[Array]:
        """Internal state at the initial time."""

    @abc.abstractmethod
    def __call__(self, t: RealScalarLike, state: PyTree[Array]) -> tuple[PyTree, PyTree[Array]]:
        """The reference at `t` and the time derivative of its internal state."""

    def update(self, t: RealScalarLike, state: PyTree[Array]) -> PyTree[Array]:
        """Discrete map after each completed step (default: none)."""
        del t
        return state

    def signals(self, t: RealScalarLike, state: PyTree[Array]) -> dict[str, Array]:
        """Named outputs recorded at the save times (default: none)."""
        del t, state
        return {}


class NoReference(AbstractReference):
    """No reference: regulation problems whose plant and controller need none. Output `None`."""

    output_type: ClassVar[type] = type(None)

    def init(self, t0: RealScalarLike) -> None:
        del t0
        return None

    def __call__(self, t: RealScalarLike, state: None) -> tuple[None, None]:
        del t, state
        return None, None
