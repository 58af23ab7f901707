r"""A chaser in proximity of a Keplerian target: relative orbit plus attitude, body-fixed thrust.

The translation is any [`jaxatt.plants.AbstractRelativeOrbit`][] (Hill frame, true anomaly
as a state); the attitude a [`jaxatt.plants.RigidBody`][] ($J(t)\dot\omega = -\omega\times
J\omega + \tau + d$, quaternion $q$ of the body relative to inertial space). The control is
one (6,) array $[f_B; \tau]$: a body-frame thrust force [N] and a torque [N m]. The thrust
couples the two: its Hill-frame acceleration is $u = C_{HN}(\theta)C_{BN}(q)^T f_B/m$, with
$C_{HN}$ from the target's orbit orientation ([`jaxatt.orbits.hill_rotation`][]).

**Signals** (with a [`jaxatt.references.PoseReference`][] whose translation is in the Hill
frame and attitude relative to inertial): the relative orbit's (`position_error`,
`velocity_error`, `position_norm`, `true_anomaly`, `disturbance`), `attitude_error`,
`attitude_error_angle` [rad], `rate_error`, and `pointing_error` [rad], the angle between
the body x axis and the direction to the target $-\rho$.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_finite, check_positive_scalar, check_scalar
from ..metrics import AbstractMetric
from ..numerics import safe_arccos, safe_norm
from ..orbits._relative_motion import hill_rotation
from ..references import AbstractReference, PoseReference
from ..rotations import attitude_error_quat, quat_angle, quat_kinematics, quat_to_dcm, rate_error
from ..signals import AbstractSignal
from ._base import AbstractPlant
from ._relative_orbit import AbstractRelativeOrbit, RelativeOrbitState
from ._rigid_body import QuaternionState, RigidBody, _pose_metrics


class ProximityState(eqx.Module):
    """`orbit`: a [`RelativeOrbitState`][]; `attitude`: a [`QuaternionState`][] (inertial)."""

    orbit: RelativeOrbitState
    attitude: QuaternionState


class Proximity(AbstractPlant):
    r"""Relative orbit + rigid-body attitude with body-fixed thrust (module docstring).

    **Arguments:** `orbit` (a relative-orbit plant), `mass` $m > 0$ [kg], `inertia` $J_0$,
    the target orbit's orientation `i`, `raan`, `argp` [rad]; optional
    `torque_disturbance` (3,) [N m] (the force disturbance is the orbit plant's, an
    acceleration).
    """

    orbit: AbstractRelativeOrbit
    body: RigidBody
    mass: Float[Array, ""]
    i: Float[Array, ""]
    raan: Float[Array, ""]
    argp: Float[Array, ""]
    measurement_type: ClassVar[type] = ProximityState

    def __init__(
        self,
        orbit: AbstractRelativeOrbit,
        mass: ArrayLike,
        inertia: ArrayLike,
        *,
        i: RealScalarLike = 0.0,
        raan: RealScalarLike = 0.0,
        argp: RealScalarLike = 0.0,
        torque_disturbance: AbstractSignal | None = None,
    ):
        if not isinstance(orbit, AbstractRelativeOrbit):
            raise ValueError(
                f"Proximity: `orbit` must be a relative-orbit plant, got {type(orbit).__name__}."
            )
        self.orbit = orbit
        self.body = RigidBody(inertia, None, torque_disturbance)
        self.mass = check_positive_scalar("Proximity", "mass", mass)
        self.i, self.raan, self.argp = (
            check_finite("Proximity", n, check_scalar("Proximity", n, v))
            for n, v in (("i", i), ("raan", raan), ("argp", argp))
        )

    def hill_rotation(self, theta: RealScalarLike) -> Float[Array, "3 3"]:
        """$C_{HN}(\\theta)$, inertial to Hill components."""
        return hill_rotation(theta, self.i, self.raan, self.argp)

    def thrust_acceleration(
        self, state: ProximityState, force: Float[Array, "3"]
    ) -> Float[Array, "3"]:
        """$C_{HN}C_{BN}^T f_B/m$ [m/s^2] (Hill frame)."""
        c_bn = quat_to_dcm(state.attitude.q)
        return self.hill_rotation(state.orbit.theta) @ (c_bn.T @ force) / self.mass

    def body_force(
        self, state: ProximityState, acceleration: Float[Array, "3"]
    ) -> Float[Array, "3"]:
        """The body-frame force giving the Hill-frame `acceleration`: $m C_{BN}C_{HN}^T u$."""
        c_bn = quat_to_dcm(state.attitude.q)
        return self.mass * c_bn @ (self.hill_rotation(state.orbit.theta).T @ acceleration)

    def vector_field(self, t, state: ProximityState, control) -> ProximityState:
        force, torque = control[:3], control[3:]
        orbit = self.orbit.vector_field(t, state.orbit, self.thrust_acceleration(state, force))
        att = state.attitude
        attitude = QuaternionState(
            quat_kinematics(att.q, att.omega), self.body.angular_acceleration(t, att.omega, torque)
        )
        return ProximityState(orbit, attitude)

    def measure(self, t, state):
        return state

    def signals(self, t, state: ProximityState, reference) -> dict[str, Array]:
        if not isinstance(reference, PoseReference):
            raise ValueError(
                "Proximity: its signals need a PoseReference (e.g. jaxatt.references.FlyAround), "
                f"got {type(reference).__name__}."
            )
        out = self.orbit.signals(t, state.orbit, reference.translation)
        e = attitude_error_quat(state.attitude.q, reference.attitude.q_d)
        c_bh = quat_to_dcm(state.attitude.q) @ self.hill_rotation(state.orbit.theta).T
        body_x = c_bh[0]  # body x axis in Hill components
        to_target = -state.orbit.rho / safe_norm(state.orbit.rho)
        out.update(
            attitude_error=e,
            attitude_error_angle=quat_angle(e),
            rate_error=rate_error(e, state.attitude.omega, reference.attitude.omega_d),
            pointing_error=safe_arccos(jnp.dot(body_x, to_target)),
        )
        return out

    def check_state(self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()):
        if not isinstance(state, ProximityState):
            raise ValueError(
                f"Proximity: `{name}` must be a ProximityState(orbit, attitude), got "
                f"{type(state).__name__}."
            )
        from ._rigid_body import RigidBodyQuaternion

        orbit = self.orbit.check_state(state.orbit, f"{name}.orbit", batch_shape)
        attitude = RigidBodyQuaternion(self.body.inertia).check_state(
            state.attitude, f"{name}.attitude", batch_shape
        )
        return ProximityState(orbit, attitude)

    def default_reference(self) -> AbstractReference:
        from ..references import ConstantPose

        return ConstantPose()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """`settle_time_position` of $\\|\\rho - \\rho_d\\|$ to `tolerance` [m],
        `settle_time_attitude` of the attitude-error angle to `tolerance` [rad] (the same number
        in each group's unit, as [`CoupledAttitudeOrbit`][jaxatt.plants.CoupledAttitudeOrbit] does),
        `peak_control` $\\max_{t,i}|u_i|$ over the force [N] and torque [N m] entries, `effort`
        $\\int\\|u\\|^2 dt$."""
        return _pose_metrics(tolerance)
