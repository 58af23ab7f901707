r"""Rigid-body attitude plants with quaternion or MRP kinematics.

Both plants integrate Euler's equation with a time-varying true inertia,

$$J(t)\,\dot\omega = -\omega \times J(t)\,\omega + u + d(t), \qquad J(t) = J_0 + \Delta J(t),$$

where $J_0$ is the nominal inertia [kg m^2] known to controllers, $\Delta J(t)$ an inertia
perturbation signal, $u$ the applied torque [N m] and $d(t)$ the disturbance torque [N m].
As in Chen et al. (2022) eq. (3) there is no $\dot J\,\omega$ term: the perturbation models an
uncertain inertia, not a mass-flow; this is the convention SPEC.md settles for every paper.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import MRP, Mat33, Quaternion, RealScalarLike, Vec3
from .._validation import check_shape, check_spd, check_unit_quaternion
from ..numerics import solve3
from ..rotations import (
    attitude_error_mrp,
    attitude_error_quat,
    mrp_from_quat,
    mrp_kinematics,
    mrp_switch,
    quat_kinematics,
    quat_normalize,
    rate_error,
    rate_error_mrp,
)
from ._base import AbstractPlant
from ._signals import AbstractSignal, Constant, check_signal_shape


class RigidBody(eqx.Module):
    r"""Euler's rotational equation $J(t)\dot\omega = -\omega\times J(t)\omega + u + d(t)$.

    The part shared by [`RigidBodyQuaternion`][] and [`RigidBodyMRP`][].

    **Arguments:**
    - `inertia`: nominal inertia $J_0$, symmetric positive definite, shape (3, 3) [kg m^2].
    - `inertia_perturbation`: signal $\Delta J(t)$ of shape (3, 3) [kg m^2]; default zero.
      $J_0 + \Delta J(t)$ must stay positive definite along the run (not checked at every t:
      the caller's model guarantees it, e.g. Chen 2022's $|\Delta J| \le 3 < \lambda_{\min}(J_0)$).
    - `disturbance`: signal $d(t)$ of shape (3,) [N m]; default zero.
    """

    inertia: Mat33
    inertia_perturbation: AbstractSignal
    disturbance: AbstractSignal

    def __init__(
        self,
        inertia: ArrayLike,
        inertia_perturbation: AbstractSignal | None = None,
        disturbance: AbstractSignal | None = None,
    ):
        self.inertia = check_spd("RigidBody", "inertia", inertia)
        if inertia_perturbation is None:
            inertia_perturbation = Constant(jnp.zeros_like(self.inertia))
        if disturbance is None:
            disturbance = Constant(jnp.zeros(3, self.inertia.dtype))
        check_signal_shape("RigidBody", "inertia_perturbation", inertia_perturbation, (3, 3))
        check_signal_shape("RigidBody", "disturbance", disturbance, (3,))
        self.inertia_perturbation = inertia_perturbation
        self.disturbance = disturbance

    def inertia_at(self, t: RealScalarLike) -> Mat33:
        """True inertia $J(t) = J_0 + \\Delta J(t)$ [kg m^2]."""
        return self.inertia + self.inertia_perturbation(t)

    def angular_acceleration(self, t: RealScalarLike, omega: Vec3, torque: Vec3) -> Vec3:
        r"""$\dot\omega = J(t)^{-1}(-\omega\times J(t)\omega + u + d(t))$ [rad/s^2]."""
        inertia = self.inertia_at(t)
        momentum = inertia @ omega
        return solve3(inertia, -jnp.cross(omega, momentum) + torque + self.disturbance(t))


def _check_rate(where: str, name: str, omega) -> Vec3:
    return check_shape(where, f"{name}.omega", omega, (3,))


class QuaternionState(eqx.Module):
    """Attitude quaternion `q` (scalar first, body relative to inertial), body rate `omega` [rad/s].

    Leading batch axes are allowed (a batch of initial states for `vmap`).
    """

    q: Float[Array, "*batch 4"]
    omega: Float[Array, "*batch 3"]


class MRPState(eqx.Module):
    """Modified Rodrigues parameters `sigma` (body relative to inertial), body rate `omega` [rad/s].

    Leading batch axes are allowed (a batch of initial states for `vmap`).
    """

    sigma: Float[Array, "*batch 3"]
    omega: Float[Array, "*batch 3"]


class RigidBodyQuaternion(AbstractPlant):
    r"""Rigid body with quaternion attitude, $\dot q = \tfrac12 E(q)\omega$, plus [`RigidBody`][].

    **Arguments:** those of [`RigidBody`][] (`inertia`, `inertia_perturbation`, `disturbance`)
    and
    - `renormalize`: if True, $q \leftarrow q/\|q\|$ after every completed step. Default False:
      the quaternion is integrated as is (RK4 keeps $\|q\|$ within ~1e-12 of 1 over 100 s at
      dt = 1e-3; `Trajectory.signals["quat_norm_error"]` records $\|q\| - 1$ so drift is
      visible rather than hidden).

    Initial states passed to `simulate` must have $|\,\|q\| - 1| \le 10^{-6}$; normalize
    printed values (e.g. Chen 2022's $q(0)$ has norm 1.000021) before use.
    """

    body: RigidBody
    renormalize: bool = eqx.field(static=True)
    state_type: ClassVar[type] = QuaternionState

    def __init__(
        self,
        inertia: ArrayLike,
        inertia_perturbation: AbstractSignal | None = None,
        disturbance: AbstractSignal | None = None,
        *,
        renormalize: bool = False,
    ):
        self.body = RigidBody(inertia, inertia_perturbation, disturbance)
        self.renormalize = bool(renormalize)

    def vector_field(
        self, t: RealScalarLike, state: QuaternionState, control: Vec3, args
    ) -> QuaternionState:
        del args
        return QuaternionState(
            q=quat_kinematics(state.q, state.omega),
            omega=self.body.angular_acceleration(t, state.omega, control),
        )

    def post_step(self, state: QuaternionState) -> QuaternionState:
        if self.renormalize:
            return QuaternionState(q=quat_normalize(state.q), omega=state.omega)
        return state

    def check_state(self, state, name: str = "x0") -> QuaternionState:
        if not isinstance(state, QuaternionState):
            raise ValueError(
                f"RigidBodyQuaternion: `{name}` must be a QuaternionState(q, omega), got "
                f"{type(state).__name__}."
            )
        q = check_unit_quaternion("RigidBodyQuaternion", f"{name}.q", state.q)
        return QuaternionState(q=q, omega=_check_rate("RigidBodyQuaternion", name, state.omega))

    def tracking_error(self, state: QuaternionState, reference) -> tuple[Quaternion, Vec3]:
        """Error quaternion $e = q_d^{-1}\\otimes q$ and rate error $\\omega - C(e)\\omega_d$."""
        e = attitude_error_quat(state.q, reference.q_d)
        return e, rate_error(e, state.omega, reference.omega_d)

    def disturbance_at(self, t: RealScalarLike) -> Vec3:
        return self.body.disturbance(t)


class RigidBodyMRP(AbstractPlant):
    r"""Rigid body with MRP attitude, $\dot\sigma = G(\sigma)\omega$ plus [`RigidBody`][].

    $G(\sigma) = \tfrac14[(1 - \sigma^T\sigma)I + 2\sigma^\times + 2\sigma\sigma^T]$.

    **Arguments:** those of [`RigidBody`][] and
    - `shadow_switching`: if True (default), $\sigma \leftarrow -\sigma/\|\sigma\|^2$ after a
      completed step whenever $\|\sigma\| > 1$, so the attitude stays in the unit ball (the
      short rotation). Never applied between solver stages. Reproductions of Yu 2022 and
      Zhang 2021 set it False: those papers start outside the unit ball and do not switch.
    """

    body: RigidBody
    shadow_switching: bool = eqx.field(static=True)
    state_type: ClassVar[type] = MRPState

    def __init__(
        self,
        inertia: ArrayLike,
        inertia_perturbation: AbstractSignal | None = None,
        disturbance: AbstractSignal | None = None,
        *,
        shadow_switching: bool = True,
    ):
        self.body = RigidBody(inertia, inertia_perturbation, disturbance)
        self.shadow_switching = bool(shadow_switching)

    def vector_field(self, t: RealScalarLike, state: MRPState, control: Vec3, args) -> MRPState:
        del args
        return MRPState(
            sigma=mrp_kinematics(state.sigma, state.omega),
            omega=self.body.angular_acceleration(t, state.omega, control),
        )

    def post_step(self, state: MRPState) -> MRPState:
        if self.shadow_switching:
            return MRPState(sigma=mrp_switch(state.sigma), omega=state.omega)
        return state

    def check_state(self, state, name: str = "x0") -> MRPState:
        if not isinstance(state, MRPState):
            raise ValueError(
                f"RigidBodyMRP: `{name}` must be an MRPState(sigma, omega), got "
                f"{type(state).__name__}."
            )
        sigma = check_shape("RigidBodyMRP", f"{name}.sigma", state.sigma, (3,))
        return MRPState(sigma=sigma, omega=_check_rate("RigidBodyMRP", name, state.omega))

    def tracking_error(self, state: MRPState, reference) -> tuple[MRP, Vec3]:
        """MRP of $q_d^{-1}\\otimes q$ and the rate error $\\omega - C(\\sigma_e)\\omega_d$."""
        sigma_e = attitude_error_mrp(state.sigma, mrp_from_quat(reference.q_d))
        return sigma_e, rate_error_mrp(sigma_e, state.omega, reference.omega_d)

    def disturbance_at(self, t: RealScalarLike) -> Vec3:
        return self.body.disturbance(t)
