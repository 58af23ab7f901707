r"""Modified Rodrigues parameters $\sigma = \hat n \tan(\phi/4)$: maps, DCM, shadows, kinematics.

See the [`jaxatt.rotations`][] module docstring for the conventions.

The helpers a closed loop calls at every stage (`mrp_to_dcm`, `mrp_kinematics_matrix`,
`mrp_kinematics`) are `jax.jit` functions: traced once per argument shape, with their
derivative and batching rules cached, where inline code is traced again at each call site
(docs/testing.md, "Where a test's time goes").
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check
from ._quaternion import quat_from_dcm
from ._skew import skew


def mrp_from_quat(q: Float[ArrayLike, "4"]) -> Float[Array, "3"]:
    r"""MRP of a unit quaternion, $\sigma = q_v / (1 + q_0)$, taken literally.

    No canonicalization: `q` with $q_0 < 0$ (rotation angle above $\pi$ in the
    $[0, 2\pi)$ reading) gives $\|\sigma\| > 1$, the shadow set of the MRP of `-q`. Apply
    [`mrp_switch`][] afterwards, or pass `quat_canonical(q)`, for $\|\sigma\| \le 1$.

    **Norm:** `q` is not normalised here. For $\|q\| \ne 1$ the result is not the MRP of
    the attitude of `q` (for $q = k\,\hat q$ it is $k\hat q_v / (1 + k\hat q_0)$, off by
    about $|k - 1|$ relative); pass [`quat_normalize`][]`(q)` when the norm may have drifted
    (a quaternion integrated by a solver keeps its norm only to the solver's accuracy).

    **Singular point:** $q_0 = -1$ (a $2\pi$ rotation) divides by zero and returns inf/NaN.
    The gradient is finite everywhere else, in particular at the identity.
    """
    q = jnp.asarray(q)
    return q[1:] / (1 + q[0])


def quat_from_mrp(sigma: Float[ArrayLike, "3"]) -> Float[Array, "4"]:
    r"""Unit quaternion of an MRP: $q = \left[\frac{1 - \sigma^\top\sigma}{1 + \sigma^\top\sigma},
    \frac{2\sigma}{1 + \sigma^\top\sigma}\right]$.

    The inverse of [`mrp_from_quat`][] for every $\sigma$; $q_0 \ge 0$ exactly when
    $\|\sigma\| \le 1$. Smooth everywhere.
    """
    sigma = jnp.asarray(sigma)
    s2 = jnp.dot(sigma, sigma)
    denom = 1 + s2
    return jnp.concatenate([((1 - s2) / denom)[None], 2 * sigma / denom])


def mrp_shadow(sigma: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
    r"""Shadow set $\sigma^S = -\sigma / (\sigma^\top\sigma)$: the same attitude, the other MRP.

    $\sigma^S$ is [`mrp_from_quat`][] of $-q$; `mrp_to_dcm(mrp_shadow(s)) == mrp_to_dcm(s)`.

    **Singular point:** only meaningful for $\sigma \ne 0$ (the shadow of the identity is at
    infinity). At $\sigma = 0$ this returns 0 with gradient 0 (double `where`) rather than
    NaN; [`mrp_switch`][] never evaluates it there.
    """
    sigma = jnp.asarray(sigma)
    s2 = jnp.dot(sigma, sigma)
    zero = s2 == 0  # (not `> 0`: a NaN MRP must stay NaN)
    return jnp.where(zero, 0, -sigma / jnp.where(zero, 1, s2))


def mrp_switch(sigma: Float[ArrayLike, "3"], threshold: RealScalarLike = 1.0) -> Float[Array, "3"]:
    r"""Shadow-set switching: the shadow set where $\|\sigma\| >$ `threshold`, else `sigma`.

    With the default threshold 1 the result satisfies $\|\sigma\| \le 1$ (rotation angle
    $\le \pi$). Apply it after a completed integration step, never between solver stages
    (SPEC, decisions). The map is discontinuous at $\|\sigma\| = $ `threshold`; the gradient is
    that of the branch taken.

    **Arguments:**
    - `sigma`: an MRP.
    - `threshold`: switching radius, at least 1 (a radius below 1 would map some sets outside
      the radius back outside it); checked, raising `ValueError` when concrete.

    **Returns:** an MRP of the same attitude, dtype of `sigma`.
    """
    sigma = jnp.asarray(sigma)
    threshold = check("mrp_switch", "threshold", threshold, lambda xp, t: t >= 1, "must be >= 1")
    s2 = jnp.dot(sigma, sigma)
    return jnp.where(s2 > threshold * threshold, mrp_shadow(sigma), sigma)


@jax.jit
def mrp_to_dcm(sigma: Float[ArrayLike, "3"]) -> Float[Array, "3 3"]:
    r"""Attitude matrix $C_{BN}$ of an MRP (maps inertial components to body components).

    $$C(\sigma) = I_3 + \frac{8[\sigma\times]^2 - 4(1 - \sigma^\top\sigma)[\sigma\times]}
    {(1 + \sigma^\top\sigma)^2},$$

    equal to `quat_to_dcm(quat_from_mrp(sigma))` and unchanged by [`mrp_shadow`][].
    """
    sigma = jnp.asarray(sigma)
    s2 = jnp.dot(sigma, sigma)
    s_x = skew(sigma)
    eye = jnp.eye(3, dtype=sigma.dtype)
    return eye + (8 * (s_x @ s_x) - 4 * (1 - s2) * s_x) / (1 + s2) ** 2


def mrp_from_dcm(c: Float[ArrayLike, "3 3"]) -> Float[Array, "3"]:
    r"""MRP with `mrp_to_dcm(sigma) == c` and $\|\sigma\| \le 1$.

    Computed as `mrp_from_quat(quat_from_dcm(c))`; the canonical quaternion ($q_0 \ge 0$)
    makes $\|\sigma\| \le 1$, with equality at rotations by $\pi$. Gradients finite
    everywhere.
    """
    q = quat_from_dcm(c)
    return q[1:] / (1 + q[0])


@jax.jit
def mrp_kinematics_matrix(sigma: Float[ArrayLike, "3"]) -> Float[Array, "3 3"]:
    r"""Kinematics matrix $G(\sigma)$ of $\dot\sigma = G(\sigma)\,\omega$ (body rate $\omega$).

    $$G(\sigma) = \tfrac14\left[(1 - \sigma^\top\sigma) I_3 + 2[\sigma\times]
    + 2\sigma\sigma^\top\right],$$

    (SPEC seed 004 eq. 3; Schaub's $B(\sigma)/4$). It satisfies
    $\sigma^\top G\,\omega = \frac{1 + \sigma^\top\sigma}{4}\sigma^\top\omega$ and
    $G G^\top = \left(\frac{1 + \sigma^\top\sigma}{4}\right)^2 I_3$ (seed 004 eq. 4).
    """
    sigma = jnp.asarray(sigma)
    s2 = jnp.dot(sigma, sigma)
    eye = jnp.eye(3, dtype=sigma.dtype)
    return 0.25 * ((1 - s2) * eye + 2 * skew(sigma) + 2 * jnp.outer(sigma, sigma))


@jax.jit
def mrp_kinematics(sigma: Float[ArrayLike, "3"], omega: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
    r"""MRP rate $\dot\sigma = G(\sigma)\,\omega$ [1/s], with $G$ from [`mrp_kinematics_matrix`][].

    Written out: $\dot\sigma = \tfrac14\left[(1 - \sigma^\top\sigma)\,\omega
    + 2\,\sigma\times\omega + 2(\sigma^\top\omega)\,\sigma\right]$.

    **Arguments:**
    - `sigma`: attitude of the body frame relative to the inertial frame.
    - `omega`: body angular rate in body components [rad/s].
    """
    sigma = jnp.asarray(sigma)
    omega = jnp.asarray(omega)
    s2 = jnp.dot(sigma, sigma)
    return 0.25 * (
        (1 - s2) * omega + 2 * jnp.cross(sigma, omega) + 2 * jnp.dot(sigma, omega) * sigma
    )


def mrp_compose(
    sigma_a: Float[ArrayLike, "3"], sigma_b: Float[ArrayLike, "3"]
) -> Float[Array, "3"]:
    r"""MRP of the composed rotation, by Schaub's MRP addition formula.

    $$\sigma = \frac{(1 - \|\sigma_a\|^2)\,\sigma_b + (1 - \|\sigma_b\|^2)\,\sigma_a
    + 2\,\sigma_a \times \sigma_b}{1 + \|\sigma_a\|^2\|\sigma_b\|^2
    - 2\,\sigma_a^\top\sigma_b}.$$

    **Frame chain** (the order of [`quat_multiply`][]): `sigma_a` is the attitude of frame A
    relative to N, `sigma_b` that of B relative to A; the result is B relative to N, with
    `mrp_to_dcm(result) == mrp_to_dcm(sigma_b) @ mrp_to_dcm(sigma_a)`. The formula is
    algebraically identical to
    `mrp_from_quat(quat_multiply(quat_from_mrp(sigma_a), quat_from_mrp(sigma_b)))`, literal
    as that is: the result may have $\|\sigma\| > 1$ (use [`mrp_switch`][]).

    **Accuracy:** where the composed rotation exceeds $\pi$ (composed $q_0 < 0$, the
    denominator below $\|\sigma_a + \sigma_b\|^2$) the denominator, a difference of terms
    of order 1, is computed as the equal $\|\mathrm{numerator}\|^2 / \|\sigma_a +
    \sigma_b\|^2$, which has no cancellation: the result (and its [`mrp_switch`][]) stays
    accurate to the numerator's rounding as $q_0 \to -1$, e.g. when `sigma_b` is nearly the
    shadow set of `-sigma_a`.

    **Singular point:** the denominator vanishes exactly when the composed quaternion is
    $[-1, 0, 0, 0]$ (e.g. `sigma_b` is the shadow set of `-sigma_a`: the composition is the
    identity rotation). Where the denominator is below `16 eps` times
    $(1 + \|\sigma_a\|^2)(1 + \|\sigma_b\|^2)$ (`eps` the dtype's machine epsilon; the
    literal result would exceed $1/\sqrt{16\,\mathrm{eps}}$ in norm, about 2e7 in float64
    and 7e2 in float32) the shadow set
    $-\mathrm{numerator} / \|\sigma_a + \sigma_b\|^2$ is returned instead: the same attitude,
    finite and close to 0; gradients stay finite (double `where`).
    """
    sigma_a = jnp.asarray(sigma_a)
    sigma_b = jnp.asarray(sigma_b)
    a2 = jnp.dot(sigma_a, sigma_a)
    b2 = jnp.dot(sigma_b, sigma_b)
    numerator = (1 - a2) * sigma_b + (1 - b2) * sigma_a + 2 * jnp.cross(sigma_a, sigma_b)
    # denominator = (1 + q0) (1 + a2) (1 + b2) / 2 >= 0 and
    # (1 + a2)(1 + b2) - denominator = |sigma_a + sigma_b|^2 = (1 - q0) (1 + a2) (1 + b2) / 2,
    # so |numerator|^2 = denominator * shadow_denominator (|sigma|^2 = (1 - q0) / (1 + q0)).
    shadow_denominator = jnp.dot(sigma_a + sigma_b, sigma_a + sigma_b)
    denominator = 1 + a2 * b2 - 2 * jnp.dot(sigma_a, sigma_b)
    # For q0 < 0 the denominator cancels between O(1) terms (absolute error ~eps, relative
    # eps / denominator); |numerator|^2 / shadow_denominator has the relative error of the
    # numerator only. (Double where: the shadow denominator is 0 when sigma_a = -sigma_b.)
    far = denominator < shadow_denominator
    denominator = jnp.where(
        far,
        jnp.dot(numerator, numerator) / jnp.where(far, shadow_denominator, 1),
        denominator,
    )
    eps = jnp.finfo(numerator.dtype).eps
    singular = denominator <= 16 * eps * (1 + a2) * (1 + b2)
    literal = numerator / jnp.where(singular, 1, denominator)
    shadow = -numerator / jnp.where(singular, shadow_denominator, 1)
    return jnp.where(singular, shadow, literal)
