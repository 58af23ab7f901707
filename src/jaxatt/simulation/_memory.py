r"""Refusing a run whose saved trajectories cannot fit in memory, before anything compiles.

A saved trajectory holds, per sample and per save, the closed loop's state, its signals and
the time: $B = n_\text{samples}\,(n_\text{saves})\,b_\text{record}$ bytes. A long horizon
saved at every step (the default `save_every=1`) can ask for more than the machine has; XLA
would then fail to allocate after compiling, or, on a host that overcommits memory, the
process would grow until the kernel kills it (a notebook's kernel dies without a message).
[`check_saved_memory`][] compares $B$ with the memory of the default backend before the run
compiles and refuses, naming the arguments that set it.

Only the saved trajectories are counted: the program's other buffers (the loop's carry, the
metrics, XLA's temporaries, reverse-mode residuals) come on top, so a run that passes can
still fail; one that is refused cannot succeed.
"""

import os

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu

from ._settings import Simulation


def memory_limit() -> int | None:
    """Bytes of memory of the default backend's first device: a GPU's `bytes_limit` from
    `Device.memory_stats()`, or the host's physical memory (`os.sysconf`) for a CPU; `None`
    where neither is known (the check is then skipped)."""
    stats = jax.devices()[0].memory_stats() or {}
    if "bytes_limit" in stats:
        return int(stats["bytes_limit"])
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # not a POSIX host
        return None


def _bytes(tree) -> int:
    return sum(leaf.size * leaf.dtype.itemsize for leaf in jtu.tree_leaves(tree))


def record_bytes(closed_loop, x0, t0: float) -> int:
    """Bytes of one saved record of one sample: the loop state `closed_loop.init(t0, x0)`, the
    signals `closed_loop.signals(t0, state, None)` and the time (shapes only: `jax.eval_shape`,
    nothing runs or compiles). `closed_loop` and `x0` may hold `jax.ShapeDtypeStruct`s."""

    def record(loop, x):
        t = jnp.asarray(t0, jnp.result_type(*jtu.tree_leaves(x)))
        y = loop.init(t, x)
        return t, y, loop.signals(t, y, None)

    dynamic, static = eqx.partition(
        closed_loop, lambda leaf: eqx.is_array(leaf) or isinstance(leaf, jax.ShapeDtypeStruct)
    )
    return _bytes(jax.eval_shape(lambda d, x: record(eqx.combine(d, static), x), dynamic, x0))


def _gigabytes(n: int) -> str:
    return f"{n / 2**30:.3g} GiB"


def check_saved_memory(
    where: str, closed_loop, x0, sim: Simulation, *, samples: int = 1, remedy: str = ""
) -> None:
    """Raise `ValueError` before compiling if `samples` saved trajectories of `sim` cannot fit
    in [`memory_limit`][].

    `x0` is one sample's initial state (arrays or `jax.ShapeDtypeStruct`s) and `closed_loop`
    one sample's loop. The cheap bound (the saved initial states alone) is taken first; the
    loop state and signals are traced (`jax.eval_shape`) only when that bound reaches 1/64 of
    the memory, so an ordinary run pays nothing. `remedy` ends the message with the caller's
    own way out (e.g. ", or leave `keep_trajectories` off"). Only shapes are read, so it runs
    under an outer `jit`, `vmap` or `grad` too (inside `vmap`, `simulate` sees one sample:
    the batch is the caller's)."""
    limit = memory_limit()
    if limit is None:
        return
    saves = sim.n_steps // sim.save_every + 1
    if samples * saves * _bytes(x0) * 64 < limit:
        return
    # Shapes only, so the check also runs inside an outer jit/vmap/grad (tracers).
    closed_loop, x0 = jtu.tree_map(
        lambda a: jax.ShapeDtypeStruct(a.shape, a.dtype) if eqx.is_array(a) else a,
        (closed_loop, x0),
    )
    needed = samples * saves * record_bytes(closed_loop, x0, sim.t0)
    if needed <= limit:
        return
    raise ValueError(
        f"{where}: the saved trajectories need {_gigabytes(needed)} ({samples} sample(s) x "
        f"{saves} saves x {needed // (samples * saves)} bytes), more than the "
        f"{_gigabytes(limit)} of memory of this {jax.devices()[0].platform.upper()}: raise "
        f"`save_every` (now {sim.save_every}), shorten `t1 - t0` or raise `dt`{remedy}."
    )
