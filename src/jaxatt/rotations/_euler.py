r"""3-2-1 ("aerospace", yaw-pitch-roll) Euler angles.

The angles are ordered as the states of SPEC 001(b), $a = (\phi, \theta, \psi)$ = (roll,
pitch, yaw) [rad]: the body frame B is reached from the inertial frame N by a rotation $\psi$
about $z$, then $\theta$ about the new $y$, then $\phi$ about the new $x$, so

$$C_{BN} = R_1(\phi)\,R_2(\theta)\,R_3(\psi),\qquad
q = q_z(\psi)\otimes q_y(\theta)\otimes q_x(\phi)$$

with the conventions of [`jaxatt.rotations`][] ($R_i$ the frame rotation about axis $i$,
$q_n(\alpha) = [\cos\frac\alpha2, \hat n\sin\frac\alpha2]$). The kinematics
$\dot a = R(\phi, \theta)\,\omega$ (body rates $\omega = (p, q, r)$) are singular at
$\cos\theta = 0$ (gimbal lock); each function says what it does there.
"""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from ..numerics import safe_norm, vectorized_sincos
from ._quaternion import quat_from_axis_angle, quat_multiply


def euler321_to_dcm(angles: Float[ArrayLike, "3"]) -> Float[Array, "3 3"]:
    r"""$C_{BN} = R_1(\phi)R_2(\theta)R_3(\psi)$ of the 3-2-1 angles $(\phi, \theta, \psi)$.

    $$C = \begin{bmatrix} c_\theta c_\psi & c_\theta s_\psi & -s_\theta\\
    s_\phi s_\theta c_\psi - c_\phi s_\psi & s_\phi s_\theta s_\psi + c_\phi c_\psi
    & s_\phi c_\theta\\
    c_\phi s_\theta c_\psi + s_\phi s_\psi & c_\phi s_\theta s_\psi - s_\phi c_\psi
    & c_\phi c_\theta \end{bmatrix}.$$ Defined everywhere (no singularity).
    """
    phi, theta, psi = jnp.asarray(angles)
    sf, cf = vectorized_sincos(phi)
    st, ct = vectorized_sincos(theta)
    sp, cp = vectorized_sincos(psi)
    return jnp.stack(
        [
            jnp.stack([ct * cp, ct * sp, -st]),
            jnp.stack([sf * st * cp - cf * sp, sf * st * sp + cf * cp, sf * ct]),
            jnp.stack([cf * st * cp + sf * sp, cf * st * sp - sf * cp, cf * ct]),
        ]
    )


def euler321_from_dcm(c: Float[ArrayLike, "3 3"]) -> Float[Array, "3"]:
    r"""3-2-1 angles of $C_{BN}$, accurate to rounding for every attitude, gimbal lock included.

    $$\psi = \operatorname{atan2}(C_{12}, C_{11}),\quad
    \theta = \operatorname{atan2}\bigl(-C_{13}, \sqrt{C_{11}^2 + C_{12}^2}\bigr),\quad
    \phi = \operatorname{atan2}(C_{31}s_\psi - C_{32}c_\psi,\; C_{22}c_\psi - C_{21}s_\psi).$$

    Returns $\phi, \psi \in [-\pi, \pi]$, $\theta \in [-\pi/2, \pi/2]$.
    $\theta$ comes from an arctangent, not $-\arcsin C_{13}$, whose error grows like
    $\varepsilon/|\cos\theta|$ near $\theta = \pm\pi/2$. $\phi$ is the roll left once $\psi$
    is undone ($R_1(\phi) = C R_3(\psi)^\top R_2(\theta)^\top$, rows 2 and 3 of column 2),
    not $\operatorname{atan2}(C_{23}, C_{33})$: the two agree away from gimbal lock, but
    only this one keeps $\phi$ consistent with the $\psi$ chosen where both are ill-defined.

    **Gimbal lock** ($|C_{13}| = 1$, $\cos\theta = 0$): only $\phi - \psi$ (at
    $\theta = \pi/2$) or $\phi + \psi$ (at $-\pi/2$) is determined. $\psi$ is then whatever
    $\operatorname{atan2}(C_{12}, C_{11})$ gives on rounding-level entries (0 when they are
    exactly 0), and $\phi$ completes it: `euler321_to_dcm` of the result reproduces `c` to
    rounding everywhere.

    **Gradient:** finite everywhere; at exact gimbal lock with $C_{11} = C_{12} = 0$ the
    derivative of $\psi$ (undefined there) is 0 (double `where`).
    """
    c = jnp.asarray(c)
    c11, c12 = c[0, 0], c[0, 1]
    # Double where: atan2(0, 0) has a 0/0 derivative; only exact gimbal lock reaches it.
    locked = (c11 == 0) & (c12 == 0)
    psi = jnp.where(locked, 0, jnp.arctan2(c12, jnp.where(locked, 1, c11)))
    theta = jnp.arctan2(-c[0, 2], safe_norm(jnp.stack([c11, c12])))
    sp, cp = vectorized_sincos(psi)
    phi = jnp.arctan2(c[2, 0] * sp - c[2, 1] * cp, c[1, 1] * cp - c[1, 0] * sp)
    return jnp.stack([phi, theta, psi])


