r"""Rigid-body attitude plants with quaternion or MRP kinematics.

Both plants integrate Euler's equation with a time-varying true inertia,

$$J(t)\,\dot\omega = -\omega \times J(t)\,\omega + u + d(t), \qquad J(t) = J_0 + \Delta J(t),$$

where $J_0$ is the nominal inertia [kg m^2] known to controllers, $\Delta J(t)$ an inertia
perturbation signal, $u$ the applied torque [N m] and $d(t)$ the disturbance torque [N m].
As in Chen et al. (2022) eq. (3) there is no $\dot J\,\omega$ term: the perturbation models an
uncertain inertia, not a mass-flow; this is the convention SPEC.md settles for every paper.

**Signals** (recorded at the save times, with the reference's $q_d, \omega_d$):

- `attitude_error`, (4,) or (3,): $e = q_d^{-1}\otimes q$ (quaternion plant) or its MRP
  $\sigma_e$ (MRP plant);
- `attitude_error_vector`, (3,): a 3-vector that vanishes at zero error,
  $e_v = \hat n\sin(\phi/2)$ (quaternion plant) or $\sigma_e = \hat n\tan(\phi/4)$ (MRP
  plant); its norm is the magnitude the default metrics time;
- `attitude_error_angle`, (): the rotation angle $\phi \in [0, \pi]$ of the error [rad], in
  either representation;
- `rate_error`, (3,): $\omega - C(e)\omega_d$ [rad/s];
- `disturbance`, (3,): $d(t)$ [N m];
- `quat_norm_error`, () (quaternion plant): $\|q\| - 1$.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._custom_types import MRP, Mat33, Quaternion, RealScalarLike, Vec3
from .._validation import (
    check_batched_shape,
    check_flag,
    check_spd,
    check_tree_finite,
    check_unit_quaternions,
    describe,
    is_traced,
)
from ..metrics import AbstractMetric, Effort, Euclidean, Peak, SettlingTime
from ..numerics import safe_norm, solve3
from ..references import AbstractReference, AttitudeReference, ConstantAttitude
from ..rotations import (
    attitude_error_mrp,
    attitude_error_quat,
    mrp_from_quat,
    mrp_kinematics,
    mrp_switch,
    quat_angle,
    quat_from_mrp,
    quat_kinematics,
    quat_normalize,
    rate_error,
    rate_error_mrp,
)
from ..signals import AbstractSignal, Constant, check_signal_shape
from ._base import AbstractPlant


def _positive_definite(m: Mat33) -> Bool[Array, ""]:
    """Sylvester's criterion on the symmetric part: all leading principal minors positive."""
    m = 0.5 * (m + m.T)
    minor1 = m[0, 0]
    minor2 = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
    minor3 = (
        m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1])
        - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0])
        + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0])
    )
    return (minor1 > 0) & (minor2 > 0) & (minor3 > 0)


