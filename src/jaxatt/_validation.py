"""Argument checks shared by every constructor.

Each helper converts its argument to a JAX array and checks a rule.

- **Concrete values** (the usual case: a module built eagerly) are checked on the host with
  NumPy, so a check compiles nothing. A violated rule raises a `ValueError` that names the
  owner, the argument, the value and the rule.
- **Traced values** (a module built inside `jit`/`vmap`/`grad`) cannot be decided at trace
  time, so the check is attached to the value with `eqx.error_if` and fires at run time -
  except inside the programs jaxatt compiles itself ([`host_checked_program`][]: `simulate`'s
  time loop, the Monte Carlo batch, a tuning step), whose inputs were checked on the host
  before tracing (constructors check their concrete fields; the entry points check states and
  settings). Those programs hold no host callback, so JAX's persistent compilation cache
  accepts them; their run-time failures come back as status codes.

Every result is a *strongly typed* floating array: a Python float becomes an array of JAX's
default float dtype (float64 when x64 is enabled), never a weakly typed one. Tuning writes
strongly typed gains back into modules, so a template built from Python floats and its tuned
copies share their compiled programs.
"""

import contextlib
import contextvars
import functools
import numbers
from collections.abc import Callable
from types import ModuleType

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike


Predicate = Callable[[ModuleType, Array], ArrayLike]
"""`predicate(xp, x)` returns booleans that must all hold; `xp` is `numpy` for concrete
values and `jax.numpy` for traced ones, so one predicate serves both."""


_HOST_CHECKED = contextvars.ContextVar("jaxatt_host_checked", default=False)


@contextlib.contextmanager
def host_checked():
    """While tracing a program whose inputs were checked on the host: traced checks are not
    re-attached as `eqx.error_if` (host callbacks)."""
    token = _HOST_CHECKED.set(True)
    try:
        yield
    finally:
        _HOST_CHECKED.reset(token)


def host_checked_program(fn: Callable) -> Callable:
    """`fn` traced under [`host_checked`][]: for the bodies of jaxatt's own compiled entry points
    (wrap before `eqx.filter_jit`). Their arrays are either module fields that the modules'
    constructors checked on the host, states and settings the entry point checked on the host,
    or values computed in the program (whose failures the status codes report)."""

    @functools.wraps(fn)
    def traced(*args, **kwargs):
        with host_checked():
            return fn(*args, **kwargs)

    return traced


def _skip_traced_check() -> bool:
    return _HOST_CHECKED.get()


def is_traced(x) -> bool:
    """Whether `x` is a JAX tracer (its value is unknown at trace time)."""
    return isinstance(x, jax.core.Tracer)


def describe(x) -> str:
    """A short printable form of a value, for error messages."""
    arr = np.asarray(x)
    if arr.ndim == 0:
        return f"{arr.item()!r}"
    return np.array2string(arr, precision=6, separator=", ", threshold=20)


def as_float_array(x: ArrayLike, name: str, where: str) -> Array:
    """A strongly typed floating JAX array (integers and bools become the default float)."""
    if isinstance(x, (str, bytes)) or x is None or isinstance(x, eqx.Module):
        raise ValueError(f"{where}: `{name}` must be a number or an array, got {x!r}.")
    if is_traced(x):
        dtype = x.dtype if jnp.issubdtype(x.dtype, jnp.floating) else jnp.result_type(float)
        return jnp.asarray(x, dtype=dtype)
    try:
        host = np.asarray(x)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: `{name}` must be a number or an array, got {x!r}.") from None
    if host.dtype == object:
        raise ValueError(f"{where}: `{name}` must be a number or an array, got {x!r}.")
    if isinstance(x, jax.Array) and jnp.issubdtype(x.dtype, jnp.floating):
        return jnp.asarray(x, dtype=x.dtype)  # keeps float32 arrays float32, drops weak type
    if np.issubdtype(host.dtype, np.floating) and not isinstance(x, (float, int)):
        # NumPy float arrays keep their precision (float32 stays float32), within what JAX's
        # configuration allows (float64 becomes float32 without x64).
        return jnp.asarray(host, dtype=jax.dtypes.canonicalize_dtype(host.dtype))
    return jnp.asarray(host, dtype=jnp.result_type(float))


