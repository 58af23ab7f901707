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