def euler321_to_quat(angles: Float[ArrayLike, "3"]) -> Float[Array, "4"]:
    r"""$q = q_z(\psi)\otimes q_y(\theta)\otimes q_x(\phi)$, the attitude of B relative to N."""
    phi, theta, psi = jnp.asarray(angles)
    one = jnp.ones((), dtype=jnp.result_type(phi))
    zero = jnp.zeros((), dtype=jnp.result_type(phi))
    qz = quat_from_axis_angle(jnp.stack([zero, zero, one]), psi)
    qy = quat_from_axis_angle(jnp.stack([zero, one, zero]), theta)
    qx = quat_from_axis_angle(jnp.stack([one, zero, zero]), phi)
    return quat_multiply(quat_multiply(qz, qy), qx)


def euler321_kinematics_matrix(
    angles: Float[ArrayLike, "3"], cos_floor: RealScalarLike | None = None
) -> Float[Array, "3 3"]:
    r"""$R(\phi, \theta)$ of $\dot a = R\,\omega$ (SPEC 001(b)):

    $$R = \begin{bmatrix} 1 & s_\phi t_\theta & c_\phi t_\theta\\ 0 & c_\phi & -s_\phi\\
    0 & s_\phi/c_\theta & c_\phi/c_\theta\end{bmatrix}.$$

    Infinite at $\cos\theta = 0$ (gimbal lock). With `cos_floor` $= c_{\min} > 0$,
    $\cos\theta$ is replaced by $\operatorname{sign}(\cos\theta)\max(|\cos\theta|,
    c_{\min})$ (sign +1 at 0), so the matrix stays finite; exact wherever
    $|\cos\theta| \ge c_{\min}$ (used by [`jaxatt.plants.RigidBodyEuler`][], which reports
    the states beyond the floor as invalid).
    """
    phi, theta, _ = jnp.asarray(angles)
    sf, cf = vectorized_sincos(phi)
    st, ct = vectorized_sincos(theta)
    if cos_floor is not None:
        floor = jnp.asarray(cos_floor, dtype=ct.dtype)
        ct = jnp.where(jnp.abs(ct) >= floor, ct, jnp.where(ct < 0, -floor, floor))
    tt = st / ct
    zero = jnp.zeros_like(phi)
    one = jnp.ones_like(phi)
    return jnp.stack(
        [
            jnp.stack([one, sf * tt, cf * tt]),
            jnp.stack([zero, cf, -sf]),
            jnp.stack([zero, sf / ct, cf / ct]),
        ]
    )


def euler321_kinematics(
    angles: Float[ArrayLike, "3"],
    omega: Float[ArrayLike, "3"],
    cos_floor: RealScalarLike | None = None,
) -> Float[Array, "3"]:
    r"""$\dot a = R(\phi, \theta)\,\omega$: $\dot\phi = p + (q s_\phi + r c_\phi)t_\theta$,
    $\dot\theta = q c_\phi - r s_\phi$, $\dot\psi = (q s_\phi + r c_\phi)/c_\theta$ [rad/s].
    Singular at $\cos\theta = 0$; `cos_floor` as in [`euler321_kinematics_matrix`][]."""
    return euler321_kinematics_matrix(angles, cos_floor) @ jnp.asarray(omega)


def euler321_body_rates(
    angles: Float[ArrayLike, "3"], angle_rates: Float[ArrayLike, "3"]
) -> Float[Array, "3"]:
    r"""$\omega = R^{-1}(\phi, \theta)\,\dot a$, the inverse map, defined everywhere:

    $$R^{-1} = \begin{bmatrix} 1 & 0 & -s_\theta\\ 0 & c_\phi & s_\phi c_\theta\\
    0 & -s_\phi & c_\phi c_\theta\end{bmatrix}$$ (rank 2 at $\cos\theta = 0$).
    """
    phi, theta, _ = jnp.asarray(angles)
    d_phi, d_theta, d_psi = jnp.asarray(angle_rates)
    sf, cf = vectorized_sincos(phi)
    st, ct = vectorized_sincos(theta)
    return jnp.stack(
        [d_phi - st * d_psi, cf * d_theta + sf * ct * d_psi, -sf * d_theta + cf * ct * d_psi]
    )
