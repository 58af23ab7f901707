r"""Relative pose errors of a chaser with respect to a point fixed in a target's body frame."""

from typing import NamedTuple

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..rotations import attitude_error_mrp, mrp_to_dcm


class PoseErrors(NamedTuple):
    r"""Chaser-relative-to-target errors, all in chaser body axes (Zhang et al. 2021 eqs. 1-7).

    - `position` $r_e$ [m], `velocity` $v_e$ [m/s];
    - `attitude` $\sigma_e$ (MRP of the chaser body frame relative to the target body frame);
    - `rate` $\omega_e$ [rad/s];
    - `dcm` $P_e = C(\sigma_e)$, mapping target-body components to chaser-body components.
    """

    position: Float[Array, "3"]
    velocity: Float[Array, "3"]
    attitude: Float[Array, "3"]
    rate: Float[Array, "3"]
    dcm: Float[Array, "3 3"]


def relative_pose_errors(
    chaser_position: Float[ArrayLike, "3"],
    chaser_velocity: Float[ArrayLike, "3"],
    chaser_attitude: Float[ArrayLike, "3"],
    chaser_rate: Float[ArrayLike, "3"],
    target_position: Float[ArrayLike, "3"],
    target_velocity: Float[ArrayLike, "3"],
    target_attitude: Float[ArrayLike, "3"],
    target_rate: Float[ArrayLike, "3"],
    offset: Float[ArrayLike, "3"],
) -> PoseErrors:
    r"""The errors (5)-(7) of Zhang et al. (2021) from the two spacecraft's inertial states.

    Positions [m] and velocities [m/s] are inertial vectors in inertial components; attitudes
    are MRPs relative to the inertial frame; rates [rad/s] are body rates in each body's axes;
    `offset` $p_f$ is the desired chaser position in the target body frame [m]. With
    $C_p = C(\sigma_p)$, $C_t = C(\sigma_t)$, $P_e = C(\sigma_e) = C_p C_t^\top$:

    $$r_d = C_t r_t + p_f,\quad v_d = C_t v_t + \omega_t\times p_f,$$
    $$r_e = C_p r_p - P_e r_d,\quad v_e = C_p v_p - P_e v_d,\quad
    \omega_e = \omega_p - P_e\,\omega_t,$$

    and $\sigma_e$ is the MRP of $P_e$ (eq. 1, never switched to its shadow set).
    """
    c_p = mrp_to_dcm(chaser_attitude)
    c_t = mrp_to_dcm(target_attitude)
    sigma_e = attitude_error_mrp(chaser_attitude, target_attitude)
    p_e = mrp_to_dcm(sigma_e)
    offset = jnp.asarray(offset)
    r_d = c_t @ jnp.asarray(target_position) + offset
    v_d = c_t @ jnp.asarray(target_velocity) + jnp.cross(jnp.asarray(target_rate), offset)
    return PoseErrors(
        position=c_p @ jnp.asarray(chaser_position) - p_e @ r_d,
        velocity=c_p @ jnp.asarray(chaser_velocity) - p_e @ v_d,
        attitude=sigma_e,
        rate=jnp.asarray(chaser_rate) - p_e @ jnp.asarray(target_rate),
        dcm=p_e,
    )