def check(
    where: str,
    name: str,
    value: ArrayLike,
    predicate: Predicate,
    rule: str,
) -> Array:
    """Check `predicate(xp, value)` elementwise; raise (concrete) or attach an `error_if` (traced).

    **Arguments:**
    - `where`: the owner, e.g. the class name, used as the message prefix.
    - `name`: the argument's name as the user wrote it.
    - `value`: the value; converted to a strongly typed floating JAX array.
    - `predicate`: `(xp, x) -> booleans` that must all hold (see [`Predicate`][]).
    - `rule`: the rule in words, e.g. "must be positive and finite".

    **Returns:** the value as a floating JAX array.
    """
    arr = as_float_array(value, name, where)
    message = f"{where}: `{name}` {rule}"
    if is_traced(arr):
        if _skip_traced_check():
            return arr
        ok = jnp.all(jnp.asarray(predicate(jnp, arr)))
        return eqx.error_if(arr, ~ok, message + ".")
    host = np.asarray(arr)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        ok = bool(np.all(predicate(np, host)))
    if not ok:
        raise ValueError(f"{message}, got {name}={describe(host)}.")
    return arr


def check_finite(where: str, name: str, value: ArrayLike) -> Array:
    return check(where, name, value, lambda xp, x: xp.isfinite(x), "must be finite")


def check_positive(where: str, name: str, value: ArrayLike) -> Array:
    return check(
        where, name, value, lambda xp, x: xp.isfinite(x) & (x > 0), "must be positive and finite"
    )


def check_nonnegative(where: str, name: str, value: ArrayLike) -> Array:
    return check(
        where,
        name,
        value,
        lambda xp, x: xp.isfinite(x) & (x >= 0),
        "must be non-negative and finite",
    )


def check_in_open_interval(
    where: str, name: str, value: ArrayLike, low: float, high: float
) -> Array:
    return check(
        where, name, value, lambda xp, x: (x > low) & (x < high), f"must lie in ({low}, {high})"
    )


def check_greater_than(where: str, name: str, value: ArrayLike, low: float) -> Array:
    return check(
        where,
        name,
        value,
        lambda xp, x: xp.isfinite(x) & (x > low),
        f"must be greater than {low} and finite",
    )


def check_shape(where: str, name: str, value: ArrayLike, shape: tuple[int, ...]) -> Array:
    """Convert to a floating array and require an exact shape (always decidable at trace time)."""
    arr = as_float_array(value, name, where)
    if arr.shape != shape:
        raise ValueError(f"{where}: `{name}` must have shape {shape}, got shape {arr.shape}.")
    return arr


def check_scalar(where: str, name: str, value: ArrayLike) -> Array:
    """Convert to a floating array and require shape `()` (always decidable at trace time)."""
    arr = as_float_array(value, name, where)
    if arr.shape != ():
        raise ValueError(f"{where}: `{name}` must be a scalar, got shape {arr.shape}.")
    return arr


def is_real_scalar(x) -> bool:
    """A real number: a Python or NumPy real (not a bool) or a 0-d real array."""
    if isinstance(x, (bool, np.bool_)):
        return False
    if isinstance(x, numbers.Real):
        return True
    dtype = getattr(x, "dtype", None)
    return (
        dtype is not None
        and getattr(x, "ndim", 1) == 0
        and np.issubdtype(dtype, np.number)
        and not np.issubdtype(dtype, np.complexfloating)
    )


