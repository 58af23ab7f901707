r"""Safe approach with collision avoidance under input saturation (Wu, Song, Sun 2018; SPEC
001(c), a documented **reconstruction**: the paper's controller equations are lost).

Two channels of the same design, each written for a second-order error $(e_1, e_2)$ whose
derivative $\dot e_2 = a + B\,u$ is affine in the input $u$:

- translation (Hill frame = target body frame, see `jaxatt.scenarios.wu2018`):
  $e_1 = \rho - \rho_d$, $e_2 = \dot\rho - \dot\rho_d$, $u$ the body-frame force, $B = C_{HN}
  C_{BN}^T/m$;
- attitude, in MRP coordinates: $e_1 = \sigma - \sigma_d$, $e_2 = \dot\sigma - \dot\sigma_d$ with
  $\dot\sigma = G(\sigma)\omega$, $u$ the torque, $B = G(\sigma)J^{-1}$.

Per channel, with the printed gain names (SPEC's template; our choices marked **[R]**):

- sliding variable $s = e_2 + \kappa$, $\kappa = \mathrm{sat}_L(w + b)$ with the channel's own
  limit $L$ (below):
  - `surface="terminal"` (default, **[R]**): $w = k_1e_1 + k_2\,\mathrm{sig}^\gamma(e_1)$, a
    fast terminal surface; on $s = 0$ the error obeys $\dot e_1 = -\mathrm{sat}_L(w + b)$;
  - `surface="integral"` (the template's literal form): $w = k_1e_1 + k_2\int_0^t
    \mathrm{sig}^\gamma(e_1)\,d\tau$ (`integral_start="zero_surface"` starts the integral where
    $s(0) = 0$, through the inverse of the channel's saturation when it has a limit and the
    initial rate error is below it);
  - $b = \nabla\Phi$, the avoidance term (translation only, `avoidance="surface"`): the gradient
    of Khatib's potential $\Phi = \frac{k_h}{2}\max(0, 1/\hat h - 1/\hat h_0)^2$ on $1/\hat h$,
    i.e. $k_h(1/\hat h - 1/\hat h_0)\nabla(1/\hat h)$, with $\hat h = h/N$ the collision-avoidance
    function normalised to a distance ([`SafeApproachSlidingMode.normalised_h`][]). On the
    sliding surface $\frac{d}{dt}(1/\hat h) = -c\,\nabla(1/\hat h)\cdot(w + b) < 0$ wherever
    $|\nabla(1/\hat h)|$ is large ($c > 0$ the saturation's scale), so $1/\hat h$ stays bounded
    and $h > 0$: the paper's argument, made at the velocity level. `avoidance="input"` adds
    $b$ to the commanded acceleration instead (the template's literal placement);
  - $\mathrm{sat}_L(\kappa) = \kappa/\sqrt{1 + \|\kappa\|^2/L^2}$ (**[R]**; no limit: the
    identity), a smooth bound $\|\kappa\| < L$ on the rate the surface asks for, per channel
    in that channel's units: translation `velocity_limit` $L = V$ [m/s] (the printed
    $k_1 = 0.5$ asks for 22 m/s from Case 1's 43.5 m), attitude `rate_limit` $L = R$ [1/s] on
    the MRP rate $\dot\sigma - \dot\sigma_d$ (about $\|\omega - \omega_d\|/4$ near
    $\sigma = 0$, since $G(0) = I/4$). Each is `None` (no limit) by default.
- auxiliary (anti-windup) system, $\Delta = B(\mathrm{sat}(u) - u)$ in channel units,
  $\dot\eta = -k_\eta\eta + \Delta$ (**[R]**), or with `template_auxiliary=True` the template's
  $\dot\eta = -k_\eta\eta - \frac{|s^\top\Delta| + \frac12\Delta^\top\Delta}{\max(\|\eta\|^2,
  \mu^2)}\eta + \Delta$ ($\mu$ guards $\eta = 0$; its $1/\|\eta\|^2$ gain makes the system stiff);
- compensated surface $z = s - \eta$ (**[R]**: how $\eta$ enters the law is lost);
- adaptive disturbance bound (sigma modification) $\dot{\hat d}_m = P_1\|s\| - P_2\hat d_m$;
- commanded channel acceleration $v = -a_0 - \dot\kappa - k_sz - k_3\mathrm{sig}^\gamma(z) -
  \hat d_m\tanh(z/\epsilon)$ and $u = \mathrm{sat}(B^{-1}v)$ per body axis, so that
  $\dot s = -k_sz - k_3\mathrm{sig}^\gamma(z) - \hat d_m\tanh(z/\epsilon)$ when unsaturated.

$a_0$ is the known drift (the relative-orbit model without $J_2$, the gyroscopic and
$\dot G\omega$ terms, the reference's second derivative). $\dot\kappa$ is exact except for the
terminal surface's slope $\gamma|e_1|^{\gamma-1}$, which is evaluated at $\max(|e_1|,
\text{floor})$ (its singularity at $e_1 = 0$).
"""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import (
    check_flag,
    check_in_open_interval,
    check_nonnegative,
    check_positive_scalar,
    check_scalar,
    check_spd,
)
from ..numerics import clip, maximum, minimum, safe_norm, sig_pow, solve3
from ..plants import Proximity, ProximityState
from ..references import PoseReference
from ..rotations import mrp_from_quat, mrp_kinematics_matrix, skew
from ..safety import CollisionAvoidance
from ._base import AbstractController


