r"""Rigid body with 3-2-1 Euler-angle kinematics (SPEC 001(b), the model of the slides) [R].

States $x = (\phi, \theta, \psi, p, q, r)$: roll, pitch, yaw [rad] and the body rates [rad/s].

$$\begin{aligned}
\dot\phi &= p + (q\sin\phi + r\cos\phi)\tan\theta, &
\dot\theta &= q\cos\phi - r\sin\phi, &
\dot\psi &= (q\sin\phi + r\cos\phi)/\cos\theta,\\
J\dot\omega &= -\omega\times J\omega + M + d(t). &&&&
\end{aligned}$$

With a diagonal $J = \mathrm{diag}(J_x, J_y, J_z)$ Euler's equation is the slides' form
$\dot p = \frac{J_y - J_z}{J_x}qr + \frac{M_x}{J_x}$,
$\dot q = \frac{J_z - J_x}{J_y}pr + \frac{M_y}{J_y}$,
$\dot r = \frac{J_x - J_y}{J_z}pq + \frac{M_z}{J_z}$; a full symmetric positive-definite $J$ is
accepted too. **[E]** The slide prints $pr$ in $\dot r$; Euler's equation has $pq$, which is
what this plant integrates. `literal=True` integrates the printed
$\dot r = \frac{J_x - J_y}{J_z}pr + \frac{M_z}{J_z}$ (diagonal $J$ only); it does not conserve
the rotational kinetic energy of the torque-free motion, which is how the erratum shows.

**[R]** The slides survive only as fragments; this is the standard Euler-angle model consistent
with them (the fragment $(r\cos\phi + q\sin\phi)/\cos\theta$ survives), as SPEC reconstructs it.

**Gimbal lock.** The kinematics are singular at $\cos\theta = 0$. The pitch lives in the
band $\cos\theta > c_{\min}$ (`gimbal_margin`), i.e. $\theta \in (-\pi/2, \pi/2)$ up to
$2\pi$ (every attitude has 3-2-1 angles there). The plant never returns NaN: an initial state
outside the band is refused by `check_state`; [`valid`][] is False as soon as a completed step
ends with $\cos\theta \le c_{\min}$ (the sample's status becomes `invalid_plant`), which a
continuous motion cannot skip, since leaving the band makes $\cos\theta$ change sign (a test
of $|\cos\theta|$ alone would be jumped over by a finite step); and the vector field evaluates
$\cos\theta$ floored in magnitude at $c_{\min}$, so it stays finite inside the solver's
stages (exact wherever $|\cos\theta| \ge c_{\min}$).

**Signals** (with the reference's [`jaxatt.references.EulerAngleCommand`][]): `angle_error`
$y - y_d$ [rad] (plain difference, not wrapped), `angle_rate_error` $\dot y - \dot y_d$
[rad/s], `attitude_error_angle` the rotation angle between the body and the desired attitude
[rad] (wrap-free), `cos_theta`, `disturbance` [N m].
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._custom_types import RealScalarLike, Vec3
from .._validation import (
    check_batched_shape,
    check_flag,
    check_in_open_interval,
    check_scalar,
    check_tree_finite,
    is_traced,
)
from ..metrics import AbstractMetric, Effort, Euclidean, Peak, SettlingTime
from ..numerics import vectorized_cos
from ..references import AbstractReference, EulerAngleCommand, EulerAngleTrajectory
from ..rotations import attitude_error_quat, euler321_kinematics, euler321_to_quat, quat_angle
from ..signals import AbstractSignal
from ._base import AbstractPlant
from ._rigid_body import RigidBody


class EulerAngleState(eqx.Module):
    """3-2-1 Euler angles `angles` $= (\\phi, \\theta, \\psi)$ [rad] and body rates `omega`
    $= (p, q, r)$ [rad/s]. Leading batch axes are allowed."""

    angles: Float[Array, "*batch 3"]
    omega: Float[Array, "*batch 3"]


class RigidBodyEuler(AbstractPlant):
    r"""Rigid body with 3-2-1 Euler-angle attitude (module docstring).

    **Arguments:**
    - `inertia`: $J$, symmetric positive definite (3, 3) [kg m^2]; the slides' $\mathrm{diag}
      (J_x, J_y, J_z)$ or a full matrix.
    - `disturbance`: a signal $d(t)$ of shape (3,) [N m]; default zero.
    - `literal`: integrate the slide's printed $\dot r$ (with $pr$; erratum, see the module
      docstring). Requires a diagonal `inertia`. Default False (Euler's equation).
    - `gimbal_margin`: $c_{\min} \in (0, 1)$, the smallest $|\cos\theta|$ accepted (default
      1e-6).

    The measurement is the full state (`EulerAngleState`); the default reference holds zero
    angles.
    """

    body: RigidBody
    gimbal_margin: Float[Array, ""]
    literal: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = EulerAngleState

    def __init__(
        self,
        inertia: ArrayLike,
        disturbance: AbstractSignal | None = None,
        *,
        literal: bool = False,
        gimbal_margin: RealScalarLike = 1e-6,
    ):
        self.body = RigidBody(inertia, None, disturbance)
        self.literal = check_flag("RigidBodyEuler", "literal", literal)
        self.gimbal_margin = check_in_open_interval(
            "RigidBodyEuler",
            "gimbal_margin",
            check_scalar("RigidBodyEuler", "gimbal_margin", gimbal_margin),
            0.0,
            1.0,
        )
        if self.literal and not is_traced(self.body.inertia):  # traced: built under jit/vmap
            inertia = np.asarray(self.body.inertia)
            if np.any(inertia != np.diag(np.diag(inertia))):
                raise ValueError(
                    "RigidBodyEuler: `literal=True` (the slide's printed r' equation) is "
                    "written for a diagonal inertia diag(Jx, Jy, Jz), got inertia="
                    f"{inertia.tolist()}."
                )

    def angle_rates(self, angles: Vec3, omega: Vec3) -> Vec3:
        r"""$\dot y = R(\phi, \theta)\omega$ with $\cos\theta$ floored at `gimbal_margin`."""
        return euler321_kinematics(angles, omega, self.gimbal_margin)

    def angular_acceleration(self, t: RealScalarLike, omega: Vec3, torque: Vec3) -> Vec3:
        r"""$\dot\omega = J^{-1}(-\omega\times J\omega + M + d)$, or the literal printed form."""
        omega_dot = self.body.angular_acceleration(t, omega, torque)
        if not self.literal:
            return omega_dot
        jx, jy, jz = jnp.diag(self.body.inertia)
        p, q, r = omega
        printed_minus_euler = (jx - jy) / jz * (p * r - p * q)
        return omega_dot.at[2].add(printed_minus_euler)

    def vector_field(
        self, t: RealScalarLike, state: EulerAngleState, control: Vec3
    ) -> EulerAngleState:
        return EulerAngleState(
            angles=self.angle_rates(state.angles, state.omega),
            omega=self.angular_acceleration(t, state.omega, control),
        )

    def measure(self, t: RealScalarLike, state: EulerAngleState) -> EulerAngleState:
        del t
        return state

    def valid(self, t: RealScalarLike, state: EulerAngleState) -> Bool[Array, ""]:
        """False at or beyond gimbal lock: $\\cos\\theta \\le c_{\\min}$."""
        del t
        return vectorized_cos(state.angles[1]) > self.gimbal_margin

    def check_state(
        self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()
    ) -> EulerAngleState:
        where = "RigidBodyEuler"
        if not isinstance(state, EulerAngleState):
            raise ValueError(
                f"{where}: `{name}` must be an EulerAngleState(angles, omega), got "
                f"{type(state).__name__}."
            )
        check_tree_finite(where, name, state)
        angles = check_batched_shape(where, f"{name}.angles", state.angles, (3,), batch_shape)
        omega = check_batched_shape(where, f"{name}.omega", state.omega, (3,), batch_shape)
        if not is_traced(angles):  # traced values are left to `valid` at run time
            host = np.asarray(angles)
            cos_theta = np.cos(host[..., 1])
            margin = float(self.gimbal_margin)
            if np.any(cos_theta <= margin):
                raise ValueError(
                    f"{where}: `{name}.angles` has the pitch theta at or beyond the Euler-angle "
                    f"singularity: got theta = {np.asarray(host[..., 1]).tolist()} (cos theta = "
                    f"{cos_theta.tolist()}); the 3-2-1 pitch must satisfy cos(theta) > "
                    f"gimbal_margin = {margin:g}, i.e. theta in (-pi/2, pi/2)."
                )
        return EulerAngleState(angles=angles, omega=omega)

    def default_reference(self) -> AbstractReference:
        return EulerAngleTrajectory()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """`settling_time` of $\\|y - y_d\\|$ to `tolerance` [rad], `peak_torque`, `effort`,
        `max_rate_error` $\\max_t\\|\\omega\\|$ [rad/s]."""
        return {
            "settling_time": SettlingTime("angle_error", tolerance),
            "peak_torque": Peak("u"),
            "effort": Effort("u"),
            "max_rate_error": Peak("angle_rate_error", Euclidean()),
        }

    def signals(self, t: RealScalarLike, state: EulerAngleState, reference) -> dict[str, Array]:
        if not isinstance(reference, EulerAngleCommand):
            raise ValueError(
                "RigidBodyEuler: its signals need an EulerAngleCommand reference (from "
                f"EulerAngleTrajectory), got {type(reference).__name__}."
            )
        error_quat = attitude_error_quat(
            euler321_to_quat(state.angles), euler321_to_quat(reference.angles)
        )
        return {
            "angle_error": state.angles - reference.angles,
            "angle_rate_error": self.angle_rates(state.angles, state.omega) - reference.rates,
            "attitude_error_angle": quat_angle(error_quat),
            "cos_theta": vectorized_cos(state.angles[1]),
            "disturbance": self.body.disturbance(t),
        }
