r"""Maxima, minima and clipping whose derivatives follow the chosen element.

JAX's derivative rules for `jnp.max`/`jnp.min` (the `reduce_max`/`reduce_min` primitives) and
for `jnp.maximum`/`jnp.minimum`/`jnp.clip` (`max`/`min`) find the chosen element by testing
*bitwise* equality between the operand and the result. In a compiled gradient the operand is
often computed twice: in the forward pass, and again in the backward pass (a `jax.checkpoint`
recomputing it, or XLA duplicating its producer into two fusions). The two copies can differ in
the last bit, and then no element equals the result: `reduce_max`'s derivative divides a zero
sum by a zero count (NaN), and `max`'s derivative drops the gradient (zero), with no error.

Measured on jax 0.10.2 (2026-12-05): the gradient of Zhang 2021's tuning objective
(`jaxatt.scenarios.zhang2021_tuning`, 150 s horizon, `checkpoint=False`) was NaN in all ten
entries under XLA:CPU's LLVM emitters at optimization level 0 (the test suite's compiler
settings), from the derivative of the `jnp.max` in `MaxAbs`; the same program gave finite
gradients under XLA's defaults. On GPUs the same mechanism silently drops `jnp.maximum`'s
gradient (jax issue #40564).

The helpers here choose with a comparison instead (`jnp.where`, `jnp.argmax`): the predicate is
computed once from the operands, and the derivative is exactly that of the chosen element,
however its copies round. Values equal those of the `jnp` functions, NaN included (a NaN
operand gives NaN). At a tie the derivative goes to one of the tied elements (the first), where
JAX's rules split it; both are valid one-sided derivatives of a function that is not
differentiable there.
"""

import math

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Real


_UNROLLED = 16
"""Reductions over at most this many elements are a chain of elementwise selects (what
`jaxatt.simulation`'s scalarization keeps elementwise); longer ones use `jnp.argmax`."""


def maximum(a: Real[ArrayLike, "*#shape"], b: Real[ArrayLike, "*#shape"]) -> Real[Array, "..."]:
    r"""Elementwise $\max(a, b)$ (as `jnp.maximum`, NaN propagating).

    **Gradient:** that of the larger operand ($a$ at a tie), whatever the rounding of copies of
    the operands in the compiled program.
    """
    a, b = jnp.asarray(a), jnp.asarray(b)
    return jnp.where((a >= b) | jnp.isnan(a), a, b)


def minimum(a: Real[ArrayLike, "*#shape"], b: Real[ArrayLike, "*#shape"]) -> Real[Array, "..."]:
    r"""Elementwise $\min(a, b)$ (as `jnp.minimum`, NaN propagating); gradient as [`maximum`][]."""
    a, b = jnp.asarray(a), jnp.asarray(b)
    return jnp.where((a <= b) | jnp.isnan(a), a, b)


def clip(
    x: Real[ArrayLike, "*#shape"],
    lower: Real[ArrayLike, "*#shape"] | None = None,
    upper: Real[ArrayLike, "*#shape"] | None = None,
) -> Real[Array, "..."]:
    r"""$\min(\max(x, \text{lower}), \text{upper})$ (as `jnp.clip`; `None` leaves that side open).

    A NaN in `x` or in a bound propagates, as in `jnp.clip`: a saturation limit that became NaN
    (a diverged tuning step) gives a NaN command, never the unclipped one.

    **Gradient:** 1 with respect to $x$ inside the bounds (at a bound too), and that of the bound
    that is active outside them.
    """
    out = jnp.asarray(x)
    if lower is not None:
        out = jnp.where(_or_nan(out < lower, lower), lower, out)
    if upper is not None:
        out = jnp.where(_or_nan(out > upper, upper), upper, out)
    return out


def _or_nan(chosen: Array, bound) -> Array:
    """`chosen`, or everywhere where `bound` is NaN (skipped for a Python number)."""
    if isinstance(bound, (int, float)) and not math.isnan(bound):
        return chosen
    return chosen | jnp.isnan(bound)


def amax(
    x: Real[ArrayLike, "..."], axis: int | tuple[int, ...] | None = None
) -> Real[Array, "..."]:
    r"""$\max$ over `axis` (default: all axes), as `jnp.max` (NaN propagating).

    **Gradient:** one at the chosen element (the first maximum), zero elsewhere.
    """
    return _reduce(jnp.asarray(x), axis, maximum, jnp.argmax, "amax")


def amin(
    x: Real[ArrayLike, "..."], axis: int | tuple[int, ...] | None = None
) -> Real[Array, "..."]:
    r"""$\min$ over `axis` (default: all axes), as `jnp.min`; gradient as [`amax`][]."""
    return _reduce(jnp.asarray(x), axis, minimum, jnp.argmin, "amin")


def _reduce(x: Array, axis, pairwise, index, where: str) -> Array:
    if axis is None:
        axes = tuple(range(x.ndim))
    else:
        axes = (axis,) if isinstance(axis, (int, np.integer)) else tuple(axis)
        if not all(isinstance(a, (int, np.integer)) and -x.ndim <= a < x.ndim for a in axes):
            raise ValueError(
                f"{where}: `axis` must be None or axes of an array of shape {x.shape} (ints in "
                f"[-{x.ndim}, {x.ndim})), got {axis!r}."
            )
        axes = tuple(sorted({int(a) % x.ndim for a in axes}))
    kept = [d for d in range(x.ndim) if d not in axes]
    size = math.prod(x.shape[d] for d in axes)
    if size == 0:
        raise ValueError(f"{where}: the reduction over axis {axis!r} of shape {x.shape} is empty.")
    flat = jnp.transpose(x, kept + list(axes)).reshape([x.shape[d] for d in kept] + [size])
    if size <= _UNROLLED:
        out = flat[..., 0]
        for k in range(1, size):
            out = pairwise(out, flat[..., k])
        return out
    chosen = index(flat, axis=-1, keepdims=True)
    return jnp.take_along_axis(flat, chosen, axis=-1)[..., 0]
