"""jaxatt's compiled entry points: one `eqx.filter_jit` per program and compiler options.

XLA compiler options (see [`Performance.compiler_options`][jaxatt.simulation.Performance])
belong to `jax.jit`, not to the traced program, so an entry point such as `simulate` or
`monte_carlo` picks its compiled function by the options its resolved `Performance` asks
for. Each (function, options) pair is built once per process and keeps `eqx.filter_jit`'s
cache of compiled programs.
"""

import functools
from collections.abc import Callable

import equinox as eqx

from .._validation import host_checked_program
from ._performance import Performance


@functools.cache
def _jit(fn: Callable, options: tuple[tuple[str, object], ...]) -> Callable:
    return eqx.filter_jit(host_checked_program(fn), compiler_options=dict(options) or None)


def compiled(fn: Callable, performance: Performance) -> Callable:
    """`fn` traced under `host_checked` (its inputs were checked on the host) and compiled
    with `eqx.filter_jit` and the XLA compiler options of `performance` (resolved) on JAX's
    default backend."""
    return _jit(fn, tuple(sorted(performance.compiler_options().items())))