def check_flag(where: str, name: str, value) -> bool:
    """A static switch: `True` or `False` (a Python or NumPy bool). `bool(value)` would turn the
    string "False", or any non-empty object, into `True` and silently choose the other model."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{where}: `{name}` must be True or False, got {value!r}.")
    return bool(value)


def check_instance(where: str, name: str, value, kind: type | tuple[type, ...], what: str):
    """`value` if it is an instance of `kind`, else a `ValueError` naming the argument, what it
    must be (`what`, e.g. "a jaxatt.plants.Proximity") and the type it got."""
    if not isinstance(value, kind):
        raise ValueError(f"{where}: `{name}` must be {what}, got {type(value).__name__}.")
    return value


def check_positive_int(where: str, name: str, value, minimum: int = 1) -> int:
    """A static integer at least `minimum` (a count, a size, an index): a Python or NumPy
    integer, not a bool (`True` would silently read as 1) nor a float (`2.5` would be
    truncated, `2.0` would fail later as an index)."""
    rule = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
    if (
        isinstance(value, (bool, np.bool_))
        or not isinstance(value, numbers.Integral)
        or value < minimum
    ):
        raise ValueError(f"{where}: `{name}` must be {rule}, got {value!r}.")
    return int(value)


def check_positive_scalar(where: str, name: str, value: ArrayLike) -> Array:
    """A positive scalar (a band, a span, a limit): a shape `(3,)` value would broadcast and
    fail deep inside a computation, or silently give one result per entry."""
    return check_positive(where, name, check_scalar(where, name, value))


def check_less_than(where: str, low_name: str, low: Array, high_name: str, high: Array) -> None:
    """Require `low < high` for two scalars (a window's ends), checked on the host when both are
    concrete; a traced pair is not checked (NaN fails the rule)."""
    if is_traced(low) or is_traced(high):
        return
    low_host, high_host = np.asarray(low), np.asarray(high)
    if not bool(low_host < high_host):
        raise ValueError(
            f"{where}: `{low_name}` must be less than `{high_name}`, got "
            f"{low_name}={describe(low_host)} and {high_name}={describe(high_host)}."
        )


def check_gain_shape(
    where: str, name: str, value: Array, shapes: tuple[tuple[int, ...], ...] = ((), (3,))
) -> Array:
    """Require one of the allowed `shapes` (default: a scalar or one value per axis)."""
    if value.shape not in shapes:
        allowed = " or ".join("a scalar" if s == () else f"shape {s}" for s in shapes)
        raise ValueError(
            f"{where}: `{name}` must be {allowed}, got shape {value.shape} "
            f"({name}={describe(value) if not is_traced(value) else 'traced'})."
        )
    return value


def check_spd(where: str, name: str, value: ArrayLike) -> Array:
    """A symmetric positive-definite 3x3 matrix (an inertia)."""
    arr = check_shape(where, name, value, (3, 3))

    def predicate(xp, m):
        finite = xp.all(xp.isfinite(m))
        m = xp.where(finite, m, 0.0)
        scale = 1.0 + xp.max(xp.abs(m))
        symmetric = xp.max(xp.abs(m - m.T)) <= 1e-9 * scale
        min_eig = xp.linalg.eigvalsh(0.5 * (m + m.T))[0]
        return finite & symmetric & (min_eig > 0)

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
        lambda xp, q: xp.abs(xp.sqrt(xp.sum(q**2)) - 1) <= tol,
        f"must be a unit quaternion (| ||q|| - 1 | <= {tol:g}); normalize it first",
    )


def check_tree_finite(where: str, name: str, tree) -> None:
    """Raise if a concrete pytree holds a NaN or infinite entry, naming the leaf's path.

    Traced leaves are skipped (their values are unknown until run time).
    """
    for path, leaf in jax.tree_util.tree_leaves_with_path(tree):
        if is_traced(leaf) or not hasattr(leaf, "dtype"):
            continue
        host = np.asarray(leaf)
        if not np.issubdtype(host.dtype, np.floating):
            continue
        bad = ~np.isfinite(host)
        if np.any(bad):
            label = name + jax.tree_util.keystr(path)
            where_bad = np.argwhere(bad)[:5].tolist() if host.ndim else []
            raise ValueError(
                f"{where}: `{label}` must be finite, got {describe(host)}"
                + (f" (non-finite at {where_bad})" if where_bad else "")
                + "."
            )


def check_batched_shape(
    where: str,
    name: str,
    value: ArrayLike,
    shape: tuple[int, ...],
    batch_shape: tuple[int, ...] = (),
) -> Array:
    """Convert to a floating array of shape `(*batch_shape, *shape)`."""
    arr = as_float_array(value, name, where)
    expected = (*batch_shape, *shape)
    if arr.shape != expected:
        what = f"shape {expected}" if not batch_shape else f"shape {expected} (batch first)"
        raise ValueError(f"{where}: `{name}` must have {what}, got shape {arr.shape}.")
    return arr


def check_unit_quaternions(
    where: str,
    name: str,
    value: ArrayLike,
    batch_shape: tuple[int, ...] = (),
    tol: float = UNIT_QUATERNION_TOLERANCE,
) -> Array:
    """Unit quaternions of shape `(*batch_shape, 4)`; a batch names its bad samples."""
    if not batch_shape:
        return check_unit_quaternion(where, name, value, tol)
    arr = check_batched_shape(where, name, value, (4,), batch_shape)
    rule = f"must hold unit quaternions (| ||q|| - 1 | <= {tol:g}); normalize them first"
    if is_traced(arr):
        if _skip_traced_check():
            return arr
        norms = jnp.sqrt(jnp.sum(arr**2, axis=-1))
        return eqx.error_if(arr, ~jnp.all(jnp.abs(norms - 1) <= tol), f"{where}: `{name}` {rule}.")
    norms = np.linalg.norm(np.asarray(arr), axis=-1)
    bad = np.argwhere(~(np.abs(norms - 1) <= tol))
    if bad.size:
        samples = [tuple(int(i) for i in b) if len(b) > 1 else int(b[0]) for b in bad[:10]]
        raise ValueError(
            f"{where}: `{name}` {rule}; samples {samples} are not (norms "
            f"{[float(norms[tuple(b)]) for b in bad[:10]]})."
        )
    return arr
