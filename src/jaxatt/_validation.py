"""Argument checks shared by every constructor.

Each helper converts its argument to a JAX array and checks a rule. When the value is
concrete (built eagerly, the usual case) a violated rule raises a `ValueError` that names the
owner, the argument, the value and the rule. When the value is a tracer (the module is being
built inside `jit`/`vmap`/`grad`) the rule cannot be decided at trace time, so the check is
attached to the value with `eqx.error_if` and fires at run time instead.
"""

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool


def _is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


def _describe(x) -> str:
    arr = np.asarray(x)
    if arr.ndim == 0:
        return f"{arr.item()!r}"
    return np.array2string(arr, precision=6, separator=", ")


def _as_float_array(x: ArrayLike, name: str, where: str) -> Array:
    if isinstance(x, (str, bytes)) or x is None:
        raise ValueError(f"{where}: `{name}` must be a number or an array, got {x!r}.")
    arr = jnp.asarray(x)
    if not jnp.issubdtype(arr.dtype, jnp.floating):
        arr = arr.astype(jnp.result_type(float))
    return arr


def check(
    where: str,
    name: str,
    value: ArrayLike,
    predicate: Callable[[Array], Bool[Array, "..."]],
    rule: str,
) -> Array:
    """Check `predicate(value)` elementwise; raise (concrete) or attach an `error_if` (traced).

    **Arguments:**
    - `where`: the owner, e.g. the class name, used as the message prefix.
    - `name`: the argument's name as the user wrote it.
    - `value`: the value; converted to a floating JAX array.
    - `predicate`: maps the array to booleans that must all hold.
    - `rule`: the rule in words, e.g. "must be positive".

    **Returns:** the value as a floating JAX array.
    """
    arr = _as_float_array(value, name, where)
    ok = predicate(arr)
    message = f"{where}: `{name}` {rule}"
    if _is_traced(arr) or _is_traced(ok):
        return eqx.error_if(arr, ~jnp.all(ok), message + ".")
    if not bool(jnp.all(ok)):
        raise ValueError(f"{message}, got {name}={_describe(arr)}.")
    return arr


def check_finite(where: str, name: str, value: ArrayLike) -> Array:
    return check(where, name, value, jnp.isfinite, "must be finite")


def check_positive(where: str, name: str, value: ArrayLike) -> Array:
    return check(where, name, value, lambda x: jnp.isfinite(x) & (x > 0), "must be positive")


def check_nonnegative(where: str, name: str, value: ArrayLike) -> Array:
    return check(where, name, value, lambda x: jnp.isfinite(x) & (x >= 0), "must be non-negative")


def check_in_open_interval(
    where: str, name: str, value: ArrayLike, low: float, high: float
) -> Array:
    return check(
        where, name, value, lambda x: (x > low) & (x < high), f"must lie in ({low}, {high})"
    )


def check_greater_than(where: str, name: str, value: ArrayLike, low: float) -> Array:
    return check(
        where, name, value, lambda x: jnp.isfinite(x) & (x > low), f"must be greater than {low}"
    )


def check_shape(where: str, name: str, value: ArrayLike, shape: tuple[int, ...]) -> Array:
    """Convert to a floating array and require an exact shape (always decidable at trace time)."""
    arr = _as_float_array(value, name, where)
    if arr.shape != shape:
        raise ValueError(f"{where}: `{name}` must have shape {shape}, got shape {arr.shape}.")
    return arr


def check_spd(where: str, name: str, value: ArrayLike) -> Array:
    """A symmetric positive-definite 3x3 matrix (an inertia)."""
    arr = check_shape(where, name, value, (3, 3))
    sym_tol = 1e-9 * (1.0 + jnp.max(jnp.abs(arr)))

    def predicate(m):
        symmetric = jnp.max(jnp.abs(m - m.T)) <= sym_tol
        min_eig = jnp.linalg.eigvalsh(0.5 * (m + m.T))[0]
        return symmetric & (min_eig > 0) & jnp.all(jnp.isfinite(m))

    return check(where, name, arr, predicate, "must be a symmetric positive-definite matrix")


UNIT_QUATERNION_TOLERANCE = 1e-6
"""Largest accepted | ||q|| - 1 | for a quaternion handed to a constructor or `simulate`."""


def check_unit_quaternion(
    where: str, name: str, value: ArrayLike, tol: float = UNIT_QUATERNION_TOLERANCE
) -> Array:
    arr = check_shape(where, name, value, (4,))
    return check(
        where,
        name,
        arr,
        lambda q: jnp.abs(jnp.sqrt(jnp.sum(q**2)) - 1) <= tol,
        f"must be a unit quaternion (| ||q|| - 1 | <= {tol:g}); normalize it first",
    )
