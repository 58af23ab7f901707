"""Closed-form 3x3 linear algebra.

XLA:CPU lowers `jnp.linalg.solve` on a batch of 3x3 systems to a LAPACK custom call per batch;
the adjugate formula below is a handful of elementwise multiply-adds that fuse with the rest of
a vectorized closed loop (DESIGN.md, performance notes).
"""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float


def _adjugate3(a: Float[Array, "3 3"]) -> Float[Array, "3 3"]:
    # Columns of the adjugate are cross products of the rows of `a`.
    r0, r1, r2 = a[0], a[1], a[2]
    return jnp.stack([jnp.cross(r1, r2), jnp.cross(r2, r0), jnp.cross(r0, r1)], axis=-1)


def det3(a: Float[ArrayLike, "3 3"]) -> Float[Array, ""]:
    """Determinant of a 3x3 matrix (scalar triple product of its rows)."""
    a = jnp.asarray(a)
    return jnp.dot(a[0], jnp.cross(a[1], a[2]))


def solve3(a: Float[ArrayLike, "3 3"], b: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
    r"""Solve $a x = b$ (non-singular 3x3 `a`) by Cramer's rule, $x = \mathrm{adj}(a) b / \det a$.

    Exact up to rounding for well-conditioned `a` (an inertia matrix, condition number
    $\lesssim 10^3$); differentiable in `a` and `b`. Singular `a` gives inf/NaN: callers pass
    matrices already validated as positive definite.
    """
    a = jnp.asarray(a)
    b = jnp.asarray(b)
    return (_adjugate3(a) @ b) / det3(a)


def inv3(a: Float[ArrayLike, "3 3"]) -> Float[Array, "3 3"]:
    """Inverse of a non-singular 3x3 matrix by the adjugate formula (see [`solve3`][])."""
    a = jnp.asarray(a)
    return _adjugate3(a) / det3(a)


def spectral_norm(a: Float[ArrayLike, "m n"]) -> Float[Array, ""]:
    r"""$\|A\|_2 = \sigma_{\max}(A) = \sqrt{\lambda_{\max}(AA^\top)}$ (the larger Gram matrix is
    never formed: $A^\top A$ when $A$ is tall).

    Computed from the symmetric eigenvalue problem rather than an SVD: the same value, and in a
    closed loop about half the compile time of `jnp.linalg.norm(a, 2)` (measured on the Zhang
    2021 pose controller: forward 8 s against 17 s, with reverse mode 43 s against 70 s).
    **Gradient:** $u_1^\top\,dA\,v_1$ where $\sigma_{\max}$ is simple; at a repeated
    $\sigma_{\max}$ JAX's eigenvalue derivative gives a finite one-sided value. At $A = 0$ the
    gradient is 0 (guarded square root).
    """
    a = jnp.asarray(a)
    gram = a.T @ a if a.shape[0] > a.shape[1] else a @ a.T
    largest = jnp.linalg.eigvalsh(gram)[-1]
    positive = largest > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, largest, 1.0)), 0.0)
