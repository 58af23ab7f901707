r"""Adaptive sliding-mode attitude tracking with a tanh switching term (SPEC 001(f)) [R].

SPEC 001(f) has only two abstracts (Li et al. 2015: quaternion tracking, an adaptive estimate of
the disturbance, tanh instead of sign; Wang et al. 2010: the same with MRPs). The law is the
generic reconstruction SPEC gives for both. With the attitude error $\sigma_e$ (the error
quaternion's vector part $e_v$, or the MRP error), $R = C(\sigma_e)$ the map from desired-frame
to body components and $\omega_e = \omega - R\omega_d$:

$$s = \omega_e + \lambda\sigma_e,$$
$$u = \omega^\times J_0\omega + J_0\big(R\dot\omega_d - \omega_e^\times R\omega_d
- \lambda\dot\sigma_e\big) - K s - \hat d\,\varphi(s),\qquad
\dot{\hat d} = \gamma\big(s^T\varphi(s) - \nu\hat d\big),$$

with $\varphi(s) = \tanh(s/\epsilon)$ elementwise (the switching object `Tanh(eps)`; `Sign()`
gives the discontinuous law for comparison) and $\dot\sigma_e = \tfrac12(e_0 I + e_v^\times)
\omega_e$ (quaternion) or $G(\sigma_e)\omega_e$ (MRP).

**Why it works.** With $J_0\dot\omega = -\omega^\times J_0\omega + u + d$ and
$\dot R = -\omega_e^\times R$, the law gives $J_0\dot s = -Ks - \hat d\varphi(s) + d$. For
$|d_i| \le D$ and $V = \tfrac12 s^TJ_0s + (\hat d - D)^2/(2\gamma)$,
$\dot V \le -K\|s\|^2 + D(\|s\|_1 - s^T\varphi(s)) - \nu\hat d(\hat d - D)$, and
$|x| - x\tanh(x/\epsilon) \le 0.2785\,\epsilon$, so $s$ and $\hat d$ are uniformly ultimately
bounded, with a bound that shrinks with $\epsilon$ and $\nu$; on $s = 0$ the attitude error
decays like $e^{-\lambda t/2}$ (quaternion, on $e_0 > 0$) or $e^{-\lambda t/4}$ (MRP, near 0).
$\hat d$ never needs the bound $D$; it stays non-negative from $\hat d(t_0) \ge 0$ (since
$s^T\varphi(s) \ge 0$) and, with the leakage $\nu > 0$ ($\sigma$-modification), bounded.
$\nu = 0$ is the pure integral law, whose $\hat d$ only grows.

**[R]** Not the papers' equations (lost): the reconstruction of SPEC, with $\hat d$ a scalar
bound on every component of $d$. The inertia-uncertainty adaptation of Wang (2010) is not
implemented. The quaternion law uses $e_v$ as printed (no hemisphere switch: from $e_0 < 0$ it
unwinds); the MRP law uses the short-rotation error (shadow set when $\|\sigma_e\| > 1$) unless
`short_rotation=False`.
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, PyTree

from .._custom_types import Mat33, RealScalarLike, Scalar, Vec3
from .._validation import check_flag, check_gain_shape, check_nonnegative, check_positive, check_spd
from ..plants import MRPState, QuaternionState
from ..reaching import AbstractSwitching, Tanh
from ..references import AttitudeReference
from ..rotations import (
    attitude_error_mrp,
    attitude_error_quat,
    mrp_from_quat,
    mrp_kinematics,
    mrp_switch,
    mrp_to_dcm,
    quat_kinematics,
    quat_to_dcm,
)
from ._base import AbstractController


class AdaptiveBoundState(eqx.Module):
    """The disturbance-bound estimate `d_hat` $= \\hat d$ [N m] (a scalar)."""

    d_hat: Scalar


class _AttitudeErrors(eqx.Module):
    sigma: Vec3  # e_v or sigma_e
    dcm: Mat33  # R = C(sigma_e), desired frame -> body
    omega_e: Vec3
    sigma_dot: Vec3


class AbstractAdaptiveTanhSlidingMode(AbstractController):
    r"""The adaptive switching-gain sliding-mode law (module docstring); one subclass per
    attitude representation ([`AdaptiveTanhQuaternion`][], [`AdaptiveTanhMRP`][]).

    **Arguments:**
    - `inertia`: the nominal inertia $J_0$ the law knows, SPD (3, 3) [kg m^2].
    - `slope`: $\lambda > 0$ [1/s], scalar or per axis.
    - `gain`: $K > 0$ [N m s/rad], scalar or per axis.
    - `gamma`: adaptation rate $\gamma > 0$ [N m/rad].
    - `leakage`: $\nu \ge 0$ [(rad/s)/(N m)] ($\gamma\nu$ is the decay rate of $\hat d$,
      1/s).
    - `switching`: $\varphi$, a [`jaxatt.reaching.AbstractSwitching`][]; default (`None`)
      `Tanh(0.01)`, $\epsilon = 0.01$ rad/s; `Sign()` is the discontinuous law.
    - `d_hat0`: $\hat d(t_0) \ge 0$ [N m]; default 0.

    **Signals:** `s` (3,) [rad/s] and `d_hat` [N m].
    """

    inertia: eqx.AbstractVar[Mat33]
    slope: eqx.AbstractVar[Float[Array, "*k"]]
    gain: eqx.AbstractVar[Float[Array, "*k"]]
    gamma: eqx.AbstractVar[Float[Array, ""]]
    leakage: eqx.AbstractVar[Float[Array, ""]]
    switching: eqx.AbstractVar[AbstractSwitching]
    d_hat0: eqx.AbstractVar[Float[Array, ""]]
    reference_type: ClassVar[type] = AttitudeReference

    @abc.abstractmethod
    def attitude_errors(self, measurement: PyTree, reference: AttitudeReference) -> _AttitudeErrors:
        """Attitude error vector, $R$, rate error and the error vector's rate."""

    def sliding_variable(self, measurement: PyTree, reference: AttitudeReference) -> Vec3:
        """$s = \\omega_e + \\lambda\\sigma_e$ [rad/s]."""
        errors = self.attitude_errors(measurement, reference)
        return errors.omega_e + self.slope * errors.sigma

    def init(self, t0: RealScalarLike, measurement, reference) -> AdaptiveBoundState:
        del t0, measurement, reference
        return AdaptiveBoundState(self.d_hat0)

    def __call__(
        self,
        t: RealScalarLike,
        measurement,
        reference: AttitudeReference,
        state: AdaptiveBoundState,
    ) -> tuple[Vec3, AdaptiveBoundState]:
        del t
        errors = self.attitude_errors(measurement, reference)
        omega = measurement.omega
        j0 = self.inertia
        s = errors.omega_e + self.slope * errors.sigma
        switch = self.switching(s)
        desired_rate = errors.dcm @ reference.omega_d
        feedforward = jnp.cross(omega, j0 @ omega) + j0 @ (
            errors.dcm @ reference.omega_d_dot
            - jnp.cross(errors.omega_e, desired_rate)
            - self.slope * errors.sigma_dot
        )
        u = feedforward - self.gain * s - state.d_hat * switch
        d_hat_dot = self.gamma * (s @ switch - self.leakage * state.d_hat)
        return u, AdaptiveBoundState(d_hat_dot)

    def signals(
        self, t: RealScalarLike, measurement, reference, state: AdaptiveBoundState
    ) -> dict[str, Array]:
        del t
        return {"s": self.sliding_variable(measurement, reference), "d_hat": state.d_hat}


