"""Euclidean norms whose gradient at the zero vector is finite (zero)."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float


def safe_norm(
    x: Float[ArrayLike, "..."], axis: int | tuple[int, ...] = -1, keepdims: bool = False
) -> Float[Array, "..."]:
    r"""$\|x\|_2$ along `axis`, with gradient 0 (not NaN) where the vector is exactly zero.

    Elementwise over the other axes: a batch with some zero rows gets finite gradients for
    every row. The double `where` (mask the input, then the output) is what keeps `sqrt'(0)`
    out of the backward pass.
    """
    x = jnp.asarray(x)
    squared = jnp.sum(x * x, axis=axis, keepdims=keepdims)
    nonzero = squared > 0
    return jnp.where(nonzero, jnp.sqrt(jnp.where(nonzero, squared, 1)), 0)


def safe_normalize(x: Float[ArrayLike, "..."], axis: int = -1) -> Float[Array, "..."]:
    r"""$x / \|x\|_2$ along `axis`; the zero vector maps to the zero vector with gradient 0."""
    x = jnp.asarray(x)
    norm = safe_norm(x, axis=axis, keepdims=True)
    nonzero = norm > 0
    return jnp.where(nonzero, x / jnp.where(nonzero, norm, 1), 0)
