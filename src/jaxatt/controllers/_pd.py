r"""Proportional-derivative attitude laws (baselines that exercise the closed loop)."""

from typing import ClassVar

from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike, Vec3
from .._validation import check_gain_shape, check_positive
from ..plants import MRPState, QuaternionState
from ..references import AttitudeReference
from ..rotations import (
    attitude_error_mrp,
    attitude_error_quat,
    mrp_from_quat,
    rate_error,
    rate_error_mrp,
)
from ._base import AbstractController


class MRPPD(AbstractController):
    r"""$\tau = -k_1\sigma_e - k_2\omega_e$ on MRP errors.

    $\sigma_e$ is the MRP of $q_d^{-1}\otimes q$ and $\omega_e = \omega - C(\sigma_e)\omega_d$;
    for a constant identity reference this is Yu et al. (2022)'s PD baseline
    $\tau = -k_1\sigma - k_2\omega$ (SPEC 004.4, form reconstructed [R]).

    **Arguments:**
    - `k1`: attitude gain, positive scalar or per-axis (3,) [N m].
    - `k2`: rate gain, positive scalar or per-axis (3,) [N m s].

    No feed-forward: tracking a moving reference leaves a rate-dependent error.
    """

    k1: Float[Array, "*k"]
    k2: Float[Array, "*k"]
    measurement_type: ClassVar[type] = MRPState
    reference_type: ClassVar[type] = AttitudeReference

    def __init__(self, k1: Float[ArrayLike, "*k"], k2: Float[ArrayLike, "*k"]):
        self.k1 = check_gain_shape("MRPPD", "k1", check_positive("MRPPD", "k1", k1))
        self.k2 = check_gain_shape("MRPPD", "k2", check_positive("MRPPD", "k2", k2))

    def init(self, t0: RealScalarLike, measurement: MRPState, reference) -> None:
        del t0, reference
        return None

    def __call__(
        self, t: RealScalarLike, measurement: MRPState, reference: AttitudeReference, state: None
    ) -> tuple[Vec3, None]:
        del t, state
        sigma_e = attitude_error_mrp(measurement.sigma, mrp_from_quat(reference.q_d))
        omega_e = rate_error_mrp(sigma_e, measurement.omega, reference.omega_d)
        return -self.k1 * sigma_e - self.k2 * omega_e, None


class QuaternionPD(AbstractController):
    r"""$u = -k_p e_v - k_d e_\omega$ on the error quaternion $e = q_d^{-1}\otimes q$.

    $e_\omega = \omega - C(e)\omega_d$. The law regulates to $e = \pm[1, 0, 0, 0]$ without
    choosing the shorter rotation (no $\mathrm{sign}(e_0)$ factor).

    **Arguments:**
    - `kp`: attitude gain, positive scalar or per-axis (3,) [N m].
    - `kd`: rate gain, positive scalar or per-axis (3,) [N m s].
    """

    kp: Float[Array, "*k"]
    kd: Float[Array, "*k"]
    measurement_type: ClassVar[type] = QuaternionState
    reference_type: ClassVar[type] = AttitudeReference

    def __init__(self, kp: Float[ArrayLike, "*k"], kd: Float[ArrayLike, "*k"]):
        self.kp = check_gain_shape("QuaternionPD", "kp", check_positive("QuaternionPD", "kp", kp))
        self.kd = check_gain_shape("QuaternionPD", "kd", check_positive("QuaternionPD", "kd", kd))

    def init(self, t0: RealScalarLike, measurement: QuaternionState, reference) -> None:
        del t0, reference
        return None

    def __call__(
        self,
        t: RealScalarLike,
        measurement: QuaternionState,
        reference: AttitudeReference,
        state: None,
    ) -> tuple[Vec3, None]:
        del t, state
        e = attitude_error_quat(measurement.q, reference.q_d)
        e_omega = rate_error(e, measurement.omega, reference.omega_d)
        return -self.kp * e[1:] - self.kd * e_omega, None
