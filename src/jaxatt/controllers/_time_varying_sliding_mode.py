r"""Time-varying sliding-mode attitude control with adaptive $k(t)$ and $p^2(t)$.

Shi & Song (2024) eqs. (21)-(27), with the corrections of SPEC seed 002(b). With the error
quaternion $q_e = q_c^{-1}\otimes q = (q_{e0}, \mathbf q)$ and the body rate $\omega$:

$$s = \omega + k(t)\,\mathbf q\quad(21),\qquad
\tau = -k_p\tau_{\max}\mathbf q - (1 - k_p)\tau_{\max}\tanh(s/p^2)\quad(26),$$
$$\dot k = -\gamma_k(1 - k_p)\tau_{\max}\,\mathbf q^T\big[\tanh(s/p^2) + \tanh(k\mathbf q/p^2)\big]
- \gamma_k\gamma_c k(\mathbf q^T\mathbf q + \gamma_d)\quad(22),$$
$$\frac{d}{dt}p^2 = -6\gamma_p\bar\alpha(1 - k_p)\tau_{\max}p^2
+ \gamma_p\gamma_c k^2(\mathbf q^T\mathbf q + \gamma_d)\quad(23),$$

($\tanh$ elementwise; (25) as printed drops $\tau_{\max}$ and writes $\alpha$ for $\bar\alpha$).
The paper's law (26) also subtracts the observer's $\hat T_d$: compose with
[`jaxatt.controllers.ObserverCompensated`][] and an observer (e.g.
[`jaxatt.observers.IntegralSlidingModeObserver`][]); without it this is the paper's Case 2.

**Lyapunov function (27)** $V_2 = \tfrac12\omega^TJ\omega + 2k_p\tau_{\max}(1 - q_{e0})
+ k^2/(2\gamma_k) + p^2/\gamma_p$ ([`TimeVaryingSlidingMode.lyapunov`][]). Along the closed loop
(for a constant command) $\dot V_2 = s^T[\tilde T - (1 - k_p)\tau_{\max}\tanh(s/p^2)]
- k\mathbf q^T[\tilde T + (1 - k_p)\tau_{\max}\tanh(k\mathbf q/p^2)]
- 6\bar\alpha(1 - k_p)\tau_{\max}p^2$, with $\tilde T$ the uncompensated torque. The proof
bounds $|x| - x\tanh(x/y) \le \bar\alpha y$ (24, corrected), whose sharp constant is
$\bar\alpha = \max_{u \ge 0}u(1 - \tanh u) = 0.27846$ (at $u = 0.6392$): the paper's
$\bar\alpha = 0.24$ is too small for (29)-(31). Both are available (`alpha_bar`).
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, PyTree

from .._custom_types import RealScalarLike, Vec3
from .._validation import check_in_open_interval, check_positive
from ..plants import QuaternionState
from ..references import AttitudeReference
from ..rotations import attitude_error_quat
from ._base import AbstractController


SHARP_ALPHA_BAR = 0.2784645427610738
"""$\\max_{u\\ge0} u(1 - \\tanh u)$, the smallest $\\bar\\alpha$ for which (24) holds."""
PAPER_ALPHA_BAR = 0.24
"""The value printed in the paper's simulation (too small for (24))."""


class TimeVaryingSlidingModeState(eqx.Module):
    """The adaptive gain `k` and the boundary-layer width `p2` $= p^2$ (scalars)."""

    k: Float[Array, ""]
    p2: Float[Array, ""]


