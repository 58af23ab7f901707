"""Euclidean norms whose gradient at the zero vector is finite (zero), and that never hide NaN."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float


def safe_norm(
    x: Float[ArrayLike, "..."], axis: int | tuple[int, ...] = -1, keepdims: bool = False
) -> Float[Array, "..."]:
    r"""$\|x\|_2$ along `axis`, with gradient 0 (not NaN) where the vector is exactly zero.

    Elementwise over the other axes: a batch with some zero rows gets finite gradients for
    every row. The double `where` (mask the input, then the output) is what keeps `sqrt'(0)`
    out of the backward pass.

    **Non-finite input propagates:** a vector holding a NaN has norm NaN, one holding an
    infinity (and no NaN) has norm `inf`. A diverged state therefore never looks small (a
    norm of 0 would make a diverged simulation look settled).
    """
    x = jnp.asarray(x)
    squared = jnp.sum(x * x, axis=axis, keepdims=keepdims)
    positive = squared > 0
    # `squared` is 0 (norm 0), > 0 (sqrt), or NaN (neither comparison holds: returned as is).
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, squared, 1)), squared)


def safe_normalize(x: Float[ArrayLike, "..."], axis: int = -1) -> Float[Array, "..."]:
    r"""$x / \|x\|_2$ along `axis`; the zero vector maps to the zero vector with gradient 0.

    A vector holding a NaN maps to NaN.
    """
    x = jnp.asarray(x)
    norm = safe_norm(x, axis=axis, keepdims=True)
    nonzero = norm > 0
    return jnp.where(nonzero, x / jnp.where(nonzero, norm, 1), x * 0)