class ChannelState(eqx.Module):
    """`integral` $\\int \\mathrm{sig}^\\gamma(e_1)$, `eta` (auxiliary), `d_hat` (bound)."""

    integral: Float[Array, "3"]
    eta: Float[Array, "3"]
    d_hat: Float[Array, ""]


class SafeApproachState(eqx.Module):
    translation: ChannelState
    attitude: ChannelState


def _mrp_error(q, q_d, omega, omega_d, omega_d_dot):
    """$(\\sigma, G, \\dot G, e_1, e_2, \\ddot\\sigma_d)$ of the MRP channel."""
    sigma, sigma_d = mrp_from_quat(q), mrp_from_quat(q_d)
    g, g_d = mrp_kinematics_matrix(sigma), mrp_kinematics_matrix(sigma_d)
    sigma_dot, sigma_d_dot = g @ omega, g_d @ omega_d
    g_dot = jax.jvp(mrp_kinematics_matrix, (sigma,), (sigma_dot,))[1]
    g_d_dot = jax.jvp(mrp_kinematics_matrix, (sigma_d,), (sigma_d_dot,))[1]
    sigma_d_ddot = g_d_dot @ omega_d + g_d @ omega_d_dot
    return sigma, g, g_dot, sigma - sigma_d, sigma_dot - sigma_d_dot, sigma_d_ddot


