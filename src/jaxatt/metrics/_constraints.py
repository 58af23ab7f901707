"""Constraint margins: how close a signal comes to a magnitude bound."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import BoolScalar, RealScalarLike, Scalar
from .._validation import check_positive
from ..numerics import amax, amin
from ._signals import as_signal


_HINT = " For a scalar signal pass x[:, None]."


def _bound(where: str, bound: ArrayLike, x: Array) -> Array:
    bound = check_positive(where, "bound", bound)
    if bound.shape not in ((), (x.shape[1],)):
        raise ValueError(
            f"{where}: `bound` must be a scalar or have one entry per component (shape "
            f"({x.shape[1]},)), got shape {bound.shape}."
        )
    return bound


@jax.jit
def _constraint_margin(x: Array, bound: Array) -> Array:
    return amin(bound - amax(jnp.abs(x), axis=0))


@jax.jit
def _constraint_violated(x: Array, bound: Array) -> Array:
    # `max` propagates NaN, and `~(nan < b)` is True.
    return jnp.any(~(amax(jnp.abs(x), axis=0) < bound))


def max_abs(x: Float[ArrayLike, "T n"]) -> Float[Array, " n"]:
    r"""Largest magnitude of each component over the record, $\max_t |x_{t,i}|$.

    **Arguments:**
    - `x`: signal, shape `(T, n)`, time first (e.g. body rates [rad/s]).

    **Returns:** shape `(n,)`, in the unit of `x`.

    **Gradients:** through the extreme sample of each component (as `max`).
    """
    x = as_signal("max_abs", "x", x, 2, _HINT)
    return amax(jnp.abs(x), axis=0)


def constraint_margin(
    x: Float[ArrayLike, "T n"], bound: RealScalarLike | Float[ArrayLike, " n"]
) -> Scalar:
    r"""Smallest distance to the bound over time and components (positive = satisfied).

    $$m = \min_i \left(b_i - \max_t |x_{t,i}|\right),$$

    which for a scalar bound $b$ is $b - \max_{t,i} |x_{t,i}|$. The constraint $|x_{t,i}| < b_i$
    holds on every sample exactly when $m > 0$.

    **Arguments:**
    - `x`: constrained signal, shape `(T, n)` (e.g. body rates [rad/s] under a rate limit).
    - `bound`: positive bound, a scalar or one per component (shape `(n,)`), unit of `x`.

    **Returns:** a scalar in the unit of `x`.

    **Gradients:** $-\operatorname{sign}(x)$ at the binding sample (as `max`), 1 in the binding
    `bound`; finite.
    """
    where = "constraint_margin"
    x = as_signal(where, "x", x, 2, _HINT)
    bound = _bound(where, bound, x)
    return _constraint_margin(x, bound)


def constraint_violated(
    x: Float[ArrayLike, "T n"], bound: RealScalarLike | Float[ArrayLike, " n"]
) -> BoolScalar:
    r"""Whether any sample reaches the bound, $\exists\, t, i:\ |x_{t,i}| \ge b_i$.

    A NaN sample counts as a violation (a diverged run must not look feasible).

    **Arguments:** as [`constraint_margin`][].

    **Returns:** a boolean scalar array.
    """
    where = "constraint_violated"
    x = as_signal(where, "x", x, 2, _HINT)
    bound = _bound(where, bound, x)
    return _constraint_violated(x, bound)
