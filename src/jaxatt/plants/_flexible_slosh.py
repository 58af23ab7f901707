r"""A liquid-filled flexible spacecraft: rigid hub, a slosh pendulum and appendage modes.

Shi & Song (2024) eqs. (1), (4)-(11), in the control-oriented form SPEC seed 002(b) settles on.
With the slosh pendulum's lateral displacement $\eta \in \mathbb R^2$ [m], the appendage's
mass-normalised modal coordinates $n \in \mathbb R^N$, and the auxiliary momenta
$\psi = \dot\eta + A^{-1}\delta\omega$, $\zeta = \dot n + B_s\omega$:

$$\dot q = \tfrac12 E(q)\omega,\qquad
(J + \Delta J(t))\,\dot\omega = -\omega^\times\big((J + \Delta J)\omega + B_s^T\dot n
+ \delta^T\dot\eta\big) - \delta^T\dot\psi - B_s^T\dot\zeta + T_d(t) + \tau,$$
$$\dot\psi = -A^{-1}C_f\psi - A^{-1}K_f\eta + A^{-1}C_fA^{-1}\delta\omega,\qquad
\dot\eta = \psi - A^{-1}\delta\omega,$$
$$\dot\zeta = -C_s\zeta - K_s n + C_sB_s\omega,\qquad \dot n = \zeta - B_s\omega.$$

The hub equation is the paper's (7), $J\dot\omega = -\omega^\times J\omega + \bar T_d + \tau$,
with its lumped disturbance written out:

$$\bar T_d = T_d - \omega^\times(\Delta J\omega + B_s^T\dot n + \delta^T\dot\eta)
- \Delta J\dot\omega + \delta^T(A^{-1}C_f\psi + A^{-1}K_f\eta - A^{-1}C_fA^{-1}\delta\omega)
+ B_s^T(C_s\zeta + K_s n - C_sB_s\omega)$$

(`δη'` as printed is `δ^T η'`; the pendulum's $m_pD$ and $F(\omega)\dot\eta$ terms are dropped
as higher order, as the paper does). [`FlexibleSloshSpacecraft.lumped_disturbance`][] evaluates
it.

**Which inertia is $J$.** Eliminating $\ddot\eta$ and $\ddot n$ from (4)-(6) gives (7) with
$J = J_{\mathrm{tot}} - B_s^TB_s - \delta^TA^{-1}\delta$, where $J_{\mathrm{tot}}$ is the
inertia in the coupled mass matrix

$$M = \begin{bmatrix} J_{\mathrm{tot}} & \delta^T & B_s^T\\ \delta & A & 0\\
B_s & 0 & I\end{bmatrix}
\succ 0 \iff J \succ 0 \quad(\text{Schur complement}).$$

SPEC decides that the printed $J$ is this effective $J$ of (7) (the default); its implied total
inertia and $M$'s smallest eigenvalue are reported by [`FlexibleSloshSpacecraft.total_inertia`][]
and [`FlexibleSloshSpacecraft.mass_matrix`][]. Read as $J_{\mathrm{tot}}$ instead
(`inertia_is_total=True`), the paper's data give an indefinite $M$ (smallest eigenvalue
-0.207): the constructor refuses it with a `ValueError`.

**Signals:** those of [`jaxatt.plants.RigidBodyQuaternion`][] (`attitude_error`,
`attitude_error_vector`, `attitude_error_angle`, `rate_error`, `disturbance` ($T_d$),
`quat_norm_error`), and `slosh_displacement` $\eta$ [m], `slosh_rate` $\dot\eta$ [m/s],
`modal_coordinates` $n$, `modal_rates` $\dot n$, `modal_energy`
$\tfrac12(\dot n^T\dot n + n^TK_sn)$ [J] and `slosh_energy`
$\tfrac12(\dot\eta^TA\dot\eta + \eta^TK_f\eta)$ [J].
"""

from collections.abc import Sequence
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._custom_types import Mat33, RealScalarLike, Vec3, Vector3Like
from .._validation import (
    check,
    check_batched_shape,
    check_flag,
    check_nonnegative,
    check_positive,
    check_positive_int,
    check_positive_scalar,
    check_shape,
    check_spd,
    check_tree_finite,
    check_unit_quaternions,
    describe,
    is_traced,
)
from ..metrics import AbstractMetric
from ..numerics import safe_norm, solve3
from ..references import AbstractReference, ConstantAttitude
from ..rotations import (
    attitude_error_quat,
    quat_angle,
    quat_kinematics,
    rate_error,
)
from ..signals import AbstractSignal, Constant, check_signal_shape
from ._base import AbstractPlant
from ._beam import CantileverBeam, cantilever_modes
from ._rigid_body import QuaternionState, _attitude_metrics, _attitude_reference, _positive_definite