class TimeVaryingSlidingMode(AbstractController):
    r"""The time-varying sliding-mode law (21)-(26) (see the module docstring).

    **Arguments:**
    - `max_torque`: $\tau_{\max} > 0$ [N m] (not printed in the paper; SPEC: 10 N m).
    - `kp`: $k_p \in (0, 1)$, the share of $\tau_{\max}$ on the proportional term.
    - `gamma_k`, `gamma_c`, `gamma_p`, `gamma_d`: positive adaptation constants.
    - `alpha_bar`: $\bar\alpha > 0$ of (23); 0.24 printed, 0.27846 ([`SHARP_ALPHA_BAR`][])
      needed by the proof.
    - `k0`: $k(t_0) > 0$.
    - `p2_0`: $p^2(t_0) > 0$.

    The law reads the body rate $\omega$ in $s$ (SPEC) and the error quaternion's vector part
    against the reference's $q_d$, as printed (no hemisphere switch). Bounded:
    $|\tau_i| \le k_p\tau_{\max}|\mathbf q_i| + (1 - k_p)\tau_{\max} \le \tau_{\max}$ before the
    observer's compensation.

    **Signals:** `s` (3,), `k`, `p2`.
    """

    max_torque: Float[Array, ""]
    kp: Float[Array, ""]
    gamma_k: Float[Array, ""]
    gamma_c: Float[Array, ""]
    gamma_p: Float[Array, ""]
    gamma_d: Float[Array, ""]
    alpha_bar: Float[Array, ""]
    k0: Float[Array, ""]
    p2_0: Float[Array, ""]
    measurement_type: ClassVar[type] = QuaternionState
    reference_type: ClassVar[type] = AttitudeReference

    def __init__(
        self,
        max_torque: float | Float[ArrayLike, ""] = 10.0,
        kp: float | Float[ArrayLike, ""] = 0.4,
        *,
        gamma_k: float | Float[ArrayLike, ""] = 0.005,
        gamma_c: float | Float[ArrayLike, ""] = 1.0,
        gamma_p: float | Float[ArrayLike, ""] = 0.02,
        gamma_d: float | Float[ArrayLike, ""] = 0.08,
        alpha_bar: float | Float[ArrayLike, ""] = PAPER_ALPHA_BAR,
        k0: float | Float[ArrayLike, ""] = 2.0,
        p2_0: float | Float[ArrayLike, ""] = 1.2,
    ):
        where = "TimeVaryingSlidingMode"
        self.max_torque = check_positive(where, "max_torque", max_torque)
        self.kp = check_in_open_interval(where, "kp", kp, 0.0, 1.0)
        self.gamma_k = check_positive(where, "gamma_k", gamma_k)
        self.gamma_c = check_positive(where, "gamma_c", gamma_c)
        self.gamma_p = check_positive(where, "gamma_p", gamma_p)
        self.gamma_d = check_positive(where, "gamma_d", gamma_d)
        self.alpha_bar = check_positive(where, "alpha_bar", alpha_bar)
        self.k0 = check_positive(where, "k0", k0)
        self.p2_0 = check_positive(where, "p2_0", p2_0)
        for name in (
            "max_torque",
            "kp",
            "gamma_k",
            "gamma_c",
            "gamma_p",
            "gamma_d",
            "alpha_bar",
            "k0",
            "p2_0",
        ):
            if getattr(self, name).shape != ():
                raise ValueError(
                    f"{where}: `{name}` must be a scalar, got shape {getattr(self, name).shape}."
                )

    def init(self, t0: RealScalarLike, measurement, reference) -> TimeVaryingSlidingModeState:
        del t0, measurement, reference
        return TimeVaryingSlidingModeState(k=self.k0, p2=self.p2_0)

    def error_vector(self, measurement: PyTree, reference: AttitudeReference) -> Vec3:
        """$\\mathbf q$, the vector part of $q_c^{-1}\\otimes q$."""
        return attitude_error_quat(measurement.q, reference.q_d)[1:]

    def __call__(
        self,
        t: RealScalarLike,
        measurement,
        reference: AttitudeReference,
        state: TimeVaryingSlidingModeState,
    ) -> tuple[Vec3, TimeVaryingSlidingModeState]:
        del t
        q = self.error_vector(measurement, reference)
        k, p2 = state.k, state.p2
        robust = (1 - self.kp) * self.max_torque
        s = measurement.omega + k * q
        tanh_s = jnp.tanh(s / p2)
        tau = -self.kp * self.max_torque * q - robust * tanh_s
        weight = q @ q + self.gamma_d
        k_dot = -self.gamma_k * robust * (q @ (tanh_s + jnp.tanh(k * q / p2))) - (
            self.gamma_k * self.gamma_c * k * weight
        )
        p2_dot = -6 * self.gamma_p * self.alpha_bar * robust * p2 + (
            self.gamma_p * self.gamma_c * k**2 * weight
        )
        return tau, TimeVaryingSlidingModeState(k=k_dot, p2=p2_dot)

    def lyapunov(
        self,
        inertia: Float[ArrayLike, "3 3"],
        q_e: Float[ArrayLike, "4"],
        omega: Float[ArrayLike, "3"],
        state: TimeVaryingSlidingModeState,
    ) -> Float[Array, ""]:
        r"""$V_2$ of (27) for the error quaternion `q_e`, body rate `omega` and `state`."""
        inertia = jnp.asarray(inertia)
        omega = jnp.asarray(omega)
        q_e = jnp.asarray(q_e)
        return (
            0.5 * omega @ inertia @ omega
            + 2 * self.kp * self.max_torque * (1 - q_e[0])
            + state.k**2 / (2 * self.gamma_k)
            + state.p2 / self.gamma_p
        )

    def signals(
        self,
        t: RealScalarLike,
        measurement,
        reference: AttitudeReference,
        state: TimeVaryingSlidingModeState,
    ) -> dict[str, Array]:
        del t
        q = self.error_vector(measurement, reference)
        return {"s": measurement.omega + state.k * q, "k": state.k, "p2": state.p2}
