"""Inverse trigonometric functions with finite derivatives at the ends of their domain."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ._atan import vectorized_arccos
from ._extrema import clip, maximum


@jax.custom_jvp
def safe_arccos(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    r"""$\arccos(\mathrm{clip}(x, -1, 1))$, from
    [`vectorized_arccos`][jaxatt.numerics.vectorized_arccos] (no C-library call in a float64
    program).

    **Gradient:** $-1/\sqrt{\max(1 - x^2, \varepsilon)}$ (`eps` the dtype's machine epsilon),
    finite at $x = \pm 1$ where the exact derivative is infinite.
    """
    x = jnp.asarray(x)
    return vectorized_arccos(clip(x, -1, 1))


@safe_arccos.defjvp
def _safe_arccos_jvp(primals, tangents):
    (x,), (x_dot,) = primals, tangents
    x = jnp.asarray(x)
    eps = jnp.finfo(x.dtype).eps
    slope = -1 / jnp.sqrt(maximum(1 - x * x, eps))
    return safe_arccos(x), slope * x_dot
