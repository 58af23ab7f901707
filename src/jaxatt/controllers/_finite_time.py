r"""Homogeneous finite-time MRP attitude laws, with and without an angular-velocity barrier.

Yu, Cheng, Jin, Du (2022), SPEC seed 004. Both laws act on the MRP error $e$ (the MRP of
$q_d^{-1}\otimes q$; equal to $\sigma$ for the identity reference, taken literally, without
shadow switching) and the rate error $v = \omega - R(e)\omega_d$, $R(e) = C(e)$ mapping
desired-frame to body components:

- FT, eq. (23) (Su & Zheng 2014): $\tau = -k_1 G^T(e)\,\mathrm{sig}^{\alpha_1}(e)
  - k_2\,\mathrm{sig}^{\alpha_2}(v)$;
- FTAC, eq. (6): the rate gain becomes $k_2 M^{1+\alpha_2}/|M^{1+\alpha_2} - \chi(v)|$ with
  $\chi(v) = \sum_i |v_i|^{1+\alpha_2}$, which keeps $\chi(v) < M^{1+\alpha_2}$, hence
  $|v_i| < M$, for all time.

The exponent $\alpha_2 = 2\alpha_1/(1+\alpha_1)$ is derived from $\alpha_1$, never given:
the nominal closed loop $\dot\sigma = \omega/4$, $J\dot\omega = -\tfrac{k_1}{4}
\mathrm{sig}^{\alpha_1}(\sigma) - k_2\mathrm{sig}^{\alpha_2}(\omega)$ is homogeneous of degree
$(\alpha_1 - 1)/2 < 0$ with weights $(1, (1+\alpha_1)/2)$ exactly for this $\alpha_2$ (SPEC
004.2 [V]), which is what makes the convergence finite-time.

**Tracking (Remark 3, eqs. 36-38).** With `inertia` given, the laws add the feed-forward of
eq. (38) with the corrected sign (SPEC 004.3 [E][V]: $\dot R = -v^\times R$ gives
$J\dot v = -\omega^\times J\omega + \tau - JR\dot\omega_d + Jv^\times R\omega_d + d$):

$$\tau_{\mathrm{ff}} = \omega^\times J\omega - v^\times J v + JR\dot\omega_d
- Jv^\times R\omega_d,$$

so that the error dynamics are $\dot e = G(e)v$, $J\dot v = -v^\times Jv - k_1 G^T(e)
\mathrm{sig}^{\alpha_1}(e) - (\text{rate term}) + d$: eq. (7) with $(\sigma, \omega) \to (e, v)$,
and Theorem 1 bounds the *rate error* $|v_i| < M$. For a constant reference
($\omega_d = 0$, $v = \omega$) the feed-forward is exactly zero, so stabilization is the special
case and `inertia` may be omitted.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._constants import is_known_zero
from .._custom_types import MRP, Mat33, RealScalarLike, Scalar, Vec3
from .._validation import (
    check_flag,
    check_gain_shape,
    check_in_open_interval,
    check_positive,
    check_spd,
)
from ..numerics import abs_pow, maximum, sig_pow
from ..plants import MRPState
from ..references import AttitudeReference
from ..rotations import attitude_error_mrp, mrp_from_quat, mrp_kinematics_matrix, mrp_to_dcm
from ._base import AbstractController


def homogeneous_exponent(alpha1: Float[ArrayLike, "..."]) -> Float[Array, "..."]:
    r"""$\alpha_2 = 2\alpha_1/(1+\alpha_1)$, the rate exponent that makes the nominal closed
    loop homogeneous of negative degree (Yu et al. 2022, Theorem 1). In $(0, 1)$ for
    $\alpha_1 \in (0, 1)$; smooth in $\alpha_1$."""
    alpha1 = jnp.asarray(alpha1)
    return 2 * alpha1 / (1 + alpha1)


class _Errors(eqx.Module):
    e: MRP
    v: Vec3
    desired_rate: Vec3 | None  # R(e) omega_d, body components; None: known zero
    desired_acceleration: Vec3 | None  # R(e) omega_d_dot; None: known zero


def _errors(measurement: MRPState, reference: AttitudeReference) -> _Errors:
    e = attitude_error_mrp(measurement.sigma, mrp_from_quat(reference.q_d))
    if is_known_zero(reference.omega_d) and is_known_zero(reference.omega_d_dot):
        # A reference at rest known when the program is traced (ConstantAttitude): R(e) 0 = 0
        # and v = omega exactly; nothing to rotate (benchmarks/README.md, "Zero reference
        # rates known when the program is traced").
        dtype = jnp.result_type(measurement.omega, e, reference.omega_d)
        return _Errors(e, jnp.asarray(measurement.omega, dtype), None, None)
    dcm = mrp_to_dcm(e)
    desired_rate = dcm @ reference.omega_d
    return _Errors(
        e=e,
        v=measurement.omega - desired_rate,
        desired_rate=desired_rate,
        desired_acceleration=dcm @ reference.omega_d_dot,
    )


def _attitude_term(k1: Array, alpha1: Array, e: MRP) -> Vec3:
    """$k_1 G^T(e)\\,\\mathrm{sig}^{\\alpha_1}(e)$."""
    return k1 * (mrp_kinematics_matrix(e).T @ sig_pow(e, alpha1))


def _feedforward(inertia: Mat33 | None, omega: Vec3, errors: _Errors) -> Vec3:
    """Eq. (38)'s feed-forward with the corrected sign of $Jv^\\times R\\omega_d$ (or 0)."""
    if inertia is None:
        return jnp.zeros_like(errors.v)
    v = errors.v
    gyroscopic = jnp.cross(omega, inertia @ omega) - jnp.cross(v, inertia @ v)
    if errors.desired_rate is None:  # at rest: both reference terms are exactly zero
        return gyroscopic
    return (
        gyroscopic
        + inertia @ errors.desired_acceleration
        - inertia @ jnp.cross(v, errors.desired_rate)
    )


