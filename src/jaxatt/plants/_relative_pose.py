r"""Coupled attitude-orbit relative pose of a chaser near a tumbling target (Zhang et al. 2021).

The state holds the chaser's pose **errors** in its own body axes (eqs. 5-7) and the
target's inertial state, which is propagated with it (two-body gravity, torque-free Euler
equations, disturbances), so that every term of the error dynamics (8) is available:

$$\dot r_e = v_e - \omega_p\times r_e,\qquad m_p\dot v_e = L_1 + L_2 + L_3 + f_p + f_{pd},$$
$$\dot\sigma_e = G(\sigma_e)\,\omega_e,\qquad J_p\dot\omega_e = L_4 + L_5 + \tau_p + \tau_{pd},$$

with $\omega_t = P_e^\top(\omega_p - \omega_e)$, $P_e = C(\sigma_e)$ and (SPEC 003.1, corrected):

- $L_1 = -m_p\,\omega_p^\times v_e - m_p\,(P_e\omega_t)^{\times 2} P_e p_f$;
- $L_2 = -m_p P_e\,p_f^\times J_t^{-1}(\omega_t^\times J_t\omega_t - \tau_{td})$ ($P_e^\top$ in the
  bracket; printed $M_e^\top$);
- $L_3 = -m_p P_e f_{td}/m_t - m_p\mu\,r_p/\|r_p\|^3 + m_p P_e\,\mu\,r_t/\|r_t\|^3$ ($m_p$ on
  the gravity terms; printed without, a unit error);
- $L_4 = -\omega_p^\times J_p\omega_p - J_p\,\omega_p^\times\omega_e$;
- $L_5 = J_p P_e J_t^{-1}\omega_t^\times J_t\omega_t - J_p P_e J_t^{-1}\tau_{td}$;
- $G(\sigma_e) = \tfrac14[(1 - \sigma_e^\top\sigma_e)I + 2\sigma_e^\times + 2\sigma_e\sigma_e^\top]$
  (printed with $\sigma_p$).

Here $r_p = r_e + P_e r_d$ (chaser position, chaser axes), $r_t$ the target position in target
axes and $r_d = r_t + p_f$. In the paper's compact form (9): $e_1 = [r_e; \sigma_e]$,
$e_2 = [v_e; \omega_e]$, $\dot e_1 = A_1 e_1 + A_2 e_2$, $\dot e_2 = C^{-1}(B + u + d)$ with
$A_1 = \mathrm{blkdiag}(-\omega_p^\times, 0)$, $A_2 = \mathrm{blkdiag}(I, G(\sigma_e))$,
$B = [L_1 + L_2 + L_3;\, L_4 + L_5]$ and $C = \mathrm{blkdiag}(m_p I, J_p)$ (printed $J_t$).
[`RelativePoseModel`][] computes these terms; controllers that cancel $B$ hold one too.

SPEC 003.1 [V]: these derivatives equal central differences of a full inertial simulation of
both spacecraft; `tests/plants/test_relative_pose.py` repeats that check.
"""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Bool, Float

from .._custom_types import RealScalarLike, Vec3
from .._validation import (
    check_batched_shape,
    check_finite,
    check_positive_scalar,
    check_shape,
    check_spd,
    check_tree_finite,
)
from ..metrics import AbstractMetric, MaxAbs, Peak, SettlingTime
from ..numerics import inv3, solve3
from ..orbits import MU_EARTH, point_mass_gravity
from ..rotations import mrp_from_dcm, mrp_kinematics_matrix, mrp_switch, mrp_to_dcm
from ..signals import AbstractSignal, Constant, check_signal_shape
from ._base import AbstractPlant


class TargetState(eqx.Module):
    """The target's inertial state: `position` [m] and `velocity` [m/s] in inertial
    components, `attitude` (MRP relative to the inertial frame) and body `rate` [rad/s]."""

    position: Float[Array, "*batch 3"]
    velocity: Float[Array, "*batch 3"]
    attitude: Float[Array, "*batch 3"]
    rate: Float[Array, "*batch 3"]