def _array(value):
    """Lists and tuples become NumPy arrays (the checks take array-likes)."""
    return np.asarray(value, dtype=float) if isinstance(value, (list, tuple)) else value


class SloshPendulum(eqx.Module):
    r"""Equivalent spherical-pendulum slosh model, Shi & Song (2024) eq. (4).

    $A\ddot\eta + C_f\dot\eta + \delta\dot\omega + K_f\eta = 0$ with $A = m_pI_2$,
    $C_f = \begin{bmatrix}2c_1 & c_2\\ c_2 & 2c_3\end{bmatrix}$, $K_f = (m_pg/l)I_2$,
    $\delta = \begin{bmatrix}-m_pr_z & 0 & m_pr_x\\ m_pr_y & -m_pr_x & 0\end{bmatrix}$.

    **Arguments:**
    - `mass`: $m_p > 0$ [kg].
    - `length`: pendulum length $l > 0$ [m].
    - `gravity`: the (thrust) acceleration $g > 0$ [m/s^2] (1.689 in the paper, not 9.81).
    - `suspension`: $r_p = (r_x, r_y, r_z)$, the suspension point in the body frame [m].
    - `damping`: $(c_1, c_2, c_3)$ [N s/m]; $C_f$ must be positive semidefinite.
    """

    mass: Float[Array, ""]
    length: Float[Array, ""]
    gravity: Float[Array, ""]
    suspension: Float[Array, "3"]
    damping: Float[Array, "3"]

    def __init__(
        self,
        mass: RealScalarLike,
        length: RealScalarLike,
        gravity: RealScalarLike,
        suspension: Vector3Like,
        damping: Vector3Like,
    ):
        where = "SloshPendulum"
        suspension, damping = _array(suspension), _array(damping)
        self.mass = check_positive_scalar(where, "mass", mass)
        self.length = check_positive_scalar(where, "length", length)
        self.gravity = check_positive_scalar(where, "gravity", gravity)
        self.suspension = check(
            where,
            "suspension",
            check_shape(where, "suspension", suspension, (3,)),
            lambda xp, x: xp.isfinite(x),
            "must be finite",
        )
        damping = check_nonnegative(where, "damping", check_shape(where, "damping", damping, (3,)))
        self.damping = check(
            where,
            "damping",
            damping,
            lambda xp, c: 4 * c[0] * c[2] >= c[1] ** 2,
            "must give a positive semidefinite C_f = [[2c1, c2], [c2, 2c3]] (4 c1 c3 >= c2^2)",
        )

    @property
    def frequency(self) -> Float[Array, ""]:
        """Undamped slosh frequency $\\sqrt{g/l}$ [rad/s]."""
        return jnp.sqrt(self.gravity / self.length)

    def mass_matrix(self) -> Float[Array, "2 2"]:
        """$A = m_pI_2$ [kg]."""
        return self.mass * jnp.eye(2, dtype=self.mass.dtype)

    def damping_matrix(self) -> Float[Array, "2 2"]:
        """$C_f$ [N s/m]."""
        c1, c2, c3 = self.damping
        return jnp.array([[2 * c1, c2], [c2, 2 * c3]])

    def stiffness_matrix(self) -> Float[Array, "2 2"]:
        """$K_f = (m_pg/l)I_2$ [N/m]."""
        return self.mass * self.gravity / self.length * jnp.eye(2, dtype=self.mass.dtype)

    def coupling(self) -> Float[Array, "2 3"]:
        """$\\delta$ [kg m]: $\\delta\\dot\\omega = m_p[\\dot\\omega\\times r_p]_{y,z}$."""
        rx, ry, rz = self.suspension
        zero = jnp.zeros_like(rx)
        m = self.mass
        return jnp.array([[-m * rz, zero, m * rx], [m * ry, -m * rx, zero]])


