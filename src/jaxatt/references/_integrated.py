r"""A desired attitude obtained by integrating a prescribed angular velocity."""

from typing import ClassVar

import jax
import jax.numpy as jnp
from jaxtyping import ArrayLike, Float

from .._custom_types import Quaternion, RealScalarLike
from .._validation import check_unit_quaternion
from ..rotations import quat_kinematics
from ..signals import AbstractSignal, check_signal_shape
from ._base import AbstractReference, AttitudeReference


class IntegratedReference(AbstractReference):
    r"""$q_d$ integrated from $q_d(t_0)$ with $\dot q_d = \tfrac12 E(q_d)\,\omega_d(t)$.

    $\omega_d(t)$ is an analytic signal; $\dot\omega_d(t)$ is its exact time derivative,
    obtained with `jax.jvp` (no finite differences). $q_d$ is part of the closed-loop state and
    integrated by the same solver as the plant, and returned as integrated: the flow keeps
    $\|q_d\| = 1$ exactly, the solver only to its accuracy (not renormalised here; functions
    that need a unit quaternion, such as [`jaxatt.rotations.mrp_from_quat`][], say so).

    This is Chen et al. (2022)'s reference (SPEC 000, erratum E11): $q_d(0) = [1,0,0,0]$ and
    $\omega_d = 0.05[\sin(0.01\pi t), \sin(0.02\pi t), \sin(0.03\pi t)]$ rad/s propagated by the
    corrected eqs. (5)-(6) ($\dot q_{d0} = -\tfrac12 q_{dv}^T\omega_d$).

    **Arguments:**
    - `q_d0`: desired attitude at `t0`, a unit quaternion.
    - `omega_d`: signal of shape (3,) [rad/s], e.g. a [`jaxatt.signals.Sinusoid`][].
    """

    q_d0: Quaternion
    omega_d: AbstractSignal
    output_type: ClassVar[type] = AttitudeReference

    def __init__(self, q_d0: Float[ArrayLike, "4"], omega_d: AbstractSignal):
        self.q_d0 = check_unit_quaternion("IntegratedReference", "q_d0", q_d0)
        check_signal_shape("IntegratedReference", "omega_d", omega_d, (3,))
        self.omega_d = omega_d

    def init(self, t0: RealScalarLike) -> Quaternion:
        del t0
        return self.q_d0

    def __call__(
        self, t: RealScalarLike, state: Quaternion
    ) -> tuple[AttitudeReference, Quaternion]:
        t = jnp.asarray(t, dtype=state.dtype)
        omega_d, omega_d_dot = jax.jvp(self.omega_d, (t,), (jnp.ones_like(t),))
        reference = AttitudeReference(q_d=state, omega_d=omega_d, omega_d_dot=omega_d_dot)
        return reference, quat_kinematics(state, omega_d)