class RelativePoseState(eqx.Module):
    r"""Chaser pose errors in chaser body axes, and the target it is relative to.

    - `position` $r_e$ [m], `velocity` $v_e$ [m/s], `attitude` $\sigma_e$ (MRP of the chaser
      body frame relative to the target body frame; never switched to its shadow set),
      `rate` $\omega_e$ [rad/s];
    - `target`: a [`TargetState`][].

    `e1` $= [r_e; \sigma_e]$ and `e2` $= [v_e; \omega_e]$ are the paper's stacked errors.
    """

    position: Float[Array, "*batch 3"]
    velocity: Float[Array, "*batch 3"]
    attitude: Float[Array, "*batch 3"]
    rate: Float[Array, "*batch 3"]
    target: TargetState

    @property
    def e1(self) -> Float[Array, "*batch 6"]:
        return jnp.concatenate([self.position, self.attitude], axis=-1)

    @property
    def e2(self) -> Float[Array, "*batch 6"]:
        return jnp.concatenate([self.velocity, self.rate], axis=-1)

    @classmethod
    def from_chaser(
        cls,
        chaser_position: Float[ArrayLike, "3"],
        chaser_velocity: Float[ArrayLike, "3"],
        chaser_attitude: Float[ArrayLike, "3"],
        chaser_rate: Float[ArrayLike, "3"],
        position_error: Float[ArrayLike, "3"],
        velocity_error: Float[ArrayLike, "3"],
        attitude_error: Float[ArrayLike, "3"],
        rate_error: Float[ArrayLike, "3"],
        offset: Float[ArrayLike, "3"],
    ) -> "RelativePoseState":
        r"""The state whose chaser has the given inertial state and errors (one sample).

        Inverts (1)-(7): $C_t = P_e^\top C_p$ (so $\sigma_t$ is the MRP of $C_t$),
        $\omega_t = P_e^\top(\omega_p - \omega_e)$, $r_d = P_e^\top(C_p r_p - r_e)$,
        $v_d = P_e^\top(C_p v_p - v_e)$, $r_t = C_t^\top(r_d - p_f)$,
        $v_t = C_t^\top(v_d - \omega_t\times p_f)$. With $\sigma_p = 0$, $\omega_p = 0$ (Zhang
        2021, Table 1) this gives $\sigma_t = -\sigma_e$ and $\omega_t = -P_e^\top\omega_e$.
        """
        c_p = mrp_to_dcm(chaser_attitude)
        sigma_e = jnp.asarray(attitude_error, dtype=float)
        p_e = mrp_to_dcm(sigma_e)
        c_t = p_e.T @ c_p
        omega_t = p_e.T @ (jnp.asarray(chaser_rate) - jnp.asarray(rate_error))
        offset = jnp.asarray(offset, dtype=float)
        r_d = p_e.T @ (c_p @ jnp.asarray(chaser_position) - jnp.asarray(position_error))
        v_d = p_e.T @ (c_p @ jnp.asarray(chaser_velocity) - jnp.asarray(velocity_error))
        sigma_t = mrp_from_dcm(c_t)
        # mrp_from_dcm picks the short rotation; keep the one that equals -sigma_e when
        # sigma_p = 0, so that the paper's sigma_t(0) = -sigma_e(0) is reproduced literally.
        shadow = -sigma_t / jnp.sum(sigma_t**2)
        literal = jnp.where(
            jnp.sum((shadow + sigma_e) ** 2) < jnp.sum((sigma_t + sigma_e) ** 2), shadow, sigma_t
        )
        target = TargetState(
            position=c_t.T @ (r_d - offset),
            velocity=c_t.T @ (v_d - jnp.cross(omega_t, offset)),
            attitude=literal,
            rate=omega_t,
        )
        return cls(
            position=jnp.asarray(position_error, dtype=float),
            velocity=jnp.asarray(velocity_error, dtype=float),
            attitude=sigma_e,
            rate=jnp.asarray(rate_error, dtype=float),
            target=target,
        )