class RigidBody(eqx.Module):
    r"""Euler's rotational equation $J(t)\dot\omega = -\omega\times J(t)\omega + u + d(t)$.

    The part shared by [`RigidBodyQuaternion`][] and [`RigidBodyMRP`][].

    **Arguments:**
    - `inertia`: nominal inertia $J_0$, symmetric positive definite, shape (3, 3) [kg m^2].
    - `inertia_perturbation`: signal $\Delta J(t)$ of shape (3, 3) [kg m^2]; default zero.
    - `disturbance`: signal $d(t)$ of shape (3,) [N m]; default zero.

    **Positive definiteness of $J(t)$.** Checked up front where it can be decided: if the
    signal's elementwise bound $B \ge |\Delta J(t)|$ ([`jaxatt.signals.AbstractSignal.bound`][])
    satisfies $\lambda_{\min}(J_0) > \|B\|_2$, then $J(t)$ is positive definite for every $t$
    (since $\|\Delta J\|_2 \le \||\Delta J|\|_2 \le \|B\|_2$), and nothing more is needed; if
    $J_0 + \Delta J(0)$ is not positive definite the constructor raises. Otherwise the run
    checks $J(t)$ after every completed step
    ([`valid`][jaxatt.plants.AbstractPlant.valid]) and reports a sample whose inertia stops
    being positive definite as `Status.invalid_plant`.
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
        _check_initial_inertia(self)

    def inertia_at(self, t: RealScalarLike) -> Mat33:
        """True inertia $J(t) = J_0 + \\Delta J(t)$ [kg m^2]."""
        return self.inertia + self.inertia_perturbation(t)

    def angular_acceleration(self, t: RealScalarLike, omega: Vec3, torque: Vec3) -> Vec3:
        r"""$\dot\omega = J(t)^{-1}(-\omega\times J(t)\omega + u + d(t))$ [rad/s^2]."""
        inertia = self.inertia_at(t)
        momentum = inertia @ omega
        return solve3(inertia, -jnp.cross(omega, momentum) + torque + self.disturbance(t))

    def inertia_positive_definite(self, t: RealScalarLike) -> Bool[Array, ""]:
        """Whether $J(t)$ is positive definite (Sylvester's criterion on its symmetric part)."""
        return _positive_definite(self.inertia_at(t))

    def certified_positive_definite(self) -> bool | None:
        r"""`True` if $\lambda_{\min}(J_0) > \|B\|_2$ for the perturbation's bound $B$ (so $J(t)$
        is positive definite at every $t$), `False` if not, `None` if it cannot be decided here
        (traced values or a signal without a bound)."""
        bound = self.inertia_perturbation.bound()
        if bound is None or is_traced(bound) or is_traced(self.inertia):
            return None
        smallest = np.linalg.eigvalsh(np.asarray(self.inertia))[0]
        return bool(smallest > np.linalg.norm(np.asarray(bound), 2))


def _check_initial_inertia(body: RigidBody) -> None:
    if body.certified_positive_definite() is not False:
        return
    try:
        initial = body.inertia_at(0.0)
    except Exception:  # a signal that cannot be evaluated eagerly: left to the run-time check
        return
    if is_traced(initial):
        return
    host = np.asarray(initial)
    if np.linalg.eigvalsh(0.5 * (host + host.T))[0] <= 0:
        raise ValueError(
            "RigidBody: the true inertia J0 + dJ(t) must be positive definite, but at t = 0 it "
            f"is not: J(0) = {describe(host)} (smallest eigenvalue "
            f"{np.linalg.eigvalsh(0.5 * (host + host.T))[0]:.6g}). Check `inertia_perturbation`."
        )


def _check_rate(where: str, name: str, omega, batch_shape: tuple[int, ...]) -> Array:
    return check_batched_shape(where, f"{name}.omega", omega, (3,), batch_shape)


def _attitude_metrics(tolerance: float) -> dict[str, AbstractMetric]:
    return {
        "settling_time": SettlingTime("attitude_error_vector", tolerance),
        "peak_torque": Peak("u"),
        "effort": Effort("u"),
        "max_rate_error": Peak("rate_error", Euclidean()),
    }


def _pose_metrics(tolerance: float) -> dict[str, AbstractMetric]:
    """The default metrics of the plants that fly a rigid body's attitude and a translation
    (`Proximity`, `SixDof`): settling of the position error's norm and of the attitude-error
    angle, each to `tolerance` in its own unit, and the peak and effort of the whole control."""
    return {
        "settle_time_position": SettlingTime("position_error", tolerance),
        "settle_time_attitude": SettlingTime("attitude_error_angle", tolerance),
        "peak_control": Peak("u"),
        "effort": Effort("u"),
    }


def _attitude_reference(where: str, reference) -> AttitudeReference:
    if not isinstance(reference, AttitudeReference):
        raise ValueError(
            f"{where}: its signals need an attitude reference (an AttitudeReference, e.g. from "
            f"ConstantAttitude or IntegratedReference), got {type(reference).__name__}."
        )
    return reference


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
      dt = 1e-3; the signal `quat_norm_error` records $\|q\| - 1$ so drift is visible rather
      than hidden).

    The measurement is the full state (`QuaternionState`); the default reference holds the
    identity attitude. Initial states passed to `simulate` must have
    $|\,\|q\| - 1| \le 10^{-6}$; normalize printed values (e.g. Chen 2022's $q(0)$ has norm
    1.000021) before use. Signals: see the module docstring.
    """

    body: RigidBody
    renormalize: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = QuaternionState

    def __init__(
        self,
        inertia: ArrayLike,
        inertia_perturbation: AbstractSignal | None = None,
        disturbance: AbstractSignal | None = None,
        *,
        renormalize: bool = False,
    ):
        self.body = RigidBody(inertia, inertia_perturbation, disturbance)
        self.renormalize = check_flag("RigidBodyQuaternion", "renormalize", renormalize)

    def vector_field(self, t: RealScalarLike, state: QuaternionState, control: Vec3):
        return QuaternionState(
            q=quat_kinematics(state.q, state.omega),
            omega=self.body.angular_acceleration(t, state.omega, control),
        )

    def measure(self, t: RealScalarLike, state: QuaternionState) -> QuaternionState:
        del t
        return state

    def update(self, t: RealScalarLike, state: QuaternionState) -> QuaternionState:
        del t
        if self.renormalize:
            return QuaternionState(q=quat_normalize(state.q), omega=state.omega)
        return state

    def valid(self, t: RealScalarLike, state: QuaternionState) -> Bool[Array, ""]:
        del state
        return self.body.inertia_positive_definite(t)

    def check_state(
        self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()
    ) -> QuaternionState:
        where = "RigidBodyQuaternion"
        if not isinstance(state, QuaternionState):
            raise ValueError(
                f"{where}: `{name}` must be a QuaternionState(q, omega), got "
                f"{type(state).__name__}."
            )
        check_tree_finite(where, name, state)
        q = check_unit_quaternions(where, f"{name}.q", state.q, batch_shape)
        return QuaternionState(q=q, omega=_check_rate(where, name, state.omega, batch_shape))

    def default_reference(self) -> AbstractReference:
        return ConstantAttitude()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """`settling_time` of the attitude-error vector's norm to `tolerance` (see the module
        docstring), `peak_torque` $\\max_{t,i}|u_i|$ [N m], `effort` $\\int\\|u\\|^2 dt$ and
        `max_rate_error` $\\max_t\\|\\omega_e\\|$ [rad/s]."""
        return _attitude_metrics(tolerance)

    def tracking_error(
        self, state: QuaternionState, reference: AttitudeReference
    ) -> tuple[Quaternion, Vec3]:
        """Error quaternion $e = q_d^{-1}\\otimes q$ and rate error $\\omega - C(e)\\omega_d$."""
        e = attitude_error_quat(state.q, reference.q_d)
        return e, rate_error(e, state.omega, reference.omega_d)

    def signals(self, t: RealScalarLike, state: QuaternionState, reference) -> dict[str, Array]:
        reference = _attitude_reference("RigidBodyQuaternion", reference)
        e, omega_e = self.tracking_error(state, reference)
        return {
            "attitude_error": e,
            "attitude_error_vector": e[1:],
            "attitude_error_angle": quat_angle(e),
            "rate_error": omega_e,
            "disturbance": self.body.disturbance(t),
            "quat_norm_error": safe_norm(state.q) - 1,
        }


class RigidBodyMRP(AbstractPlant):
    r"""Rigid body with MRP attitude, $\dot\sigma = G(\sigma)\omega$ plus [`RigidBody`][].

    $G(\sigma) = \tfrac14[(1 - \sigma^T\sigma)I + 2\sigma^\times + 2\sigma\sigma^T]$.

    **Arguments:** those of [`RigidBody`][] and
    - `shadow_switching`: if True (default), $\sigma \leftarrow -\sigma/\|\sigma\|^2$ after a
      completed step whenever $\|\sigma\| > 1$, so the attitude stays in the unit ball (the
      short rotation). Never applied between solver stages. Each switch is reported as the
      event `"shadow_switch"` (count and times in `Trajectory.events`), for cross-checks
      against tools that switch too (Basilisk counts them as `MRPSwitchCount`).
      Reproductions of Yu 2022 and Zhang 2021 set it False: those papers start outside the
      unit ball and do not switch.

    The measurement is the full state (`MRPState`); the default reference holds the identity.
    Signals: see the module docstring.
    """

    body: RigidBody
    shadow_switching: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = MRPState

    def __init__(
        self,
        inertia: ArrayLike,
        inertia_perturbation: AbstractSignal | None = None,
        disturbance: AbstractSignal | None = None,
        *,
        shadow_switching: bool = True,
    ):
        self.body = RigidBody(inertia, inertia_perturbation, disturbance)
        self.shadow_switching = check_flag("RigidBodyMRP", "shadow_switching", shadow_switching)

    def vector_field(self, t: RealScalarLike, state: MRPState, control: Vec3) -> MRPState:
        return MRPState(
            sigma=mrp_kinematics(state.sigma, state.omega),
            omega=self.body.angular_acceleration(t, state.omega, control),
        )

    def measure(self, t: RealScalarLike, state: MRPState) -> MRPState:
        del t
        return state

    def update(self, t: RealScalarLike, state: MRPState) -> MRPState:
        del t
        if self.shadow_switching:
            return MRPState(sigma=mrp_switch(state.sigma), omega=state.omega)
        return state

    def events(self, t: RealScalarLike, before: MRPState, after: MRPState) -> dict[str, Array]:
        del t, after
        if not self.shadow_switching:
            return {}
        return {"shadow_switch": jnp.sum(before.sigma**2) > 1}

    def valid(self, t: RealScalarLike, state: MRPState) -> Bool[Array, ""]:
        del state
        return self.body.inertia_positive_definite(t)

    def check_state(self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()) -> MRPState:
        where = "RigidBodyMRP"
        if not isinstance(state, MRPState):
            raise ValueError(
                f"{where}: `{name}` must be an MRPState(sigma, omega), got {type(state).__name__}."
            )
        check_tree_finite(where, name, state)
        sigma = check_batched_shape(where, f"{name}.sigma", state.sigma, (3,), batch_shape)
        return MRPState(sigma=sigma, omega=_check_rate(where, name, state.omega, batch_shape))

    def default_reference(self) -> AbstractReference:
        return ConstantAttitude()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """`settling_time` of the attitude-error vector's norm to `tolerance` (see the module
        docstring), `peak_torque` $\\max_{t,i}|u_i|$ [N m], `effort` $\\int\\|u\\|^2 dt$ and
        `max_rate_error` $\\max_t\\|\\omega_e\\|$ [rad/s]."""
        return _attitude_metrics(tolerance)

    def tracking_error(self, state: MRPState, reference: AttitudeReference) -> tuple[MRP, Vec3]:
        """MRP of $q_d^{-1}\\otimes q$ and the rate error $\\omega - C(\\sigma_e)\\omega_d$."""
        sigma_e = attitude_error_mrp(state.sigma, mrp_from_quat(reference.q_d))
        return sigma_e, rate_error_mrp(sigma_e, state.omega, reference.omega_d)

    def signals(self, t: RealScalarLike, state: MRPState, reference) -> dict[str, Array]:
        reference = _attitude_reference("RigidBodyMRP", reference)
        sigma_e, omega_e = self.tracking_error(state, reference)
        return {
            "attitude_error": sigma_e,
            "attitude_error_vector": sigma_e,
            "attitude_error_angle": quat_angle(quat_from_mrp(sigma_e)),
            "rate_error": omega_e,
            "disturbance": self.body.disturbance(t),
        }
