"""jaxatt's compiled entry points: one `eqx.filter_jit` per program and compiler options.

XLA compiler options (see [`Performance.compiler_options`][jaxatt.simulation.Performance])
belong to `jax.jit`, not to the traced program, so an entry point such as `simulate` or
`monte_carlo` picks its compiled function by the options its resolved `Performance` asks
for. Each (function, options) pair is built once per process and keeps `eqx.filter_jit`'s
cache of compiled programs.

JAX accepts compiler options on a top-level `jax.jit` only: an entry point called while an
enclosing program is being traced (inside the caller's `jit`, `grad`, `vmap`, ...) becomes
part of that program and compiles with the caller's options, so it passes none.
"""

import functools
from collections.abc import Callable

import equinox as eqx
import jax.numpy as jnp
import jax.tree_util as jtu
from jaxtyping import PyTree

from .._validation import host_checked_program, is_traced
from ._performance import Performance


@functools.cache
def _jit(fn: Callable, options: tuple[tuple[str, object], ...]) -> Callable:
    return eqx.filter_jit(host_checked_program(fn), compiler_options=dict(options) or None)


def inside_trace(inputs: PyTree) -> bool:
    """Whether a call with `inputs` is being traced into an enclosing program: one of its
    array leaves is a tracer, or an enclosing `jit` is staging every new array."""
    return any(is_traced(x) for x in jtu.tree_leaves(inputs)) or is_traced(jnp.zeros(()))


def compiled(fn: Callable, performance: Performance, inputs: PyTree) -> Callable:
    """`fn` traced under `host_checked` (its inputs were checked on the host) and compiled
    with `eqx.filter_jit` and the XLA compiler options of `performance` (resolved) on JAX's
    default backend; without options when called with traced `inputs` or inside a `jit`."""
    options = {} if inside_trace(inputs) else performance.compiler_options()
    return _jit(fn, tuple(sorted(options.items())))