class RelativePoseModel(eqx.Module):
    r"""The physical model of the chaser-target pair: the terms of Zhang et al. (2021) eq. (8).

    **Arguments:**
    - `chaser_mass` $m_p$ [kg], `chaser_inertia` $J_p$ [kg m^2];
    - `target_mass` $m_t$ [kg], `target_inertia` $J_t$ [kg m^2];
    - `offset` $p_f$: the desired chaser position in the target body frame [m];
    - `target_force` $f_{td}(t)$ [N] and `target_torque` $\tau_{td}(t)$ [N m]: disturbances
      on the (uncontrolled) target, in target body axes; default zero;
    - `mu`: gravitational parameter [m^3/s^2].

    The plant holds one with the true values; a controller that cancels $B$ holds its own
    copy (e.g. without the target disturbances, which it may not know).
    """

    chaser_mass: Float[Array, ""]
    chaser_inertia: Float[Array, "3 3"]
    target_mass: Float[Array, ""]
    target_inertia: Float[Array, "3 3"]
    offset: Float[Array, "3"]
    target_force: AbstractSignal
    target_torque: AbstractSignal
    mu: Float[Array, ""]

    def __init__(
        self,
        chaser_mass: RealScalarLike,
        chaser_inertia: ArrayLike,
        target_mass: RealScalarLike,
        target_inertia: ArrayLike,
        offset: ArrayLike,
        target_force: AbstractSignal | None = None,
        target_torque: AbstractSignal | None = None,
        mu: RealScalarLike = MU_EARTH,
    ):
        where = "RelativePoseModel"
        self.chaser_mass = check_positive_scalar(where, "chaser_mass", chaser_mass)
        self.chaser_inertia = check_spd(where, "chaser_inertia", chaser_inertia)
        self.target_mass = check_positive_scalar(where, "target_mass", target_mass)
        self.target_inertia = check_spd(where, "target_inertia", target_inertia)
        self.offset = check_finite(where, "offset", check_shape(where, "offset", offset, (3,)))
        zero = Constant(jnp.zeros(3))
        self.target_force = zero if target_force is None else target_force
        check_signal_shape(where, "target_force", self.target_force, (3,))
        self.target_torque = zero if target_torque is None else target_torque
        check_signal_shape(where, "target_torque", self.target_torque, (3,))
        self.mu = check_positive_scalar(where, "mu", mu)

    def without_target_disturbances(self) -> "RelativePoseModel":
        """The same model with $f_{td} = \\tau_{td} = 0$ (what a controller that does not know
        them cancels)."""
        zero = Constant(jnp.zeros_like(self.offset))
        return eqx.tree_at(lambda m: (m.target_force, m.target_torque), self, (zero, zero))

    def chaser_rate(self, state: RelativePoseState) -> Vec3:
        """$\\omega_p = \\omega_e + P_e\\omega_t$ [rad/s] in chaser axes."""
        return state.rate + mrp_to_dcm(state.attitude) @ state.target.rate

    def error_kinematics(self, state: RelativePoseState) -> tuple[Vec3, Vec3]:
        r"""$(\dot r_e, \dot\sigma_e) = A_1 e_1 + A_2 e_2$."""
        omega_p = self.chaser_rate(state)
        r_dot = state.velocity - jnp.cross(omega_p, state.position)
        sigma_dot = mrp_kinematics_matrix(state.attitude) @ state.rate
        return r_dot, sigma_dot

    def drift(self, t: RealScalarLike, state: RelativePoseState) -> tuple[Vec3, Vec3]:
        r"""$B = (L_1 + L_2 + L_3,\; L_4 + L_5)$ [N, N m] at `t`."""
        m_p, j_p, m_t, j_t = (
            self.chaser_mass,
            self.chaser_inertia,
            self.target_mass,
            self.target_inertia,
        )
        p_e = mrp_to_dcm(state.attitude)
        omega_t = state.target.rate
        omega_p = state.rate + p_e @ omega_t
        f_td, tau_td = self.target_force(t), self.target_torque(t)
        # Target angular acceleration: J_t w_t' = -w_t x J_t w_t + tau_td.
        target_accel = solve3(j_t, tau_td - jnp.cross(omega_t, j_t @ omega_t))
        c_t = mrp_to_dcm(state.target.attitude)
        r_t = c_t @ state.target.position  # target position, target axes
        r_p = state.position + p_e @ (r_t + self.offset)  # chaser position, chaser axes
        w = p_e @ omega_t  # = omega_p - omega_e
        l1 = -m_p * jnp.cross(omega_p, state.velocity) - m_p * jnp.cross(
            w, jnp.cross(w, p_e @ self.offset)
        )
        l2 = m_p * p_e @ jnp.cross(self.offset, target_accel)
        l3 = m_p * (
            -p_e @ f_td / m_t
            + point_mass_gravity(r_p, self.mu)
            - p_e @ point_mass_gravity(r_t, self.mu)
        )
        l4 = -jnp.cross(omega_p, j_p @ omega_p) - j_p @ jnp.cross(omega_p, state.rate)
        l5 = -j_p @ (p_e @ target_accel)
        return l1 + l2 + l3, l4 + l5

    def target_derivative(self, t: RealScalarLike, target: TargetState) -> TargetState:
        r"""The uncontrolled target: $\ddot r_t = -\mu r_t/\|r_t\|^3 + C_t^\top f_{td}/m_t$,
        $\dot\sigma_t = G(\sigma_t)\omega_t$, $J_t\dot\omega_t = -\omega_t^\times J_t\omega_t +
        \tau_{td}$ (inertial position and velocity, body rate)."""
        c_t = mrp_to_dcm(target.attitude)
        r = target.position
        accel = point_mass_gravity(r, self.mu) + c_t.T @ self.target_force(t) / self.target_mass
        j_t = self.target_inertia
        omega = target.rate
        return TargetState(
            position=target.velocity,
            velocity=accel,
            attitude=mrp_kinematics_matrix(target.attitude) @ omega,
            rate=solve3(j_t, self.target_torque(t) - jnp.cross(omega, j_t @ omega)),
        )

    def inverse_inertia(self) -> Float[Array, "6 6"]:
        r"""$C^{-1} = \mathrm{blkdiag}(I/m_p, J_p^{-1})$."""
        out = jnp.zeros((6, 6), dtype=self.chaser_inertia.dtype)
        out = out.at[:3, :3].set(jnp.eye(3) / self.chaser_mass)
        return out.at[3:, 3:].set(inv3(self.chaser_inertia))