def _check_inertia(where: str, inertia) -> Mat33 | None:
    return None if inertia is None else check_spd(where, "inertia", inertia)


def _check_gain_shape(where: str, name: str, value: Array) -> Array:
    return check_gain_shape(where, name, value)


class FiniteTimeMRP(AbstractController):
    r"""FT, Yu et al. (2022) eq. (23): $\tau = -k_1 G^T(e)\,\mathrm{sig}^{\alpha_1}(e)
    - k_2\,\mathrm{sig}^{\alpha_2}(v)$, $\alpha_2 = 2\alpha_1/(1+\alpha_1)$.

    The homogeneous finite-time law of Su & Zheng (2014) on MRPs; the baseline that
    [`RateConstrainedFiniteTimeMRP`][] extends with a rate barrier. With `inertia` it adds the
    tracking feed-forward of eq. (38) (module docstring).

    **Arguments:**
    - `k1`: attitude gain $k_1 > 0$, scalar or per axis [N m].
    - `k2`: rate gain $k_2 > 0$, scalar or per axis [N m (s/rad)^alpha2].
    - `alpha1`: $\alpha_1 \in (0, 1)$; $\alpha_2$ is derived ([`homogeneous_exponent`][]).
    - `inertia`: $J$ for the tracking feed-forward (3, 3) [kg m^2], or `None` (stabilization
      or a constant reference, where the feed-forward vanishes).

    **Gradients:** finite everywhere, also at $e = 0$ and $v = 0$, where
    [`jaxatt.numerics.sig_pow`][] caps the slope of $|x|^{a}$, $a < 1$, at
    $a\sqrt{\varepsilon}^{\,a-1}$.

    !!! cite
        Yu, Cheng, Jin, Du, Control and Decision 37(12):3314-3320, 2022, Remark 1, eq. (23).
    """

    k1: Float[Array, "*k"]
    k2: Float[Array, "*k"]
    alpha1: Float[Array, ""]
    inertia: Mat33 | None
    measurement_type: ClassVar[type] = MRPState
    reference_type: ClassVar[type] = AttitudeReference

    def __init__(
        self,
        k1: Float[ArrayLike, "*k"],
        k2: Float[ArrayLike, "*k"],
        alpha1: RealScalarLike,
        *,
        inertia: Float[ArrayLike, "3 3"] | None = None,
    ):
        where = "FiniteTimeMRP"
        self.k1 = _check_gain_shape(where, "k1", check_positive(where, "k1", k1))
        self.k2 = _check_gain_shape(where, "k2", check_positive(where, "k2", k2))
        self.alpha1 = check_in_open_interval(where, "alpha1", alpha1, 0.0, 1.0)
        if self.alpha1.shape != ():
            raise ValueError(f"{where}: `alpha1` must be a scalar, got shape {self.alpha1.shape}.")
        self.inertia = _check_inertia(where, inertia)

    @property
    def alpha2(self) -> Float[Array, ""]:
        """$\\alpha_2 = 2\\alpha_1/(1+\\alpha_1)$."""
        return homogeneous_exponent(self.alpha1)

    def init(self, t0: RealScalarLike, measurement: MRPState, reference) -> None:
        del t0, measurement, reference
        return None

    def __call__(
        self, t: RealScalarLike, measurement: MRPState, reference: AttitudeReference, state: None
    ) -> tuple[Vec3, None]:
        del t, state
        errors = _errors(measurement, reference)
        tau = (
            -_attitude_term(self.k1, self.alpha1, errors.e)
            - self.k2 * sig_pow(errors.v, self.alpha2)
            + _feedforward(self.inertia, measurement.omega, errors)
        )
        return tau, None


