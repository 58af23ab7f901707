r"""Tracking errors between the body attitude and a desired attitude (SPEC seed 000 eqs. 7-10).

The error is the attitude of the body frame B relative to the desired frame D,
$e = q_d^{-1} \otimes q$ (so $q = q_d \otimes e$), and its attitude matrix
$C(e) = C_{BD} = C_{BN} C_{DN}^\top$ maps desired-frame components to body components.

**Zero reference rates.** When the desired rate is a NumPy constant zero (what
[`jaxatt.references.ConstantAttitude`][] gives), the rate errors return the body rate, in the
dtype the formula would give: $\omega - C\,0 = \omega$, the formula's value (up to the sign
of a zero, and inf where the formula would give NaN for an infinite $C$), with no arithmetic
emitted. XLA cannot drop the product itself: it keeps $x \cdot 0$, which is NaN for an
infinite $x$.
"""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._constants import is_known_zero
from ._mrp import mrp_compose, mrp_to_dcm
from ._quaternion import quat_conjugate, quat_multiply, quat_to_dcm


def _unchanged(x, other) -> Array:
    """`x`, in the dtype that combining it with `other` gives."""
    return jnp.asarray(x, jnp.result_type(x, other))


def attitude_error_quat(q: Float[ArrayLike, "4"], q_d: Float[ArrayLike, "4"]) -> Float[Array, "4"]:
    r"""Error quaternion $e = q_d^{-1} \otimes q = q_d^* \otimes q$ for unit quaternions.

    Component-wise (SPEC seed 000 eqs. 7-8):
    $e_0 = q_{dv}^\top q_v + q_0 q_{d0}$,
    $e_v = q_{d0} q_v - [q_{dv}\times] q_v - q_0 q_{dv}$.

    The conjugate stands for the inverse, so `q_d` must be a unit quaternion (for other
    norms the result is scaled by $\|q_d\|^2$). No canonicalization: $e_0 < 0$ when `q`
    and `q_d` lie in opposite hemispheres; a controller that wants the short way round
    applies [`quat_canonical`][] (or uses $\mathrm{sign}(e_0)$) itself.

    **Arguments:**
    - `q`: attitude of the body frame relative to the inertial frame.
    - `q_d`: desired attitude relative to the inertial frame.

    **Returns:** the attitude of the body frame relative to the desired frame.
    """
    return quat_multiply(quat_conjugate(q_d), q)


def rate_error(
    e: Float[ArrayLike, "4"], omega: Float[ArrayLike, "3"], omega_d: Float[ArrayLike, "3"]
) -> Float[Array, "3"]:
    r"""Body-rate tracking error $e_\omega = \omega - C(e)\,\omega_d$ (SPEC seed 000 eqs. 9-10).

    $C(e) = (1 - 2 e_v^\top e_v) I_3 + 2 e_v e_v^\top - 2 e_0 [e_v\times]$ is
    `quat_to_dcm(e)`, the map from desired-frame to body-frame components, so $e_\omega$ is the
    rate of the body relative to the desired frame, in body components; along the motion
    $\dot e = \tfrac12 E(e)\, e_\omega$ (eqs. 11-12).

    **Arguments:**
    - `e`: error quaternion from [`attitude_error_quat`][].
    - `omega`: body rate in body components [rad/s].
    - `omega_d`: desired rate in desired-frame components [rad/s].
    """
    if is_known_zero(omega_d):
        return _unchanged(omega, jnp.result_type(e, omega_d))
    return jnp.asarray(omega) - quat_to_dcm(e) @ jnp.asarray(omega_d)


def attitude_error_mrp(
    sigma: Float[ArrayLike, "3"], sigma_d: Float[ArrayLike, "3"]
) -> Float[Array, "3"]:
    r"""MRP error $\sigma_e$ of the body relative to the desired frame: $C(\sigma_e) = C_{BD}$.

    The MRP of the same relative rotation as [`attitude_error_quat`][]:
    $C(\sigma_e) = C(\sigma)\,C(\sigma_d)^\top$. Schaub's MRP subtraction formula, i.e.
    [`mrp_compose`][]`(-sigma_d, sigma)`:

    $$\sigma_e = \frac{(1 - \|\sigma_d\|^2)\,\sigma - (1 - \|\sigma\|^2)\,\sigma_d
    + 2\,\sigma \times \sigma_d}{1 + \|\sigma_d\|^2\|\sigma\|^2 + 2\,\sigma_d^\top\sigma}.$$

    It equals `mrp_from_quat(attitude_error_quat(quat_from_mrp(sigma), quat_from_mrp(sigma_d)))`
    and is literal like that route: $\|\sigma_e\|$ may exceed 1 (apply [`mrp_switch`][] for
    the short rotation). When `sigma` is the shadow set of `sigma_d` (the same attitude, error
    quaternion $[-1, 0, 0, 0]$) the denominator vanishes and the finite shadow set, 0, is
    returned, as documented in [`mrp_compose`][].

    **Arguments:**
    - `sigma`: attitude of the body frame relative to the inertial frame.
    - `sigma_d`: desired attitude relative to the inertial frame.
    """
    return mrp_compose(-jnp.asarray(sigma_d), sigma)


def rate_error_mrp(
    sigma_e: Float[ArrayLike, "3"], omega: Float[ArrayLike, "3"], omega_d: Float[ArrayLike, "3"]
) -> Float[Array, "3"]:
    r"""Body-rate tracking error $\omega - C(\sigma_e)\,\omega_d$ for an MRP error.

    Same as [`rate_error`][] with $C(\sigma_e)$ = `mrp_to_dcm(sigma_e)` (desired frame to body
    frame); along the motion $\dot\sigma_e = G(\sigma_e)(\omega - C(\sigma_e)\omega_d)$.
    """
    if is_known_zero(omega_d):
        return _unchanged(omega, jnp.result_type(sigma_e, omega_d))
    return jnp.asarray(omega) - mrp_to_dcm(sigma_e) @ jnp.asarray(omega_d)