class ModalAppendage(eqx.Module):
    r"""Appendage modes $B_s\dot\omega + \ddot n + C_s\dot n + K_sn = 0$, eq. (5) corrected.

    $K_s = \mathrm{diag}(\omega_i^2)$, $C_s = \mathrm{diag}(2\xi_i\omega_i)$.

    **Arguments:**
    - `frequencies`: $\omega_i > 0$ [rad/s], shape (N,).
    - `damping`: modal damping ratios $\xi_i > 0$, shape (N,) (a lightly damped structure
      has $\xi_i \ll 1$; zero or negative damping is refused).
    - `coupling`: $B_s$, shape (N, 3) [kg^(1/2) m]: row $i$ is how mode $i$ is driven by
      $\dot\omega$.

    Build it from a beam with [`ModalAppendage.from_beam`][].
    """

    frequencies: Float[Array, " N"]
    damping: Float[Array, " N"]
    coupling: Float[Array, "N 3"]

    def __init__(
        self,
        frequencies: Float[ArrayLike, " N"] | Sequence[RealScalarLike],
        damping: Float[ArrayLike, " N"] | Sequence[RealScalarLike],
        coupling: Float[ArrayLike, "N 3"] | Sequence[Vector3Like],
    ):
        where = "ModalAppendage"
        frequencies, damping, coupling = _array(frequencies), _array(damping), _array(coupling)
        self.frequencies = check_positive(where, "frequencies", frequencies)
        if self.frequencies.ndim != 1:
            raise ValueError(
                f"{where}: `frequencies` must have shape (N,), got {self.frequencies.shape}."
            )
        n = self.frequencies.shape[0]
        self.damping = check_positive(
            where, "damping", check_shape(where, "damping", damping, (n,))
        )
        self.coupling = check(
            where,
            "coupling",
            check_shape(where, "coupling", coupling, (n, 3)),
            lambda xp, x: xp.isfinite(x),
            "must be finite",
        )

    @classmethod
    def from_beam(
        cls,
        beam: CantileverBeam,
        damping: Float[ArrayLike, " N"] | list[float] | tuple[float, ...],
        *,
        axis: int = 2,
    ) -> "ModalAppendage":
        r"""The first N cantilever modes of `beam` (N = `len(damping)`), bending about the hub
        axis `axis` (the paper's beam: $B_s$ has its $b_i$ in the third column, `axis=2`)."""
        damping_arr = np.asarray(damping) if not is_traced(damping) else damping
        n_modes = int(np.shape(damping_arr)[0]) if np.ndim(damping_arr) == 1 else 0
        if n_modes < 1:
            raise ValueError(
                "ModalAppendage.from_beam: `damping` must have shape (N,) with N >= 1, got "
                f"{describe(damping_arr)}."
            )
        axis = check_positive_int("ModalAppendage.from_beam", "axis", axis, minimum=0)
        if axis > 2:
            raise ValueError(f"ModalAppendage.from_beam: `axis` must be 0, 1 or 2, got {axis}.")
        modes = cantilever_modes(beam, n_modes)
        coupling = jnp.zeros((n_modes, 3), modes.coupling.dtype).at[:, axis].set(modes.coupling)
        return cls(modes.frequencies, damping, coupling)

    def stiffness_matrix(self) -> Float[Array, "N N"]:
        """$K_s = \\mathrm{diag}(\\omega_i^2)$ [1/s^2]."""
        return jnp.diag(self.frequencies**2)

    def damping_matrix(self) -> Float[Array, "N N"]:
        """$C_s = \\mathrm{diag}(2\\xi_i\\omega_i)$ [1/s]."""
        return jnp.diag(2 * self.damping * self.frequencies)


class FlexibleSloshState(QuaternionState):
    """Hub attitude `q` (scalar first) and rate `omega` [rad/s], slosh displacement `eta` (2,)
    [m] and its momentum-like variable `psi` (2,) [m/s], modal coordinates `n` (N,) and
    `zeta` (N,) (see the module docstring: $\\psi = \\dot\\eta + A^{-1}\\delta\\omega$,
    $\\zeta = \\dot n + B_s\\omega$).

    It is a [`QuaternionState`][jaxatt.plants.QuaternionState], so every quaternion attitude
    controller reads it (only `q` and `omega`).
    """

    eta: Float[Array, "*batch 2"]
    psi: Float[Array, "*batch 2"]
    n: Float[Array, "*batch N"]
    zeta: Float[Array, "*batch N"]