class RateBarrierState(eqx.Module):
    """`time_inside`: time [s] spent so far with $\\chi(v) < M^{1+\\alpha_2}$ (inside the
    barrier set). It separates an accepted inadmissible start (see
    `allow_inadmissible`) from a later crossing."""

    time_inside: Scalar


class RateConstrainedFiniteTimeMRP(AbstractController):
    r"""FTAC, Yu et al. (2022) eq. (6): finite-time MRP control with an angular-velocity barrier.

    $$\tau = -k_1 G^T(e)\,\mathrm{sig}^{\alpha_1}(e)
    - \frac{k_2 M^{1+\alpha_2}}{\max\left(|M^{1+\alpha_2} - \chi(v)|,\;
      g M^{1+\alpha_2}\right)}\,\mathrm{sig}^{\alpha_2}(v),\qquad
    \chi(v) = \sum_i |v_i|^{1+\alpha_2},$$

    $\alpha_2 = 2\alpha_1/(1+\alpha_1)$, and $g$ the `guard` (below). With `inertia` it adds
    the tracking feed-forward of eq. (38) (module docstring); eq. (29)'s $-\hat d$ comes from
    wrapping it in [`ObserverCompensated`][].

    **Admissible set.** Theorem 1 claims $|v_i(t)| < M$ whenever $|v_i(0)| < M$, but its
    proof ((16)-(22)) shows $\chi(v(t)) < M^{1+\alpha_2}$ *provided*
    $\chi(v(0)) < M^{1+\alpha_2}$, and $|v_i(0)| < M$ does not imply that (e.g.
    $v = (0.39, 0.39, 0.39)$, $M = 0.4$; the paper's own $\omega(0) = (-0.21, -0.23, -0.25)$
    has $\chi = 0.2598 > 0.4^{5/3} = 0.2172$, SPEC 004.2). The admissible set is therefore
    $\chi(v(0)) < M^{1+\alpha_2}$ (any attitude), and $|v_i| < M$ follows from it.

    - [`check_initial`][] checks it: `simulate` calls it on the concrete initial state
      before compiling anything, and an inadmissible state raises `ValueError` (stating the
      rule, the barrier values and the opt-out) unless `allow_inadmissible=True`. Inside a
      batch (`monte_carlo`, or your own `vmap`) nothing is raised, so a Monte Carlo study is
      never aborted: the sample's status is `constraint_violated`, detected at its first
      completed step.
    - [`admissible`][] (checked after every completed step) is $\chi(v) < M^{1+\alpha_2}$.
      With `allow_inadmissible=True` the initial excursion of a state that starts outside is
      accepted and only a crossing after the state has been inside
      (`RateBarrierState.time_inside > 0`) counts as a violation.
    - Recorded signals: `"barrier_ratio"` $\chi(v)/M^{1+\alpha_2}$ (< 1 inside) and
      `"barrier_gain"`, the factor multiplying $k_2$.

    **Guard and step size.** The gain is singular on $\chi = M^{1+\alpha_2}$. Its denominator
    is floored at $g M^{1+\alpha_2}$ (so the factor never exceeds $1/g$ and nothing becomes
    inf or NaN); inside the set the law is exact wherever $\chi < (1 - g)M^{1+\alpha_2}$. At a
    relative gap $\delta = 1 - \chi/M^{1+\alpha_2}$ the barrier term changes $v_i$ at the rate
    $\approx k_2|v_i|^{\alpha_2}/(J_{ii}\delta)$, away from the boundary. A fixed step that is
    too long overshoots through $v = 0$ and out across the opposite side of the barrier; one
    step stays monotone while
    $$dt \lesssim \frac{J_{\min}\,\delta\,|v_i|^{1-\alpha_2}}{k_2}.$$
    For the paper ($k_2 = 0.01$, $J_{\min} = 0.01175$, $M = 0.4$, $\alpha_1 = 0.5$) this is
    $dt \lesssim 0.87\,\delta$ s for a rate on one axis: measured with RK4 (guard 1e-6),
    starts at $\delta = 10^{-3}$ stay inside at dt = 1e-3 s and cross at 2e-3 s, and starts
    at $\delta = 10^{-4}$ need dt = 1e-4 s. Away from the boundary ($\delta \ge 0.03$)
    dt = 1e-2 s works. Since the barrier pushes $\chi$ down, $\delta(0)$ is what matters. A
    state that starts outside crosses the singular surface (the singularity is integrable)
    with a torque spike whose size depends on the step and on $g$ (the paper's state: 0.2 to
    0.96 N m for dt from 1e-4 to 2e-3 s, against 0.015 N m afterwards).

    **Arguments:**
    - `k1`, `k2`, `alpha1`, `inertia`: as [`FiniteTimeMRP`][].
    - `rate_limit`: $M > 0$ [rad/s].
    - `guard`: $g \in (0, 1)$, the relative floor of the barrier denominator (default 1e-3).
    - `allow_inadmissible`: accept initial states outside the admissible set (static).

    **Gradients:** finite everywhere (also in $k_1, k_2, \alpha_1, M$): $|v_i|^{1+\alpha_2}$
    and $\mathrm{sig}^{a}$ go through [`jaxatt.numerics.abs_pow`][] /
    [`jaxatt.numerics.sig_pow`][]; where the guard binds the gain's derivative with respect to
    $\chi$ is 0.

    !!! cite
        Yu, Cheng, Jin, Du, Control and Decision 37(12):3314-3320, 2022, Theorem 1, eq. (6).
    """

    k1: Float[Array, "*k"]
    k2: Float[Array, "*k"]
    alpha1: Float[Array, ""]
    rate_limit: Float[Array, ""]
    guard: Float[Array, ""]
    inertia: Mat33 | None
    allow_inadmissible: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = MRPState
    reference_type: ClassVar[type] = AttitudeReference

    def __init__(
        self,
        k1: Float[ArrayLike, "*k"],
        k2: Float[ArrayLike, "*k"],
        alpha1: RealScalarLike,
        rate_limit: RealScalarLike,
        *,
        inertia: Float[ArrayLike, "3 3"] | None = None,
        guard: RealScalarLike = 1e-3,
        allow_inadmissible: bool = False,
    ):
        where = "RateConstrainedFiniteTimeMRP"
        self.k1 = _check_gain_shape(where, "k1", check_positive(where, "k1", k1))
        self.k2 = _check_gain_shape(where, "k2", check_positive(where, "k2", k2))
        self.alpha1 = check_in_open_interval(where, "alpha1", alpha1, 0.0, 1.0)
        self.rate_limit = check_positive(where, "rate_limit", rate_limit)
        self.guard = check_in_open_interval(where, "guard", guard, 0.0, 1.0)
        for name in ("alpha1", "rate_limit", "guard"):
            if getattr(self, name).shape != ():
                raise ValueError(f"{where}: `{name}` must be a scalar.")
        self.inertia = _check_inertia(where, inertia)
        self.allow_inadmissible = check_flag(
            "RateConstrainedFiniteTimeMRP", "allow_inadmissible", allow_inadmissible
        )

    @property
    def alpha2(self) -> Float[Array, ""]:
        """$\\alpha_2 = 2\\alpha_1/(1+\\alpha_1)$."""
        return homogeneous_exponent(self.alpha1)

    @property
    def barrier_level(self) -> Float[Array, ""]:
        """$M^{1+\\alpha_2}$ [(rad/s)^(1+alpha2)]."""
        return self.rate_limit ** (1 + self.alpha2)

    def chi(self, v: Vec3) -> Scalar:
        """$\\chi(v) = \\sum_i |v_i|^{1+\\alpha_2}$ (the barrier function as printed)."""
        return jnp.sum(abs_pow(v, 1 + self.alpha2))

    def barrier_ratio(self, v: Vec3) -> Scalar:
        """$\\chi(v)/M^{1+\\alpha_2}$: below 1 exactly inside the admissible set."""
        return self.chi(v) / self.barrier_level

    def barrier_gain(self, v: Vec3) -> Scalar:
        """$M^{1+\\alpha_2}/\\max(|M^{1+\\alpha_2} - \\chi(v)|, g M^{1+\\alpha_2})$, the factor
        multiplying $k_2$ (1 at $v = 0$, at most $1/g$)."""
        return self._gain(self.chi(v), self.barrier_level)

    def _gain(self, chi: Scalar, level: Scalar) -> Scalar:
        """[`barrier_gain`][] from $\\chi(v)$ and $M^{1+\\alpha_2}$."""
        return level / maximum(jnp.abs(level - chi), self.guard * level)

    def inside_barrier(
        self, measurement: MRPState, reference: AttitudeReference
    ) -> Bool[Array, ""]:
        """Whether `measurement` lies in the admissible set $\\chi(v) < M^{1+\\alpha_2}$."""
        return self.barrier_ratio(_errors(measurement, reference).v) < 1

    def init(
        self, t0: RealScalarLike, measurement: MRPState, reference: AttitudeReference
    ) -> RateBarrierState:
        """`time_inside` starts at 0 (admissibility is checked by [`check_initial`][])."""
        del t0
        v = _errors(measurement, reference).v
        return RateBarrierState(time_inside=jnp.zeros((), dtype=jnp.result_type(v)))

    def check_initial(self, t0: float, measurement: MRPState, reference: AttitudeReference) -> None:
        """Raise `ValueError` if the concrete initial state is outside the admissible set
        (and `allow_inadmissible` is False), with the barrier values and the opt-out."""
        del t0
        if self.allow_inadmissible:
            return
        v, chi, level = (np.asarray(x) for x in _initial_barrier(self, measurement, reference))
        if chi < level:
            return
        raise ValueError(
            "RateConstrainedFiniteTimeMRP: the initial rate error v(0) = "
            f"{np.array2string(v, precision=6, separator=', ')} rad/s is outside "
            "the admissible set that Theorem 1's proof needs, chi(v) = sum_i "
            "|v_i|^(1+alpha2) < M^(1+alpha2): got chi(v(0)) = "
            f"{float(chi):.6g} >= M^(1+alpha2) = {float(level):.6g} (barrier ratio "
            f"{float(chi / level):.6g}; M = {float(self.rate_limit):.6g}, alpha2 = "
            f"{float(self.alpha2):.6g}). |v_i(0)| < M alone does not suffice. Start with a "
            "smaller rate, raise `rate_limit`, or pass allow_inadmissible=True to simulate "
            "anyway (the rate bound is then not guaranteed)."
        )

    def __call__(
        self,
        t: RealScalarLike,
        measurement: MRPState,
        reference: AttitudeReference,
        state: RateBarrierState,
    ) -> tuple[Vec3, RateBarrierState]:
        del t
        errors = _errors(measurement, reference)
        v = errors.v
        chi, level = self.chi(v), self.barrier_level  # each computed once
        tau = (
            -_attitude_term(self.k1, self.alpha1, errors.e)
            - self.k2 * self._gain(chi, level) * sig_pow(v, self.alpha2)
            + _feedforward(self.inertia, measurement.omega, errors)
        )
        inside = chi / level < 1  # barrier_ratio(v) < 1
        time_dot = jnp.where(inside, 1.0, 0.0).astype(state.time_inside.dtype)
        return tau, RateBarrierState(time_inside=time_dot)

    def admissible(
        self,
        t: RealScalarLike,
        measurement: MRPState,
        reference: AttitudeReference,
        state: RateBarrierState,
    ) -> Bool[Array, ""]:
        del t
        outside = self.barrier_ratio(_errors(measurement, reference).v) >= 1
        if self.allow_inadmissible:
            return ~(outside & (state.time_inside > 0))
        return ~outside

    def signals(
        self,
        t: RealScalarLike,
        measurement: MRPState,
        reference: AttitudeReference,
        state: RateBarrierState,
    ) -> dict[str, Array]:
        del t, state
        v = _errors(measurement, reference).v
        return {"barrier_ratio": self.barrier_ratio(v), "barrier_gain": self.barrier_gain(v)}


@eqx.filter_jit
def _initial_barrier(
    law: RateConstrainedFiniteTimeMRP, measurement: MRPState, reference: AttitudeReference
) -> tuple[Vec3, Scalar, Scalar]:
    v = _errors(measurement, reference).v
    return v, law.chi(v), law.barrier_level
