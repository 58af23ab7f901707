"""The cross-product (skew-symmetric) matrix and its inverse.

`skew` is a `jax.jit` function, like the other per-stage rotation helpers (see
`jaxatt/rotations/_mrp.py`): traced once per argument shape, not at every call site.
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float


@jax.jit
def skew(v: Float[ArrayLike, "3"]) -> Float[Array, "3 3"]:
    r"""Cross-product matrix $[v\times]$, so that $[v\times]\,w = v \times w$.

    $$[v\times] = \begin{bmatrix} 0 & -v_3 & v_2 \\ v_3 & 0 & -v_1 \\ -v_2 & v_1 & 0
    \end{bmatrix}.$$

    **Arguments:**
    - `v`: a 3-vector.

    **Returns:** the skew-symmetric 3x3 matrix, same dtype as `v`.
    """
    v = jnp.asarray(v)
    # One concatenate of one-element slices: 10 jaxpr equations a call instead of 35 for nested
    # stacks of indexed entries (the same values; smaller programs to trace and compile).
    zero = jnp.zeros_like(v[:1])
    v1, v2, v3 = v[0:1], v[1:2], v[2:3]
    entries = [zero, -v3, v2, v3, zero, -v1, -v2, v1, zero]
    return jnp.concatenate(entries).reshape(3, 3)


def vee(m: Float[ArrayLike, "3 3"]) -> Float[Array, "3"]:
    r"""Inverse of [`skew`][]: the vector $v$ of the skew-symmetric part of `m`.

    $$v = \tfrac12\,(m_{32} - m_{23},\; m_{13} - m_{31},\; m_{21} - m_{12}),$$

    so `vee(skew(v)) == v` and, for any matrix, `vee(m) == vee((m - m.T) / 2)`.

    **Arguments:**
    - `m`: a 3x3 matrix (normally skew-symmetric).

    **Returns:** a 3-vector, same dtype as `m`.
    """
    m = jnp.asarray(m)
    return 0.5 * jnp.stack([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
