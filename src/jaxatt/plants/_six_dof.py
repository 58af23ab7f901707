r"""A rigid body in six degrees of freedom with time-varying mass and inertia.

Yue & Li (2018) eqs. (3), (7), (8), (10): position $R$ [m] in a reference frame $N$
(inertial, no gravity), body-frame velocity $V = C R'$ [m/s], attitude quaternion $q$
(scalar first, body $B$ relative to $N$; $C = C_{BN}(q)$, [`jaxatt.rotations.quat_to_dcm`][])
and body rate $\omega$ [rad/s]:

$$\dot R = C^T V,\qquad m(t)\dot V = -m(t)\,\omega\times V + f + d_f(t),$$
$$\dot q = \tfrac12 q\otimes[0, \omega],\qquad
J(t)\dot\omega = -\omega\times J(t)\omega + \tau + d_\tau(t),$$

with $m(t) = m_0 + \Delta m(t)$, $J(t) = J_0 + \Delta J(t)$, and **no** $\dot m$ or $\dot J$
terms (the perturbations model an uncertain mass and inertia, not a mass flow; SPEC
001(d)). The control is one (6,) array $[f; \tau]$: body-frame force [N] and torque [N m];
the disturbances $d_f$, $d_\tau$ act in the body frame.

**Signals** (with a [`jaxatt.references.PoseReference`][]): `position_error` $R - R_d$,
`position_norm`, `velocity_error` $\dot R - \dot R_d$ (frame $N$), `attitude_error`
$e = q_d^{-1}\otimes q$, `attitude_error_angle` [rad], `rate_error`, `mass`,
`force_disturbance`, `torque_disturbance`.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._custom_types import RealScalarLike
from .._validation import (
    check_batched_shape,
    check_flag,
    check_positive,
    check_tree_finite,
    check_unit_quaternions,
    describe,
    is_traced,
)
from ..metrics import AbstractMetric
from ..references import AbstractReference, ConstantPose, PoseReference
from ..rotations import (
    attitude_error_quat,
    quat_angle,
    quat_kinematics,
    quat_normalize,
    quat_to_dcm,
    rate_error,
)
from ..signals import AbstractSignal, Constant, check_signal_shape
from ._base import AbstractPlant
from ._rigid_body import RigidBody, _pose_metrics


class SixDofState(eqx.Module):
    """Position `r` [m] (frame N), body-frame velocity `v` [m/s], attitude `q` (scalar first,
    body relative to N) and body rate `omega` [rad/s]."""

    r: Float[Array, "*batch 3"]
    v: Float[Array, "*batch 3"]
    q: Float[Array, "*batch 4"]
    omega: Float[Array, "*batch 3"]


def _certify_mass(mass: Array, variation: AbstractSignal) -> None:
    bound = variation.bound()
    if bound is None or is_traced(bound) or is_traced(mass):
        return
    smallest = float(np.asarray(mass)) - float(np.asarray(bound))
    if smallest <= 0:
        raise ValueError(
            "SixDof: the mass m0 + dm(t) must stay positive, but `mass_variation` is bounded "
            f"only by {describe(bound)} >= mass = {describe(mass)} (m(t) may reach "
            f"{smallest:.6g} kg)."
        )


class SixDof(AbstractPlant):
    r"""Rigid body in 6 DOF with time-varying mass and inertia (see the module docstring).

    **Arguments:**
    - `mass`: $m_0 > 0$ [kg]; `inertia`: $J_0$ (3, 3) symmetric positive definite [kg m^2].
    - `mass_variation`: signal $\Delta m(t)$ of shape () [kg] (default 0);
      `inertia_variation`: $\Delta J(t)$, shape (3, 3) [kg m^2] (default 0).
    - `force_disturbance`: $d_f(t)$, (3,) [N]; `torque_disturbance`: $d_\tau(t)$, (3,) [N m].
    - `renormalize`: $q \leftarrow q/\|q\|$ after every completed step (default False).

    **Raises** `ValueError` (naming the argument) if the variations' bounds allow
    $m(t) \le 0$ or an indefinite $J(t)$ at some time: $m_0 \le B_m$ or
    $\lambda_{\min}(J_0) \le \|B_J\|_2$. Without a bound the run checks $m(t) > 0$ and
    $J(t) \succ 0$ after every step (`valid`, status `invalid_plant`).
    """

    mass: Float[Array, ""]
    mass_variation: AbstractSignal
    force_disturbance: AbstractSignal
    body: RigidBody
    renormalize: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = SixDofState

    def __init__(
        self,
        mass: ArrayLike,
        inertia: ArrayLike,
        *,
        mass_variation: AbstractSignal | None = None,
        inertia_variation: AbstractSignal | None = None,
        force_disturbance: AbstractSignal | None = None,
        torque_disturbance: AbstractSignal | None = None,
        renormalize: bool = False,
    ):
        self.mass = check_positive("SixDof", "mass", mass)
        if self.mass.shape != ():
            raise ValueError(f"SixDof: `mass` must be a scalar, got shape {self.mass.shape}.")
        mass_variation = Constant(0.0) if mass_variation is None else mass_variation
        check_signal_shape("SixDof", "mass_variation", mass_variation, ())
        force_disturbance = (
            Constant(jnp.zeros(3)) if force_disturbance is None else force_disturbance
        )
        check_signal_shape("SixDof", "force_disturbance", force_disturbance, (3,))
        _certify_mass(self.mass, mass_variation)
        self.mass_variation = mass_variation
        self.force_disturbance = force_disturbance
        self.body = RigidBody(inertia, inertia_variation, torque_disturbance)
        if self.body.certified_positive_definite() is False:
            raise ValueError(
                "SixDof: the inertia J0 + dJ(t) must stay positive definite, but "
                "`inertia_variation`'s bound B has ||B||_2 = "
                f"{np.linalg.norm(np.asarray(self.body.inertia_perturbation.bound()), 2):.6g} "
                ">= the smallest eigenvalue of `inertia` "
                f"({np.linalg.eigvalsh(np.asarray(self.body.inertia))[0]:.6g})."
            )
        self.renormalize = check_flag("SixDof", "renormalize", renormalize)

    @property
    def inertia(self) -> Float[Array, "3 3"]:
        return self.body.inertia

    def mass_at(self, t: RealScalarLike) -> Float[Array, ""]:
        """$m(t) = m_0 + \\Delta m(t)$ [kg]."""
        return self.mass + self.mass_variation(t)

    def vector_field(self, t, state: SixDofState, control: Float[Array, "6"]) -> SixDofState:
        force, torque = control[:3], control[3:]
        c = quat_to_dcm(state.q)
        v_dot = -jnp.cross(state.omega, state.v) + (
            force + self.force_disturbance(t)
        ) / self.mass_at(t)
        return SixDofState(
            c.T @ state.v,
            v_dot,
            quat_kinematics(state.q, state.omega),
            self.body.angular_acceleration(t, state.omega, torque),
        )

    def update(self, t, state: SixDofState) -> SixDofState:
        if not self.renormalize:
            return state
        return SixDofState(state.r, state.v, quat_normalize(state.q), state.omega)

    def valid(self, t, state) -> Bool[Array, ""]:
        return (self.mass_at(t) > 0) & self.body.inertia_positive_definite(t)

    def measure(self, t, state: SixDofState) -> SixDofState:
        return state

    def signals(self, t, state: SixDofState, reference) -> dict[str, Array]:
        if not isinstance(reference, PoseReference):
            raise ValueError(
                "SixDof: its signals need a PoseReference (e.g. jaxatt.references.ConstantPose),"
                f" got {type(reference).__name__}."
            )
        position_error = state.r - reference.translation.position
        e = attitude_error_quat(state.q, reference.attitude.q_d)
        return {
            "position_error": position_error,
            "position_norm": jnp.sqrt(jnp.sum(position_error**2)),
            "velocity_error": quat_to_dcm(state.q).T @ state.v - reference.translation.velocity,
            "attitude_error": e,
            "attitude_error_angle": quat_angle(e),
            "rate_error": rate_error(e, state.omega, reference.attitude.omega_d),
            "mass": self.mass_at(t),
            "force_disturbance": self.force_disturbance(t),
            "torque_disturbance": self.body.disturbance(t),
        }

    def check_state(self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()):
        where = "SixDof"
        if not isinstance(state, SixDofState):
            raise ValueError(
                f"{where}: `{name}` must be a SixDofState(r, v, q, omega), got "
                f"{type(state).__name__}."
            )
        check_tree_finite(where, name, state)
        return SixDofState(
            check_batched_shape(where, f"{name}.r", state.r, (3,), batch_shape),
            check_batched_shape(where, f"{name}.v", state.v, (3,), batch_shape),
            check_unit_quaternions(where, f"{name}.q", state.q, batch_shape),
            check_batched_shape(where, f"{name}.omega", state.omega, (3,), batch_shape),
        )

    def default_reference(self) -> AbstractReference:
        return ConstantPose()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """As [`jaxatt.plants.Proximity.default_metrics`][], with the position error
        $r - r_d$ [m]."""
        return _pose_metrics(tolerance)
