r"""The quaternion attitude-tracking error model shared by tracking controllers.

Chen et al. (2022) eqs. (7)-(13) with the corrections of SPEC 000.1 (E3):

$$\dot e_\omega = F + J_0^{-1}u + D,\qquad
F = -J_0^{-1}\omega^\times J_0\omega + e_\omega^\times C\omega_d - C\dot\omega_d,$$

where $e = q_d^{-1}\otimes q$, $C = C(e)$ maps desired-frame to body components and
$e_\omega = \omega - C\omega_d$. $D$ lumps inertia uncertainty and disturbance; controllers
know only the nominal inertia $J_0$.
"""

import equinox as eqx
import jax.numpy as jnp

from .._custom_types import Mat33, Quaternion, Vec3
from ..numerics import solve3
from ..plants import QuaternionState
from ..references import AttitudeReference
from ..rotations import attitude_error_quat, quat_to_dcm


class TrackingErrors(eqx.Module):
    """Error quaternion `e`, rate error `e_omega`, `dcm` = C(e), and the known drift `F`."""

    e: Quaternion
    e_omega: Vec3
    dcm: Mat33
    drift: Vec3


def tracking_errors(
    measurement: QuaternionState, reference: AttitudeReference, inertia: Mat33
) -> TrackingErrors:
    """Errors and the nominal drift $F$ of the error dynamics (see the module docstring)."""
    e = attitude_error_quat(measurement.q, reference.q_d)
    dcm = quat_to_dcm(e)
    omega = measurement.omega
    desired_rate = dcm @ reference.omega_d
    e_omega = omega - desired_rate
    gyroscopic = solve3(inertia, -jnp.cross(omega, inertia @ omega))
    drift = gyroscopic + jnp.cross(e_omega, desired_rate) - dcm @ reference.omega_d_dot
    return TrackingErrors(e=e, e_omega=e_omega, dcm=dcm, drift=drift)
