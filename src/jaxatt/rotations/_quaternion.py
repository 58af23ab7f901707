"""Scalar-first Hamilton unit quaternions: algebra, DCMs, axis-angle and kinematics.

See the [`jaxatt.rotations`][] module docstring for the conventions (frames, DCM direction).

The helpers a closed loop calls at every stage (`quat_multiply`, `quat_rotate`, `quat_to_dcm`,
`quat_from_dcm`, `quat_kinematics`) are `jax.jit` functions: traced once per argument shape,
with their derivative and batching rules cached, where inline code is traced again at each
call site (docs/testing.md, "Where a test's time goes").
"""

import jax
import jax.numpy as jnp
from jax.typing import DTypeLike
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from ..numerics import safe_norm, safe_normalize, sign, vectorized_sincos
from ._skew import skew


@jax.jit
def quat_multiply(p: Float[ArrayLike, "4"], q: Float[ArrayLike, "4"]) -> Float[Array, "4"]:
    r"""Hamilton product $p \otimes q$.

    $$p \otimes q = \begin{bmatrix} p_0 q_0 - p_v^\top q_v \\
    p_0 q_v + q_0 p_v + p_v \times q_v \end{bmatrix}.$$

    **Frame chain:** if `p` is the attitude of frame A relative to N and `q` that of B relative
    to A, then $p \otimes q$ is the attitude of B relative to N, and
    `quat_to_dcm(quat_multiply(p, q)) == quat_to_dcm(q) @ quat_to_dcm(p)`
    ($C_{BN} = C_{BA} C_{AN}$).

    **Arguments:**
    - `p`, `q`: quaternions `[q0, q1, q2, q3]` (any norm; the product of unit quaternions is
      unit).

    **Returns:** the product quaternion.
    """
    p = jnp.asarray(p)
    q = jnp.asarray(q)
    p0, pv = p[0], p[1:]
    q0, qv = q[0], q[1:]
    scalar = p0 * q0 - jnp.dot(pv, qv)
    vector = p0 * qv + q0 * pv + jnp.cross(pv, qv)
    return jnp.concatenate([scalar[None], vector])


def quat_conjugate(q: Float[ArrayLike, "4"]) -> Float[Array, "4"]:
    r"""Conjugate $q^* = [q_0, -q_v]$; the inverse of a unit quaternion."""
    q = jnp.asarray(q)
    return jnp.concatenate([q[:1], -q[1:]])


def quat_inverse(q: Float[ArrayLike, "4"]) -> Float[Array, "4"]:
    r"""Inverse $q^{-1} = q^* / \|q\|^2$, so that $q \otimes q^{-1} = [1, 0, 0, 0]$.

    For unit quaternions this is [`quat_conjugate`][] (prefer that: it is cheaper).

    **Singular point:** the zero quaternion has no inverse; it maps to the zero quaternion,
    with gradient 0 (double `where`), instead of NaN.
    """
    q = jnp.asarray(q)
    norm_sq = jnp.dot(q, q)
    zero = norm_sq == 0  # (not `> 0`: a NaN quaternion must stay NaN)
    return jnp.where(zero, 0, quat_conjugate(q) / jnp.where(zero, 1, norm_sq))


def quat_normalize(q: Float[ArrayLike, "4"]) -> Float[Array, "4"]:
    r"""Unit quaternion $q / \|q\|$.

    **Singular point:** the zero quaternion has no direction; it maps to the zero quaternion
    (not the identity) with gradient 0, through [`jaxatt.numerics.safe_normalize`][]. A zero
    quaternion therefore stays visibly invalid (norm 0) instead of silently becoming a
    rotation.
    """
    return safe_normalize(jnp.asarray(q))


def quat_canonical(q: Float[ArrayLike, "4"]) -> Float[Array, "4"]:
    r"""The representative with $q_0 \ge 0$ of the pair $\{q, -q\}$ (same rotation).

    `q0 == 0` (rotations by exactly pi) is left unchanged, so both signs remain possible there.
    """
    q = jnp.asarray(q)
    return jnp.where(q[0] < 0, -q, q)


def quat_identity(dtype: DTypeLike | None = None) -> Float[Array, "4"]:
    """The identity rotation `[1, 0, 0, 0]` (default dtype: JAX's default float)."""
    return jnp.array([1.0, 0.0, 0.0, 0.0], dtype=dtype)