class SafeApproachSlidingMode(AbstractController):
    r"""The 6-DOF safe-approach law of the module docstring, for a [`jaxatt.plants.Proximity`][].

    **Arguments:** `model` (the Proximity plant the law knows: mass, inertia, orbit; its orbit
    model's gravity is the known drift), `safety` (a [`jaxatt.safety.CollisionAvoidance`][]
    evaluated at the Hill-frame position), gains `k1, k2, k3, gamma, k_s, k_eta, k_h, P1, P2`
    (positive, $\gamma < 1$; $k_h \ge 0$, and $k_h = 0$ turns the avoidance term off inside
    the same compiled program), `force_limit` [N] and `torque_limit` [N m] (per body axis),
    `velocity_limit` $V$ [m/s] (translation channel only; `None`: none), `rate_limit` $R$
    [1/s] (attitude channel only, on the MRP rate error; `None`: none), `influence` $\hat h_0$
    [m] (default 2),
    `length` $L$ [m] (default 10), `epsilon` (tanh width, default 0.01), `mu` (guard of the
    template's auxiliary gain, default 1e-3), `floor` [m] (terminal slope guard, default
    0.01), `avoidance` (`"surface"`, `"input"` or `None`: no avoidance, the paper's "without
    the safety constraint"), `surface` (`"terminal"` or `"integral"`), `integral_start`
    (`"zero_surface"` or `"zero"`), `template_auxiliary` (bool).

    `admissible` is $h(\rho) > 0$: a sample that reaches the keep-out set gets status
    `constraint_violated` (never NaN). `check_initial` refuses a start or a target with
    $h \le 0$, naming which. **Signals:** `h`, `s_translation`, `s_attitude`, `eta_translation`,
    `eta_attitude`, `d_hat_translation`, `d_hat_attitude`, `sigma`, `sigma_error`,
    `commanded_force`, `commanded_torque`.
    """

    model: Proximity
    safety: CollisionAvoidance
    k1: Float[Array, ""]
    k2: Float[Array, ""]
    k3: Float[Array, ""]
    gamma: Float[Array, ""]
    k_s: Float[Array, ""]
    k_eta: Float[Array, ""]
    k_h: Float[Array, ""]
    P1: Float[Array, ""]
    P2: Float[Array, ""]
    force_limit: Float[Array, ""]
    torque_limit: Float[Array, ""]
    length: Float[Array, ""]
    influence: Float[Array, ""]
    floor: Float[Array, ""]
    velocity_limit: Float[Array, ""] | None
    rate_limit: Float[Array, ""] | None
    epsilon: Float[Array, ""]
    mu: Float[Array, ""]
    avoidance: str | None = eqx.field(static=True)
    integral_start: str = eqx.field(static=True)
    surface: str = eqx.field(static=True)
    template_auxiliary: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = ProximityState
    reference_type: ClassVar[type] = PoseReference

    def __init__(
        self,
        model: Proximity,
        safety: CollisionAvoidance,
        *,
        k1: RealScalarLike,
        k2: RealScalarLike,
        k3: RealScalarLike,
        gamma: RealScalarLike,
        k_s: RealScalarLike,
        k_eta: RealScalarLike,
        k_h: RealScalarLike,
        P1: RealScalarLike,
        P2: RealScalarLike,
        force_limit: RealScalarLike,
        torque_limit: RealScalarLike,
        length: RealScalarLike = 10.0,
        influence: RealScalarLike = 2.0,
        epsilon: RealScalarLike = 0.01,
        mu: RealScalarLike = 1e-3,
        avoidance: str | None = "surface",
        integral_start: str = "zero_surface",
        surface: str = "terminal",
        velocity_limit: RealScalarLike | None = None,
        rate_limit: RealScalarLike | None = None,
        floor: RealScalarLike = 1e-2,
        template_auxiliary: bool = False,
    ):
        where = "SafeApproachSlidingMode"
        if not isinstance(model, Proximity):
            raise ValueError(f"{where}: `model` must be a Proximity plant, got {model!r}.")
        if not isinstance(safety, CollisionAvoidance):
            raise ValueError(f"{where}: `safety` must be a CollisionAvoidance, got {safety!r}.")
        if avoidance not in ("surface", "input", None):
            raise ValueError(
                f"{where}: `avoidance` must be 'surface', 'input' or None, got {avoidance!r}."
            )
        if integral_start not in ("zero_surface", "zero"):
            raise ValueError(
                f"{where}: `integral_start` must be 'zero_surface' or 'zero', got "
                f"{integral_start!r}."
            )
        if surface not in ("terminal", "integral"):
            raise ValueError(
                f"{where}: `surface` must be 'terminal' or 'integral', got {surface!r}."
            )
        self.model, self.safety, self.avoidance = model, safety, avoidance
        self.surface = surface
        self.velocity_limit = (
            None
            if velocity_limit is None
            else check_positive_scalar(where, "velocity_limit", velocity_limit)
        )
        self.rate_limit = (
            None if rate_limit is None else check_positive_scalar(where, "rate_limit", rate_limit)
        )
        self.floor = check_positive_scalar(where, "floor", floor)
        self.integral_start = integral_start
        self.template_auxiliary = check_flag(where, "template_auxiliary", template_auxiliary)
        for name, value in dict(
            k1=k1,
            k2=k2,
            k3=k3,
            k_s=k_s,
            k_eta=k_eta,
            P1=P1,
            P2=P2,
            length=length,
            influence=influence,
            epsilon=epsilon,
            mu=mu,
            force_limit=force_limit,
            torque_limit=torque_limit,
        ).items():
            setattr(self, name, check_positive_scalar(where, name, value))
        self.gamma = check_in_open_interval(
            where, "gamma", check_scalar(where, "gamma", gamma), 0.0, 1.0
        )
        self.k_h = check_nonnegative(where, "k_h", check_scalar(where, "k_h", k_h))
        check_spd(where, "model.body.inertia", model.body.inertia)

    # -- the avoidance term -------------------------------------------------------------------
    def normalised_h(self, rho: Float[ArrayLike, "3"]) -> Float[Array, ""]:
        r"""$\hat h = h/N$ [m], the collision-avoidance function as a distance (**[R]**).

        $N = \sqrt{C^2\,4\|P\|^2 + O^2(4r^2 + F'(x)^2) + (h/L)^2}$ estimates $\|\nabla h\| =
        \|C\nabla O + O\nabla C\|$ from the sphere's slope $2P$ and the corridor's
        ([`jaxatt.safety.CollisionAvoidance.factors`][] gives $O$ and $C$). Near a wall
        $\hat h$ is about the distance to it, so the sphere and the corridor, whose $h$ differ in
        steepness by two orders of magnitude (about $10^5 d$ against $5\times10^2 d$ m$^4$ at
        distance $d$), repel alike; far from both $\hat h \le L$ (`length`). $N$ uses no
        derivative of $h$: a normaliser built from $\nabla h$ jumps with $h$'s second
        derivative at $x = a_1, a_2$ (the 0.1 m blend's slope reaches $10^3$ m), and the barrier
        then traps the chaser on those planes (measured). The price: in front of the blend
        $\hat h$ overestimates the distance to the lip up to about 15 times, so the barrier
        acts later there."""
        h, outer, inner = self.safety.value_and_factors(rho)
        x, r2 = rho[0], rho[1] ** 2 + rho[2] ** 2
        slope = self.safety.corridor.slope(minimum(x, self.safety.a2))
        scale2 = (
            inner**2 * 4.0 * (rho @ rho) + outer**2 * (4.0 * r2 + slope**2) + (h / self.length) ** 2
        )
        return h / jnp.sqrt(scale2)

    def potential(self, rho: Float[ArrayLike, "3"]) -> Float[Array, ""]:
        r"""$\frac{k_h}{2}\max(0, 1/\hat h - 1/\hat h_0)^2$ [m$^2$/s]: its gradient is
        $k_h(1/\hat h - 1/\hat h_0)\nabla(1/\hat h)$ inside the influence distance $\hat h_0$,
        zero outside (Khatib's repulsive potential on $1/\hat h$)."""
        excess = maximum(1.0 / self.normalised_h(rho) - 1.0 / self.influence, 0.0)
        return 0.5 * self.k_h * excess**2

    def barrier(self, rho: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
        r"""The avoidance velocity term $\nabla\Phi(\rho)$ [m/s] (points towards the keep-out
        set; unbounded at its boundary)."""
        return jax.grad(self.potential)(rho)

    def _barrier_and_rate(self, rho, rho_dot):
        if self.avoidance is None:
            return jnp.zeros(3), jnp.zeros(3)
        return jax.jvp(self.barrier, (rho,), (rho_dot,))

    # -- the two channels ---------------------------------------------------------------------
    def _translation_errors(self, y: ProximityState, r: PoseReference):
        orbit = y.orbit
        return orbit.rho - r.translation.position, orbit.rho_dot - r.translation.velocity

    def _attitude_errors(self, y: ProximityState, r: PoseReference):
        ra = r.attitude
        return _mrp_error(y.attitude.q, ra.q_d, y.attitude.omega, ra.omega_d, ra.omega_d_dot)

    def init(self, t0, measurement, reference) -> SafeApproachState:
        zero = ChannelState(jnp.zeros(3), jnp.zeros(3), jnp.zeros(()))
        if self.integral_start == "zero":
            return SafeApproachState(zero, zero)
        e1, e2 = self._translation_errors(measurement, reference)
        b, _ = self._barrier_and_rate(measurement.orbit.rho, measurement.orbit.rho_dot)
        b = b if self.avoidance == "surface" else jnp.zeros(3)
        _, _, _, a1, a2, _ = self._attitude_errors(measurement, reference)
        return SafeApproachState(
            ChannelState(
                (self._unsaturated(-e2, self.velocity_limit) - self.k1 * e1 - b) / self.k2,
                jnp.zeros(3),
                jnp.zeros(()),
            ),
            ChannelState(
                (self._unsaturated(-a2, self.rate_limit) - self.k1 * a1) / self.k2,
                jnp.zeros(3),
                jnp.zeros(()),
            ),
        )

    @staticmethod
    def _unsaturated(kappa: Array, limit: Array | None) -> Array:
        r"""The $w + b$ whose saturation is `kappa`: $\mathrm{sat}_L^{-1}(\kappa) =
        \kappa/\sqrt{1 - \|\kappa\|^2/L^2}$ with the channel's `limit` $L$ (`kappa` itself
        without one), so that `integral_start="zero_surface"` gives $s(0) = 0$. Defined for
        $\|\kappa\| < L$; a larger initial rate error cannot be cancelled by any integral (the
        saturation's range is the open ball of radius $L$), and its norm is taken as
        $(1 - 10^{-6})L$."""
        if limit is None:
            return kappa
        v2 = limit**2
        ratio = jnp.minimum((kappa @ kappa) / v2, (1.0 - 1e-6) ** 2)
        return kappa / jnp.sqrt(1.0 - ratio)

    def check_initial(self, t0, measurement, reference) -> None:
        where = "SafeApproachSlidingMode"
        self.safety.check_safe(where, "initial position x0.orbit.rho", measurement.orbit.rho)
        self.safety.check_safe(
            where, "target position reference.translation.position", reference.translation.position
        )

    def _kinematic_command(
        self, e1, e2, power, state: ChannelState, barrier, barrier_rate, limit: Array | None
    ):
        r"""The surface's position part $\kappa$ (so $s = e_2 + \kappa$) and its rate;
        `power` is $\mathrm{sig}^\gamma(e_1)$, `limit` the channel's $L$ of
        $\mathrm{sat}_L$ (`velocity_limit` or `rate_limit`: each channel's in its own units)."""
        if self.surface == "integral":
            w = self.k1 * e1 + self.k2 * state.integral
            w_dot = self.k1 * e2 + self.k2 * power
        else:
            w = self.k1 * e1 + self.k2 * power
            # gamma |e1|^(gamma - 1) with |e1| floored (> 0): no C-library pow call per element
            # (not `abs_pow`, whose exponent must be >= 0; gamma - 1 is negative for gamma < 1)
            floored = maximum(jnp.abs(e1), self.floor)
            slope = self.gamma * jnp.exp((self.gamma - 1.0) * jnp.log(floored))
            w_dot = self.k1 * e2 + self.k2 * slope * e2
        kappa, kappa_dot = w + barrier, w_dot + barrier_rate
        if limit is None:
            return kappa, kappa_dot
        v2 = limit**2
        c = 1.0 / jnp.sqrt(1.0 + (kappa @ kappa) / v2)
        return c * kappa, c * kappa_dot - c**3 * (kappa @ kappa_dot) / v2 * kappa

    def _channel(
        self, e1, e2, power, drift, state: ChannelState, surface_term, surface_rate, extra, limit
    ):
        kappa, kappa_dot = self._kinematic_command(
            e1, e2, power, state, surface_term, surface_rate, limit
        )
        s = e2 + kappa
        z = s - state.eta
        v = (
            -drift
            - kappa_dot
            - self.k_s * z
            - self.k3 * sig_pow(z, self.gamma)
            - state.d_hat * jnp.tanh(z / self.epsilon)
            - extra
        )
        return s, v

    def _channel_rates(self, power, s, delta, state: ChannelState) -> ChannelState:
        eta = state.eta
        eta_dot = -self.k_eta * eta + delta
        if self.template_auxiliary:
            gain = (jnp.abs(s @ delta) + 0.5 * delta @ delta) / maximum(eta @ eta, self.mu**2)
            eta_dot = eta_dot - gain * eta
        d_dot = self.P1 * safe_norm(s) - self.P2 * state.d_hat
        return ChannelState(power, eta_dot, d_dot)

    def _laws(self, t, y: ProximityState, r: PoseReference, state: SafeApproachState):
        model, orbit, att = self.model, y.orbit, y.attitude
        # Translation (Hill frame).
        e1, e2 = self._translation_errors(y, r)
        drift = model.orbit.natural_acceleration(t, orbit) - r.translation.acceleration
        b, b_dot = self._barrier_and_rate(orbit.rho, orbit.rho_dot)
        zero = jnp.zeros(3)
        in_surface = self.avoidance == "surface"
        # sig^gamma(e_1) of each channel, computed once for the surface and the integral.
        power_f = sig_pow(e1, self.gamma)
        s_f, v_f = self._channel(
            e1,
            e2,
            power_f,
            drift,
            state.translation,
            b if in_surface else zero,
            b_dot if in_surface else zero,
            b if self.avoidance == "input" else zero,
            self.velocity_limit,
        )
        f_cmd = model.body_force(y, v_f)
        force = clip(f_cmd, -self.force_limit, self.force_limit)
        delta_f = model.thrust_acceleration(y, force - f_cmd)
        # Attitude (MRP coordinates).
        sigma, g, g_dot, a1, a2, sdd = self._attitude_errors(y, r)
        inertia = model.body.inertia
        power_t = sig_pow(a1, self.gamma)
        s_t, v_t = self._channel(
            a1,
            a2,
            power_t,
            g_dot @ att.omega - sdd,
            state.attitude,
            zero,
            zero,
            zero,
            self.rate_limit,
        )
        g_inv = g.T / (0.25 * (1.0 + sigma @ sigma)) ** 2
        tau_cmd = skew(att.omega) @ (inertia @ att.omega) + inertia @ (g_inv @ v_t)
        torque = clip(tau_cmd, -self.torque_limit, self.torque_limit)
        delta_t = g @ solve3(inertia, torque - tau_cmd)
        rates = SafeApproachState(
            self._channel_rates(power_f, s_f, delta_f, state.translation),
            self._channel_rates(power_t, s_t, delta_t, state.attitude),
        )
        extras = dict(
            s_translation=s_f,
            s_attitude=s_t,
            sigma=sigma,
            sigma_error=a1,
            commanded_force=f_cmd,
            commanded_torque=tau_cmd,
        )
        return jnp.concatenate([force, torque]), rates, extras

    def __call__(self, t, measurement, reference, state):
        u, rates, _ = self._laws(t, measurement, reference, state)
        return u, rates

    def admissible(self, t, measurement, reference, state):
        return self.safety(measurement.orbit.rho) > 0

    def signals(self, t, measurement, reference, state) -> dict[str, Array]:
        _, _, extras = self._laws(t, measurement, reference, state)
        return {
            "h": self.safety(measurement.orbit.rho),
            "eta_translation": state.translation.eta,
            "eta_attitude": state.attitude.eta,
            "d_hat_translation": state.translation.d_hat,
            "d_hat_attitude": state.attitude.d_hat,
            **extras,
        }
