"""Shape and dtype plumbing shared by the reaching laws (private)."""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float


def as_state(s: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    """`s` as a floating JAX array (its own dtype is kept: float32 in, float32 out)."""
    s = jnp.asarray(s)
    if not jnp.issubdtype(s.dtype, jnp.floating):
        s = s.astype(jnp.result_type(float))
    return s


def as_param(where: str, name: str, value: Array, s: Array) -> Array:
    """A gain or exponent cast to the dtype of `s` and broadcast to its shape.

    Parameters are scalars or per-axis arrays; the output of a law has the shape of `s`, so a
    parameter must broadcast *to* `s.shape` (a per-axis gain of shape (3,) needs an `s` of
    shape (3,), or a batch of them). This is a static shape check, made at trace time.
    """
    try:
        target = np.broadcast_shapes(value.shape, s.shape)
    except ValueError:
        target = None
    if target != s.shape:
        raise ValueError(
            f"{where}: `{name}` of shape {value.shape} does not broadcast to the shape "
            f"{s.shape} of `s`; parameters are scalars or per-axis arrays matching `s`."
        )
    return jnp.broadcast_to(value.astype(s.dtype), s.shape)