def quat_from_axis_angle(axis: Float[ArrayLike, "3"], angle: RealScalarLike) -> Float[Array, "4"]:
    r"""Quaternion of a rotation by `angle` about `axis`: $[\cos(\phi/2), \sin(\phi/2)\,\hat n]$.

    The rotation is right-handed: the body frame is the inertial frame turned by $\phi$ about
    $\hat n$ (so [`quat_rotate`][] turns a vector by $+\phi$ about $\hat n$).

    **Arguments:**
    - `axis`: rotation axis, any nonzero finite length, tiny or huge (divided by its largest
      entry, then normalized with [`jaxatt.numerics.safe_normalize`][]). A zero axis gives the
      identity for every angle, with zero gradient with respect to both arguments.
    - `angle`: rotation angle [rad], any real value.

    **Returns:** a unit quaternion in the dtype of `axis`.
    """
    axis = jnp.asarray(axis)
    half = 0.5 * jnp.asarray(angle, dtype=axis.dtype)
    has_axis = jnp.any(axis != 0)
    # Divided by its largest magnitude first: the squared length under- or overflows for
    # lengths below ~1e-154 or above ~1e154 (float64), which made the "unit" axis 0 and the
    # quaternion [cos(phi/2), 0, 0, 0], not a rotation. The direction does not depend on the
    # scale, so the scale is held constant for differentiation: the derivative is exact, with
    # no 1/largest^2 term to overflow.
    largest = jax.lax.stop_gradient(jnp.max(jnp.abs(axis)))
    unit = safe_normalize(axis / jnp.where(has_axis, largest, 1))
    sin_half, cos_half = vectorized_sincos(half)
    q = jnp.concatenate([cos_half[None], sin_half * unit])
    return jnp.where(has_axis, q, quat_identity(axis.dtype))


def quat_to_axis_angle(q: Float[ArrayLike, "4"]) -> tuple[Float[Array, "3"], Float[Array, ""]]:
    r"""Principal axis and angle of a quaternion, with the angle in $[0, \pi]$.

    The canonical representative ($q_0 \ge 0$) is used, so `q` and `-q` give the same result:
    $\phi = 2\,\mathrm{atan2}(\|q_v\|, |q_0|)$ and $\hat n = \pm q_v/\|q_v\|$, the sign that
    of $q_0$ (`+` when $q_0 = 0$).
    The norm of `q` does not matter. `quat_from_axis_angle(*quat_to_axis_angle(q))` equals
    `quat_canonical(quat_normalize(q))`.

    **Singular point:** at the identity the axis is undefined; the zero vector is returned
    (with angle 0), gradients finite (zero through the axis).

    **Returns:** `(axis, angle)`: a unit 3-vector (or zero) and a scalar in $[0, \pi]$ [rad].
    """
    q = quat_canonical(q)
    return safe_normalize(q[1:]), quat_angle(q)


def quat_angle(q: Float[ArrayLike, "4"]) -> Float[Array, ""]:
    r"""Principal rotation angle $\phi = 2\,\mathrm{atan2}(\|q_v\|, |q_0|) \in [0, \pi]$ [rad].

    The same for `q` and `-q` and independent of $\|q\|$. Accurate at small angles (no
    `arccos` of a number close to 1).

    **Gradient:** finite everywhere. At the identity ($q_v = 0$, where $\phi$ has a cone-shaped
    minimum) it is 0, from [`jaxatt.numerics.safe_norm`][]; at $\phi = \pi$ ($q_0 = 0$, a
    cone-shaped maximum in $q_0$) the derivative with respect to $q_0$ is 0, because
    $|q_0|$ is written $q_0\,\mathrm{sign}(q_0)$ with [`jaxatt.numerics.sign`][] (whose
    derivative is 0). The zero quaternion (not a rotation) gives angle 0 and gradient 0.
    """
    q = jnp.asarray(q)
    sin_half = safe_norm(q[1:])
    cos_half = q[0] * sign(q[0])
    # The C library's atan2, not `vectorized_arctan2`: in Chen 2022's Monte Carlo timing the
    # convergence of this angle, the vectorized one ran 0.93x as fast at 1000 samples (1.07x
    # at 10 000; benchmarks/README.md, "Arctangents and an arccosine that
    # vectorize").
    # Double where: atan2(0, 0) has a 0/0 derivative; only the zero quaternion reaches it.
    # (Tested as "both zero", so that a NaN quaternion gives a NaN angle, never 0.)
    zero = (sin_half == 0) & (cos_half == 0)
    half = jnp.arctan2(sin_half, jnp.where(zero, 1, cos_half))
    return 2 * jnp.where(zero, 0, half)


