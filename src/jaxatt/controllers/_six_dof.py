r"""Coupled translation and attitude control of a 6-DOF body: Yue & Li (2018).

Translation, terminal sliding mode (16) with the chattering-free law (22) or its adaptive form
(24); attitude, the adaptive fast terminal sliding mode (25) of Zhu, Xia & Fu (2011).
The command is one (6,) array $[f; \tau]$ (body-frame force [N] and torque [N m]), the input
of [`jaxatt.plants.SixDof`][].
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import Vec3
from .._validation import (
    check_flag,
    check_gain_shape,
    check_in_open_interval,
    check_nonnegative,
    check_positive,
    check_scalar,
)
from ..numerics import safe_norm, sat, sig_pow, sign, spectral_norm
from ..plants import SixDofState
from ..references import PoseReference
from ..rotations import attitude_error_quat, quat_to_dcm, rate_error, skew
from ..sliding import TerminalSurface
from ._base import AbstractController


class SixDofAdaptiveState(eqx.Module):
    """Adaptive estimates: `m_hat` (of $\\mu m$, [N s/m]), `f_hat` (force bound [N]), `c_hat`
    [N m] and `k_hat` [N m s^2] (attitude bounds). All start at 0 in the paper."""

    m_hat: Float[Array, ""]
    f_hat: Float[Array, ""]
    c_hat: Float[Array, ""]
    k_hat: Float[Array, ""]


class AdaptiveTerminalSixDof(AbstractController):
    r"""Yue & Li (2018) eqs. (16), (22)/(24) and (25) (SPEC 001(d)).

    **Translation.** With $R = r - r_d$ and $\dot R = C^TV - \dot r_d$ (frame N), the surface
    (16) $S_1 = \dot R + \kappa_1 R + \kappa_2\,\mathrm{sig}^r(R)$
    ([`jaxatt.sliding.TerminalSurface`][], the $|R_i|^{r-1}$ singularity guarded by `floor`) and

    $$f = C\big\{-\kappa_3 S_1 - \kappa_4\,\mathrm{sig}^r(S_1) - \mathrm{sat}(S_1, e)\,
    [\hat m\|V\| + \hat f]\big\}\quad (24),$$

    $\dot{\hat m} = \|S_1\|\|V\| - \zeta_0\hat m$, $\dot{\hat f} = \|S_1\| - \zeta_1\hat f$
    (the Lyapunov-consistent regressors; `literal=True`: the printed
    $\dot{\hat m} = \|S_1\| - \zeta_0\hat m$, $\dot{\hat f} = \|S_1\|\|V\| - \zeta_1\hat f$).
    `adaptive=False` gives (22): the bracket is $\mu m\|V\| + F$ with the known `mass` $m$,
    force bound $F$ and $\mu = \|-\omega^\times + \kappa_1 I + \kappa_2 r\,
    \mathrm{diag}(\max(|R_i|, \epsilon)^{r-1})\|_2$. `sat` is the boundary layer
    $\mathrm{sat}(S_i/e_i)$; the switching term is inside $C\{\cdot\}$ (a body-frame force).

    **Attitude (25).** With $e = q_d^{-1}\otimes q$, $q_v = e_{1:3}$, $\omega_e$ the rate error:
    $S_2 = \omega_e + \lambda_1 q_v + \lambda_2\,\mathrm{sig}^p(q_v)$,
    $\tau = -\sigma\,\mathrm{sig}^p(S_2) - \mathrm{sign}(S_2)[\hat c + \hat k\|\omega\|^2]$,
    $\dot{\hat c} = p_0(\|S_2\| - \varepsilon_0\hat c)$,
    $\dot{\hat k} = p_1(\|S_2\|\|\omega\|^2 - \varepsilon_1\hat k)$.

    **Arguments** (scalars unless stated; $\kappa_{3,4}$, $\sigma$ may be (3,)):
    `k1`, `k2`, `exponent` $r\in(0,1)$, `k3`, `k4`, `boundary` $e_i$ [m/s], `zeta0`, `zeta1`;
    `lambda1`, `lambda2`, `p` $\in (0, 1)$, `sigma`, `eps0`, `eps1`, `p0`, `p1`;
    `adaptive`, `mass`, `force_bound` (for (22)), `literal`, `floor` (singularity guard, m),
    `attitude_boundary`: `None` (the paper's sign in (25)) or a width $\phi$ [rad/s] for
    $\mathrm{sat}(S_2/\phi)$ (a smooth-enough law for gradient-based tuning).

    **Signals:** `s_translation`, `s_attitude`, `m_hat`, `f_hat`, `c_hat`, `k_hat`.
    """

    surface: TerminalSurface
    k3: Float[Array, "*k"]
    k4: Float[Array, "*k"]
    boundary: Float[Array, "*k"]
    zeta0: Float[Array, ""]
    zeta1: Float[Array, ""]
    lambda1: Float[Array, ""]
    lambda2: Float[Array, ""]
    p: Float[Array, ""]
    sigma: Float[Array, "*k"]
    eps0: Float[Array, ""]
    eps1: Float[Array, ""]
    p0: Float[Array, ""]
    p1: Float[Array, ""]
    mass: Float[Array, ""]
    force_bound: Float[Array, ""]
    attitude_boundary: Float[Array, ""] | None
    adaptive: bool = eqx.field(static=True)
    literal: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = SixDofState
    reference_type: ClassVar[type] = PoseReference

    def __init__(
        self,
        *,
        k1: ArrayLike,
        k2: ArrayLike,
        exponent: ArrayLike,
        k3: ArrayLike,
        k4: ArrayLike,
        boundary: ArrayLike,
        lambda1: ArrayLike,
        lambda2: ArrayLike,
        p: ArrayLike,
        sigma: ArrayLike,
        zeta0: ArrayLike = 50.0,
        zeta1: ArrayLike = 70.0,
        eps0: ArrayLike = 0.2,
        eps1: ArrayLike = 0.2,
        p0: ArrayLike = 1.0,
        p1: ArrayLike = 1.0,
        adaptive: bool = True,
        mass: ArrayLike = 1.0,
        force_bound: ArrayLike = 0.0,
        literal: bool = False,
        floor: ArrayLike = 1e-3,
        attitude_boundary: ArrayLike | None = None,
    ):
        where = "AdaptiveTerminalSixDof"

        def gain(name, value):
            return check_gain_shape(where, name, check_positive(where, name, value))

        self.surface = TerminalSurface(k1, k2, exponent, floor)
        self.k3, self.k4 = gain("k3", k3), gain("k4", k4)
        self.boundary = gain("boundary", boundary)

        def scalar(name, value, check=check_positive):
            return check(where, name, check_scalar(where, name, value))

        self.zeta0, self.zeta1 = scalar("zeta0", zeta0), scalar("zeta1", zeta1)
        self.lambda1 = scalar("lambda1", lambda1)
        self.lambda2 = scalar("lambda2", lambda2)
        self.p = check_in_open_interval(where, "p", check_scalar(where, "p", p), 0.0, 1.0)
        self.sigma = gain("sigma", sigma)
        self.eps0, self.eps1 = scalar("eps0", eps0), scalar("eps1", eps1)
        self.p0, self.p1 = scalar("p0", p0), scalar("p1", p1)
        self.mass = scalar("mass", mass)
        self.force_bound = scalar("force_bound", force_bound, check_nonnegative)
        self.adaptive = check_flag("AdaptiveTerminalSixDof", "adaptive", adaptive)
        self.literal = check_flag("AdaptiveTerminalSixDof", "literal", literal)
        self.attitude_boundary = (
            None if attitude_boundary is None else scalar("attitude_boundary", attitude_boundary)
        )

    # --- errors and surfaces --------------------------------------------------------------

    def translation_errors(self, y: SixDofState, r: PoseReference) -> tuple[Vec3, Vec3]:
        c = quat_to_dcm(y.q)
        return y.r - r.translation.position, c.T @ y.v - r.translation.velocity

    def attitude_errors(self, y: SixDofState, r: PoseReference) -> tuple[Vec3, Vec3]:
        e = attitude_error_quat(y.q, r.attitude.q_d)
        return e[1:], rate_error(e, y.omega, r.attitude.omega_d)

    def surfaces(self, y: SixDofState, r: PoseReference) -> tuple[Vec3, Vec3]:
        big_r, big_r_dot = self.translation_errors(y, r)
        qv, omega_e = self.attitude_errors(y, r)
        s1 = self.surface(big_r, big_r_dot)
        s2 = omega_e + self.lambda1 * qv + self.lambda2 * sig_pow(qv, self.p)
        return s1, s2

    # --- the law ---------------------------------------------------------------------------

    def init(self, t0, measurement, reference) -> SixDofAdaptiveState:
        zero = jnp.zeros((), measurement.r.dtype)
        return SixDofAdaptiveState(zero, zero, zero, zero)

    def __call__(self, t, measurement, reference, state: SixDofAdaptiveState):
        y = measurement
        big_r, _ = self.translation_errors(y, reference)
        s1, s2 = self.surfaces(y, reference)
        speed = safe_norm(y.v)
        if self.adaptive:
            bracket = state.m_hat * speed + state.f_hat
        else:
            mu_matrix = -skew(y.omega) + jnp.diag(self.surface.gain(big_r) * jnp.ones(3))
            bracket = spectral_norm(mu_matrix) * self.mass * speed + self.force_bound
        r = self.surface.exponent
        force_n = -self.k3 * s1 - self.k4 * sig_pow(s1, r) - sat(s1, self.boundary) * bracket
        force = quat_to_dcm(y.q) @ force_n
        omega2 = jnp.sum(y.omega**2)
        switch = sign(s2) if self.attitude_boundary is None else sat(s2, self.attitude_boundary)
        torque = -self.sigma * sig_pow(s2, self.p) - switch * (state.c_hat + state.k_hat * omega2)
        n1, n2 = safe_norm(s1), safe_norm(s2)
        if not self.adaptive:
            m_dot = f_dot = jnp.zeros_like(n1)
        elif self.literal:
            m_dot, f_dot = n1 - self.zeta0 * state.m_hat, n1 * speed - self.zeta1 * state.f_hat
        else:
            m_dot, f_dot = n1 * speed - self.zeta0 * state.m_hat, n1 - self.zeta1 * state.f_hat
        state_dot = SixDofAdaptiveState(
            m_dot,
            f_dot,
            self.p0 * (n2 - self.eps0 * state.c_hat),
            self.p1 * (n2 * omega2 - self.eps1 * state.k_hat),
        )
        return jnp.concatenate([force, torque]), state_dot

    def signals(self, t, measurement, reference, state) -> dict[str, Array]:
        s1, s2 = self.surfaces(measurement, reference)
        return {
            "s_translation": s1,
            "s_attitude": s2,
            "m_hat": state.m_hat,
            "f_hat": state.f_hat,
            "c_hat": state.c_hat,
            "k_hat": state.k_hat,
        }