class CoupledAttitudeOrbit(AbstractPlant):
    r"""The chaser's relative pose (eq. 8) near a propagated, tumbling target; see the module
    docstring for the equations and errata.

    **Arguments:**
    - `model`: the [`RelativePoseModel`][] (masses, inertias, $p_f$, target disturbances).
    - `disturbance_force` $f_{pd}(t)$ [N] and `disturbance_torque` $\tau_{pd}(t)$ [N m]: on
      the chaser, chaser body axes; default zero. Unknown to the controllers.

    The control is `u = [f_p; tau_p]` (6,) [N; N m] in chaser body axes. The measurement is
    the full state. After each completed step the *target's* MRP is switched to its shadow set
    when $\|\sigma_t\| > 1$ (it tumbles; the same attitude, event `"target_shadow_switch"`);
    the error MRP $\sigma_e$ is never switched (SPEC decision for seed 003).

    **Signals:** `position_error` $r_e$, `attitude_error` $\sigma_e$, `velocity_error` $v_e$,
    `rate_error` $\omega_e$ (3-vectors), `pose_error` $[e_1; e_2]$ (12,),
    `disturbance` $[f_{pd}; \tau_{pd}]$ (6,).
    """

    model: RelativePoseModel
    disturbance_force: AbstractSignal
    disturbance_torque: AbstractSignal
    measurement_type = RelativePoseState

    def __init__(
        self,
        model: RelativePoseModel,
        disturbance_force: AbstractSignal | None = None,
        disturbance_torque: AbstractSignal | None = None,
    ):
        where = "CoupledAttitudeOrbit"
        if not isinstance(model, RelativePoseModel):
            raise TypeError(
                f"{where}: `model` must be a RelativePoseModel, got {type(model).__name__}."
            )
        self.model = model
        zero = Constant(jnp.zeros(3))
        self.disturbance_force = zero if disturbance_force is None else disturbance_force
        check_signal_shape(where, "disturbance_force", self.disturbance_force, (3,))
        self.disturbance_torque = zero if disturbance_torque is None else disturbance_torque
        check_signal_shape(where, "disturbance_torque", self.disturbance_torque, (3,))

    def vector_field(
        self, t: RealScalarLike, state: RelativePoseState, control: Float[Array, "6"]
    ) -> RelativePoseState:
        model = self.model
        r_dot, sigma_dot = model.error_kinematics(state)
        b_force, b_torque = model.drift(t, state)
        force = b_force + control[:3] + self.disturbance_force(t)
        torque = b_torque + control[3:] + self.disturbance_torque(t)
        return RelativePoseState(
            position=r_dot,
            velocity=force / model.chaser_mass,
            attitude=sigma_dot,
            rate=solve3(model.chaser_inertia, torque),
            target=model.target_derivative(t, state.target),
        )

    def measure(self, t: RealScalarLike, state: RelativePoseState) -> RelativePoseState:
        del t
        return state

    def update(self, t: RealScalarLike, state: RelativePoseState) -> RelativePoseState:
        del t
        return eqx.tree_at(lambda s: s.target.attitude, state, mrp_switch(state.target.attitude))

    def events(
        self, t: RealScalarLike, before: RelativePoseState, after: RelativePoseState
    ) -> dict[str, Bool[Array, ""]]:
        del t, after
        return {"target_shadow_switch": jnp.sum(before.target.attitude**2) > 1}

    def signals(self, t: RealScalarLike, state: RelativePoseState, reference) -> dict[str, Array]:
        del reference
        return {
            "position_error": state.position,
            "attitude_error": state.attitude,
            "velocity_error": state.velocity,
            "rate_error": state.rate,
            "pose_error": jnp.concatenate([state.e1, state.e2]),
            "disturbance": jnp.concatenate([self.disturbance_force(t), self.disturbance_torque(t)]),
        }

    def check_state(
        self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()
    ) -> RelativePoseState:
        where = "CoupledAttitudeOrbit"
        if not isinstance(state, RelativePoseState) or not isinstance(state.target, TargetState):
            raise ValueError(
                f"{where}: `{name}` must be a RelativePoseState(position, velocity, attitude, "
                f"rate, target=TargetState(...)), got {type(state).__name__}; build one with "
                "RelativePoseState.from_chaser(...)."
            )
        check_tree_finite(where, name, state)

        def vec(value, label):
            return check_batched_shape(where, f"{name}.{label}", value, (3,), batch_shape)

        target = state.target
        return RelativePoseState(
            position=vec(state.position, "position"),
            velocity=vec(state.velocity, "velocity"),
            attitude=vec(state.attitude, "attitude"),
            rate=vec(state.rate, "rate"),
            target=TargetState(
                position=vec(target.position, "target.position"),
                velocity=vec(target.velocity, "target.velocity"),
                attitude=vec(target.attitude, "target.attitude"),
                rate=vec(target.rate, "target.rate"),
            ),
        )

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """Settling times of the four error groups (max-abs norm) to `tolerance` (in each
        group's unit), and the peak force and torque of the control."""
        return {
            f"settle_time_{group}": SettlingTime(signal, tolerance, MaxAbs())
            for group, signal in POSE_GROUPS.items()
        } | {"peak_control": Peak("u")}


POSE_GROUPS = {
    "position": "position_error",
    "attitude": "attitude_error",
    "velocity": "velocity_error",
    "angular_velocity": "rate_error",
}
"""The four error groups of Zhang et al. (2021) Table 2, and their signal names."""