def _check_common(where: str, inertia, slope, gain, gamma, leakage, switching, d_hat0):
    if switching is None:
        switching = Tanh(0.01)
    if not isinstance(switching, AbstractSwitching):
        raise TypeError(
            f"{where}: `switching` must be a jaxatt.reaching switching (Tanh(eps), Sign(), "
            f"Saturation(width)), got {type(switching).__name__}."
        )
    return (
        check_spd(where, "inertia", inertia),
        check_gain_shape(where, "slope", check_positive(where, "slope", slope)),
        check_gain_shape(where, "gain", check_positive(where, "gain", gain)),
        check_gain_shape(where, "gamma", check_positive(where, "gamma", gamma), ((),)),
        check_gain_shape(where, "leakage", check_nonnegative(where, "leakage", leakage), ((),)),
        switching,
        check_gain_shape(where, "d_hat0", check_nonnegative(where, "d_hat0", d_hat0), ((),)),
    )


class AdaptiveTanhQuaternion(AbstractAdaptiveTanhSlidingMode):
    r"""The law with the error quaternion $e = q_d^{-1}\otimes q$: $\sigma_e = e_v$,
    $\dot\sigma_e = \tfrac12(e_0I + e_v^\times)\omega_e$ (Li et al. 2015 [R]).
    Arguments: see [`AbstractAdaptiveTanhSlidingMode`][]."""

    inertia: Mat33
    slope: Float[Array, "*k"]
    gain: Float[Array, "*k"]
    gamma: Float[Array, ""]
    leakage: Float[Array, ""]
    switching: AbstractSwitching
    d_hat0: Float[Array, ""]
    measurement_type: ClassVar[type] = QuaternionState

    def __init__(
        self,
        inertia: Float[ArrayLike, "3 3"],
        slope: Float[ArrayLike, "*k"],
        gain: Float[ArrayLike, "*k"],
        gamma: RealScalarLike,
        leakage: RealScalarLike,
        switching: AbstractSwitching | None = None,
        d_hat0: RealScalarLike = 0.0,
    ):
        (
            self.inertia,
            self.slope,
            self.gain,
            self.gamma,
            self.leakage,
            self.switching,
            self.d_hat0,
        ) = _check_common(
            "AdaptiveTanhQuaternion", inertia, slope, gain, gamma, leakage, switching, d_hat0
        )

    def attitude_errors(
        self, measurement: QuaternionState, reference: AttitudeReference
    ) -> _AttitudeErrors:
        e = attitude_error_quat(measurement.q, reference.q_d)
        dcm = quat_to_dcm(e)
        omega_e = measurement.omega - dcm @ reference.omega_d
        return _AttitudeErrors(e[1:], dcm, omega_e, quat_kinematics(e, omega_e)[1:])