def _coupled_mass_matrix(
    total: Mat33, delta: Float[Array, "2 3"], slosh_mass: Float[Array, "2 2"], b: Array
) -> Array:
    n = b.shape[0]
    dtype = total.dtype
    top = jnp.concatenate([total, delta.T, b.T], axis=1)
    middle = jnp.concatenate([delta, slosh_mass, jnp.zeros((2, n), dtype)], axis=1)
    bottom = jnp.concatenate([b, jnp.zeros((n, 2), dtype), jnp.eye(n, dtype=dtype)], axis=1)
    return jnp.concatenate([top, middle, bottom], axis=0)


class FlexibleSloshSpacecraft(AbstractPlant):
    r"""Rigid hub + slosh pendulum + appendage modes (see the module docstring).

    **Arguments:**
    - `inertia`: $J$ of eq. (7), the hub's effective inertia, symmetric positive definite
      (3, 3) [kg m^2] (with `inertia_is_total=True`: the total inertia $J_{\mathrm{tot}}$,
      from which $J = J_{\mathrm{tot}} - B_s^TB_s - \delta^TA^{-1}\delta$ is computed and
      required positive definite, i.e. the coupled mass matrix $M \succ 0$).
    - `slosh`: a [`SloshPendulum`][].
    - `appendage`: a [`ModalAppendage`][].
    - `inertia_perturbation`: signal $\Delta J(t)$ (3, 3) [kg m^2]; default zero. Like
      [`jaxatt.plants.RigidBody`][], no $\dot J$ term; $J + \Delta J(t)$ is checked positive
      definite after every step (`valid`).
    - `disturbance`: signal $T_d(t)$ (3,) [N m]; default zero.
    - `inertia_is_total`: read `inertia` as $J_{\mathrm{tot}}$ (static).

    The measurement is the full [`FlexibleSloshState`][] (a `QuaternionState`, so any
    quaternion attitude controller flies the hub); the default reference holds the identity.
    """

    inertia: Mat33
    slosh: SloshPendulum
    appendage: ModalAppendage
    inertia_perturbation: AbstractSignal
    disturbance: AbstractSignal
    measurement_type: ClassVar[type] = FlexibleSloshState

    def __init__(
        self,
        inertia: Float[ArrayLike, "3 3"],
        slosh: SloshPendulum,
        appendage: ModalAppendage,
        inertia_perturbation: AbstractSignal | None = None,
        disturbance: AbstractSignal | None = None,
        *,
        inertia_is_total: bool = False,
    ):
        where = "FlexibleSloshSpacecraft"
        if not isinstance(slosh, SloshPendulum):
            raise ValueError(f"{where}: `slosh` must be a SloshPendulum, got {type(slosh)}.")
        if not isinstance(appendage, ModalAppendage):
            raise ValueError(
                f"{where}: `appendage` must be a ModalAppendage, got {type(appendage)}."
            )
        self.slosh = slosh
        self.appendage = appendage
        if check_flag(where, "inertia_is_total", inertia_is_total):
            total = check_shape(where, "inertia", inertia, (3, 3))
            effective = total - self._coupling_inertia()
            if not is_traced(effective):
                host = np.asarray(effective)
                eig = np.linalg.eigvalsh(0.5 * (host + host.T))
                mass = np.asarray(self.mass_matrix_for_total(total))
                if eig[0] <= 0:
                    raise ValueError(
                        f"{where}: read as the total inertia (inertia_is_total=True), "
                        f"`inertia` = {describe(total)} leaves the effective inertia "
                        "J = J_tot - B_s^T B_s - delta^T A^-1 delta = "
                        f"{describe(host)} with smallest eigenvalue {eig[0]:.6g}: the coupled "
                        "mass matrix [[J_tot, delta^T, B_s^T], [delta, A, 0], [B_s, 0, I]] is "
                        f"not positive definite (smallest eigenvalue "
                        f"{np.linalg.eigvalsh(mass)[0]:.6g}). Read `inertia` as the effective J "
                        "of eq. (7) (the default) or use a lighter appendage."
                    )
            self.inertia = check_spd(where, "inertia (effective, J_tot - couplings)", effective)
        else:
            self.inertia = check_spd(where, "inertia", inertia)
        if inertia_perturbation is None:
            inertia_perturbation = Constant(jnp.zeros_like(self.inertia))
        if disturbance is None:
            disturbance = Constant(jnp.zeros(3, self.inertia.dtype))
        check_signal_shape(where, "inertia_perturbation", inertia_perturbation, (3, 3))
        check_signal_shape(where, "disturbance", disturbance, (3,))
        self.inertia_perturbation = inertia_perturbation
        self.disturbance = disturbance

    # --- Structure -------------------------------------------------------------------------

    @property
    def n_modes(self) -> int:
        return self.appendage.frequencies.shape[0]

    def _coupling_inertia(self) -> Mat33:
        """$B_s^TB_s + \\delta^TA^{-1}\\delta$ [kg m^2]."""
        b = self.appendage.coupling
        delta = self.slosh.coupling()
        return b.T @ b + delta.T @ delta / self.slosh.mass

    def total_inertia(self) -> Mat33:
        """Implied total inertia $J_{\\mathrm{tot}} = J + B_s^TB_s + \\delta^TA^{-1}\\delta$."""
        return self.inertia + self._coupling_inertia()

    def mass_matrix_for_total(self, total: Mat33) -> Float[Array, "M M"]:
        """The coupled mass matrix $M$ with `total` in its hub block."""
        return _coupled_mass_matrix(
            jnp.asarray(total),
            self.slosh.coupling(),
            self.slosh.mass_matrix(),
            self.appendage.coupling,
        )

    def mass_matrix(self) -> Float[Array, "M M"]:
        """The coupled mass matrix $M$ of the reading used (positive definite by construction)."""
        return self.mass_matrix_for_total(self.total_inertia())

    def inertia_at(self, t: RealScalarLike) -> Mat33:
        """$J + \\Delta J(t)$ [kg m^2]."""
        return self.inertia + self.inertia_perturbation(t)

    # --- Dynamics --------------------------------------------------------------------------

    def internal_rates(self, state: FlexibleSloshState) -> tuple[Array, Array, Array, Array]:
        r"""$(\dot\eta, \dot\psi, \dot n, \dot\zeta)$: they depend on the state only."""
        slosh, app = self.slosh, self.appendage
        delta = slosh.coupling()
        m = slosh.mass
        c_f = slosh.damping_matrix()
        k_f = slosh.stiffness_matrix()
        b = app.coupling
        c_s = app.damping_matrix()
        k_s = app.stiffness_matrix()
        omega = state.omega
        delta_omega = delta @ omega / m
        eta_dot = state.psi - delta_omega
        psi_dot = -(c_f @ state.psi + k_f @ state.eta - c_f @ delta_omega) / m
        b_omega = b @ omega
        n_dot = state.zeta - b_omega
        zeta_dot = -(c_s @ state.zeta + k_s @ state.n - c_s @ b_omega)
        return eta_dot, psi_dot, n_dot, zeta_dot

    def _hub_torque(self, t, state: FlexibleSloshState, rates) -> Vec3:
        """Everything on the right of $(J + \\Delta J)\\dot\\omega$ except $\\tau$."""
        eta_dot, psi_dot, n_dot, zeta_dot = rates
        delta = self.slosh.coupling()
        b = self.appendage.coupling
        inertia = self.inertia_at(t)
        omega = state.omega
        momentum = inertia @ omega + b.T @ n_dot + delta.T @ eta_dot
        return (
            -jnp.cross(omega, momentum) - delta.T @ psi_dot - b.T @ zeta_dot + self.disturbance(t)
        )

    def angular_acceleration(
        self, t: RealScalarLike, state: FlexibleSloshState, torque: Vec3
    ) -> Vec3:
        """$\\dot\\omega$ [rad/s^2] under the applied torque $\\tau$ [N m]."""
        rates = self.internal_rates(state)
        return solve3(self.inertia_at(t), self._hub_torque(t, state, rates) + torque)

    def vector_field(
        self, t: RealScalarLike, state: FlexibleSloshState, control: Vec3
    ) -> FlexibleSloshState:
        rates = self.internal_rates(state)
        eta_dot, psi_dot, n_dot, zeta_dot = rates
        omega_dot = solve3(self.inertia_at(t), self._hub_torque(t, state, rates) + control)
        return FlexibleSloshState(
            q=quat_kinematics(state.q, state.omega),
            omega=omega_dot,
            eta=eta_dot,
            psi=psi_dot,
            n=n_dot,
            zeta=zeta_dot,
        )

    def lumped_disturbance(
        self, t: RealScalarLike, state: FlexibleSloshState, control: Vec3
    ) -> Vec3:
        r"""$\bar T_d = J\dot\omega + \omega^\times J\omega - \tau$ [N m]: the lumped disturbance
        of eq. (7) (what the observer estimates), given the applied torque $\tau$."""
        omega_dot = self.angular_acceleration(t, state, control)
        omega = state.omega
        return self.inertia @ omega_dot + jnp.cross(omega, self.inertia @ omega) - control

    def measure(self, t: RealScalarLike, state: FlexibleSloshState) -> FlexibleSloshState:
        del t
        return state

    def valid(self, t: RealScalarLike, state: FlexibleSloshState) -> Bool[Array, ""]:
        del state
        return _positive_definite(self.inertia_at(t))

    def check_state(
        self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()
    ) -> FlexibleSloshState:
        where = "FlexibleSloshSpacecraft"
        if not isinstance(state, FlexibleSloshState):
            raise ValueError(
                f"{where}: `{name}` must be a FlexibleSloshState(q, omega, eta, psi, n, zeta), "
                f"got {type(state).__name__}."
            )
        check_tree_finite(where, name, state)
        n = self.n_modes
        return FlexibleSloshState(
            q=check_unit_quaternions(where, f"{name}.q", state.q, batch_shape),
            omega=check_batched_shape(where, f"{name}.omega", state.omega, (3,), batch_shape),
            eta=check_batched_shape(where, f"{name}.eta", state.eta, (2,), batch_shape),
            psi=check_batched_shape(where, f"{name}.psi", state.psi, (2,), batch_shape),
            n=check_batched_shape(where, f"{name}.n", state.n, (n,), batch_shape),
            zeta=check_batched_shape(where, f"{name}.zeta", state.zeta, (n,), batch_shape),
        )

    def rest_state(
        self, q: Float[ArrayLike, "4"], omega: Vector3Like | None = None
    ) -> FlexibleSloshState:
        r"""Hub at `q` with rate `omega` (default 0), slosh and modes at rest
        ($\dot\eta = \dot n = 0$, so $\psi = A^{-1}\delta\omega$, $\zeta = B_s\omega$)."""
        q = jnp.asarray(q, self.inertia.dtype)
        omega = jnp.zeros(3, q.dtype) if omega is None else jnp.asarray(omega, q.dtype)
        return FlexibleSloshState(
            q=q,
            omega=omega,
            eta=jnp.zeros(2, q.dtype),
            psi=self.slosh.coupling() @ omega / self.slosh.mass,
            n=jnp.zeros(self.n_modes, q.dtype),
            zeta=self.appendage.coupling @ omega,
        )

    def default_reference(self) -> AbstractReference:
        return ConstantAttitude()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """As [`jaxatt.plants.RigidBodyQuaternion.default_metrics`][]."""
        return _attitude_metrics(tolerance)

    def energies(self, state: FlexibleSloshState) -> tuple[Array, Array]:
        """(modal energy, slosh energy) [J] (see the module docstring)."""
        eta_dot, _, n_dot, _ = self.internal_rates(state)
        k_s = self.appendage.stiffness_matrix()
        modal = 0.5 * (jnp.sum(n_dot**2) + state.n @ k_s @ state.n)
        slosh = 0.5 * (
            self.slosh.mass * jnp.sum(eta_dot**2)
            + state.eta @ self.slosh.stiffness_matrix() @ state.eta
        )
        return modal, slosh

    def signals(self, t: RealScalarLike, state: FlexibleSloshState, reference) -> dict:
        reference = _attitude_reference("FlexibleSloshSpacecraft", reference)
        e = attitude_error_quat(state.q, reference.q_d)
        eta_dot, _, n_dot, _ = self.internal_rates(state)
        modal, slosh = self.energies(state)
        return {
            "attitude_error": e,
            "attitude_error_vector": e[1:],
            "attitude_error_angle": quat_angle(e),
            "rate_error": rate_error(e, state.omega, reference.omega_d),
            "disturbance": self.disturbance(t),
            "quat_norm_error": safe_norm(state.q) - 1,
            "slosh_displacement": state.eta,
            "slosh_rate": eta_dot,
            "modal_coordinates": state.n,
            "modal_rates": n_dot,
            "modal_energy": modal,
            "slosh_energy": slosh,
        }