@jax.jit
def quat_rotate(q: Float[ArrayLike, "4"], v: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
    r"""Vector part of $q \otimes [0, v] \otimes q^*$: body components to inertial components.

    $$v_N = (q_0^2 - q_v^\top q_v)\,v_B + 2 (q_v^\top v_B)\,q_v + 2 q_0\, q_v \times v_B
    = C_{BN}^\top v_B,$$

    i.e. `quat_to_dcm(q).T @ v`. Equivalently, it turns `v` actively by the rotation `q`.
    For a non-unit `q` the result is scaled by $\|q\|^2$ (as the sandwich product is).
    """
    q = jnp.asarray(q)
    v = jnp.asarray(v)
    q0, qv = q[0], q[1:]
    return (q0 * q0 - jnp.dot(qv, qv)) * v + 2 * jnp.dot(qv, v) * qv + 2 * q0 * jnp.cross(qv, v)


@jax.jit
def quat_to_dcm(q: Float[ArrayLike, "4"]) -> Float[Array, "3 3"]:
    r"""Attitude matrix $C_{BN}$ (maps inertial components to body components).

    $$C(q) = (q_0^2 - q_v^\top q_v) I_3 + 2 q_v q_v^\top - 2 q_0 [q_v\times].$$

    Orthonormal with determinant 1 for unit `q` (for other norms it is $\|q\|^2$ times a
    rotation). $C(q) = C(-q)$ and $\dot C = -[\omega\times] C$ along [`quat_kinematics`][].
    """
    q = jnp.asarray(q)
    q0, qv = q[0], q[1:]
    eye = jnp.eye(3, dtype=q.dtype)
    return (q0 * q0 - jnp.dot(qv, qv)) * eye + 2 * jnp.outer(qv, qv) - 2 * q0 * skew(qv)


@jax.jit
def quat_from_dcm(c: Float[ArrayLike, "3 3"]) -> Float[Array, "4"]:
    r"""Unit quaternion with `quat_to_dcm(q) == c`, by Shepperd's method; $q_0 \ge 0$.

    With $C = C(q)$, the symmetric matrix $K_{kj} = 4 q_k q_j$ is linear in the entries of $C$:
    $K_{00} = 1 + \mathrm{tr}\,C$, $K_{ii} = 1 + 2C_{ii} - \mathrm{tr}\,C$,
    $K_{01} = C_{23} - C_{32}$, $K_{12} = C_{12} + C_{21}$, and so on. The row $k$ with the
    largest diagonal entry ($4 q_k^2 \ge 1$, since the diagonal sums to 4) is the best
    conditioned; it is selected with `argmax` (branch-free under `jit`/`vmap`), normalized,
    and made canonical. Accurate to rounding for every rotation, including angles near
    $\pi$ where $q_0 \to 0$. A slightly non-orthogonal `c` still yields a unit quaternion.

    **Gradient:** finite everywhere (the selected row has norm $\ge 1$); at rotations by
    exactly $\pi$ the sign fixed by [`quat_canonical`][] is arbitrary.
    """
    c = jnp.asarray(c)
    trace = c[0, 0] + c[1, 1] + c[2, 2]
    d01 = c[1, 2] - c[2, 1]
    d02 = c[2, 0] - c[0, 2]
    d03 = c[0, 1] - c[1, 0]
    s12 = c[0, 1] + c[1, 0]
    s13 = c[0, 2] + c[2, 0]
    s23 = c[1, 2] + c[2, 1]
    k = jnp.stack(
        [
            jnp.stack([1 + trace, d01, d02, d03]),
            jnp.stack([d01, 1 + 2 * c[0, 0] - trace, s12, s13]),
            jnp.stack([d02, s12, 1 + 2 * c[1, 1] - trace, s23]),
            jnp.stack([d03, s13, s23, 1 + 2 * c[2, 2] - trace]),
        ]
    )
    row = k[jnp.argmax(jnp.diagonal(k))]
    return quat_canonical(safe_normalize(row))


def quat_kinematics_matrix(q: Float[ArrayLike, "4"]) -> Float[Array, "4 3"]:
    r"""Kinematics matrix $E(q)$ of $\dot q = \tfrac12 E(q)\,\omega$ (body rate $\omega$).

    $$E(q) = \begin{bmatrix} -q_v^\top \\ q_0 I_3 + [q_v\times] \end{bmatrix},
    \qquad E(q)\,\omega = q \otimes [0, \omega].$$
    """
    q = jnp.asarray(q)
    q0, qv = q[0], q[1:]
    lower = q0 * jnp.eye(3, dtype=q.dtype) + skew(qv)
    return jnp.concatenate([-qv[None, :], lower], axis=0)


@jax.jit
def quat_kinematics(q: Float[ArrayLike, "4"], omega: Float[ArrayLike, "3"]) -> Float[Array, "4"]:
    r"""Quaternion rate $\dot q = \tfrac12 E(q)\,\omega = \tfrac12\, q \otimes [0, \omega]$.

    SPEC seed 000 eqs. (1)-(2): $\dot q_0 = -\tfrac12 q_v^\top\omega$,
    $\dot q_v = \tfrac12 (q_0 I_3 + [q_v\times])\,\omega$.

    **Arguments:**
    - `q`: attitude of the body frame relative to the inertial frame.
    - `omega`: body angular rate in body components [rad/s].

    **Returns:** $\dot q$ [1/s]. The flow preserves $\|q\|$ exactly ($q^\top \dot q = 0$);
    numerical integration does not.
    """
    q = jnp.asarray(q)
    omega = jnp.asarray(omega)
    q0, qv = q[0], q[1:]
    scalar = -0.5 * jnp.dot(qv, omega)
    vector = 0.5 * (q0 * omega + jnp.cross(qv, omega))
    return jnp.concatenate([scalar[None], vector])