class AdaptiveTanhMRP(AbstractAdaptiveTanhSlidingMode):
    r"""The law with the MRP error $\sigma_e$ ($C(\sigma_e) = C(\sigma)C(\sigma_d)^T$),
    $\dot\sigma_e = G(\sigma_e)\omega_e$ (Wang et al. 2010 [R]).

    Arguments: see [`AbstractAdaptiveTanhSlidingMode`][], and `short_rotation` (default True):
    use the shadow set of $\sigma_e$ when $\|\sigma_e\| > 1$ (the same attitude, the short way
    round; the kinematics are the same for both sets).
    """

    inertia: Mat33
    slope: Float[Array, "*k"]
    gain: Float[Array, "*k"]
    gamma: Float[Array, ""]
    leakage: Float[Array, ""]
    switching: AbstractSwitching
    d_hat0: Float[Array, ""]
    short_rotation: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = MRPState

    def __init__(
        self,
        inertia: Float[ArrayLike, "3 3"],
        slope: Float[ArrayLike, "*k"],
        gain: Float[ArrayLike, "*k"],
        gamma: RealScalarLike,
        leakage: RealScalarLike,
        switching: AbstractSwitching | None = None,
        d_hat0: RealScalarLike = 0.0,
        *,
        short_rotation: bool = True,
    ):
        (
            self.inertia,
            self.slope,
            self.gain,
            self.gamma,
            self.leakage,
            self.switching,
            self.d_hat0,
        ) = _check_common(
            "AdaptiveTanhMRP", inertia, slope, gain, gamma, leakage, switching, d_hat0
        )
        self.short_rotation = check_flag("AdaptiveTanhMRP", "short_rotation", short_rotation)

    def attitude_errors(
        self, measurement: MRPState, reference: AttitudeReference
    ) -> _AttitudeErrors:
        sigma_e = attitude_error_mrp(measurement.sigma, mrp_from_quat(reference.q_d))
        if self.short_rotation:
            sigma_e = mrp_switch(sigma_e)
        dcm = mrp_to_dcm(sigma_e)
        omega_e = measurement.omega - dcm @ reference.omega_d
        return _AttitudeErrors(sigma_e, dcm, omega_e, mrp_kinematics(sigma_e, omega_e))
