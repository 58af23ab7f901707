"""Small time loops compiled as one XLA:CPU kernel: [`enable_small_loop_kernels`][].

XLA:CPU runs a compiled program as a sequence of *thunks*, one per kernel (a fusion of
elementwise operations, a copy, a loop), each dispatched by its runtime at a cost of tens of
nanoseconds. A time loop over one trajectory or a few dozen samples holds a few hundred such
kernels per step, each on a few dozen numbers, so dispatch, not arithmetic, sets its speed.
XLA:CPU's `SmallWhileLoopHoistingPass` compiles a `while` loop whose body and condition access
fewer than `xla_cpu_small_while_loop_byte_threshold` bytes per iteration (XLA's cost analysis
counts one iteration) into a single kernel, with no dispatch inside. XLA's default threshold,
1024 bytes, admits none of jaxatt's time loops; 10^6 bytes admits the time loop of one
trajectory of every family measured but Zhang 2017's fractional law (whose memory of past steps
is larger). XLA never folds a loop that holds a matrix product (`dot`) or a library call,
as the plain vmapped batch's loop does, and batches of 128 samples and more ran as before.

The threshold is a process-wide option of XLA's (`XLA_FLAGS`, read once, when JAX's CPU
backend starts), not one that `jax.jit(...).lower(...).compile(compiler_options=...)` accepts,
so it must be set before the first computation. Results are those of XLA's default
configuration up to rounding (the same HLO, other machine code: 1e-17 to 1e-14 relative on
the final states of one trajectory per family, `benchmarks/bench_single.py
--small-loop-kernels`; `tests/simulation/test_small_loop_kernels.py` checks Chen 2022's).

jaxlib before 0.7.2 aborts the process on some folded loops (those holding an operation XLA
splits across threads, such as the random bits of `jax.random.uniform(key, (1000, 4))`), so
[`enable_small_loop_kernels`][] refuses to set the option there: see `FIRST_SAFE_JAXLIB`.
"""

import importlib.metadata
import os
import re

import jax
import jax.numpy as jnp
import numpy as np


OPTION = "xla_cpu_small_while_loop_byte_threshold"
"""The XLA:CPU backend option, set through `--xla_backend_extra_options` in `XLA_FLAGS`."""

DEFAULT_BYTES_PER_ITERATION = 1_000_000
"""[`enable_small_loop_kernels`][]'s default threshold [bytes accessed per loop iteration]."""

MIN_BYTES_PER_ITERATION = 4096
"""The smallest threshold [`enable_small_loop_kernels`][] sets: its check compiles a loop that
accesses between 1024 (XLA's default threshold) and 4096 bytes per iteration."""

FIRST_SAFE_JAXLIB = (0, 7, 2)
"""The first jaxlib whose XLA:CPU runs every loop the threshold folds. Before it, a folded loop
that holds an operation XLA splits across threads aborts the whole process: with the
threshold at 10^6, `jax.random.uniform(jax.random.key(1), (1000, 4))` died in jaxlib 0.6.2
("runtime_fork_join.cc:83] Check failed: run_options != nullptr") and in 0.7.0 and 0.7.1
("LLVM ERROR: Program used external function '__xla_cpu_runtime_ParallelForkJoin' which could
not be resolved!"), and ran in 0.7.2, 0.8.0 and 0.10.2 (2026-12-07, one fresh virtual
environment per version; jaxatt's attitude samplers hit it at 1000 samples)."""

_SETTING = re.compile(rf"{OPTION}=([^,\s'\"]*)")


def jaxlib_version() -> tuple[int, ...]:
    """The installed jaxlib's release as integers, e.g. `(0, 10, 2)` (read from its metadata;
    a suffix such as `.dev20251201` is dropped)."""
    text = importlib.metadata.version("jaxlib")
    found = re.match(r"(\d+)\.(\d+)\.(\d+)", text)
    if found is None:
        raise RuntimeError(f"cannot read jaxlib's version from {text!r}")
    return tuple(int(part) for part in found.groups())


def threshold_in_flags(flags: str) -> int | None:
    """The small-loop threshold [bytes] that an `XLA_FLAGS` string sets (its last setting), or
    `None` when it sets none."""
    found = _SETTING.findall(flags)
    if not found:
        return None
    try:
        return int(found[-1])
    except ValueError:
        raise ValueError(
            f"XLA_FLAGS sets {OPTION} to {found[-1]!r}, which is not an integer number of bytes."
        ) from None


def without_threshold(flags: str) -> str:
    """An `XLA_FLAGS` string with every option that sets the small-loop threshold removed (the
    whole `--xla_backend_extra_options=...` token that holds it): what a child process gets to
    start with XLA's default threshold."""
    return " ".join(token for token in flags.split() if OPTION not in token)


def _probe(x):
    return jax.lax.fori_loop(0, 3, lambda i, c: jnp.sin(c) * c + 1.0, x)


def small_loops_compile_as_one_kernel() -> bool:
    """Whether XLA:CPU, in this process, compiles a loop accessing between 1024 and 4096 bytes
    per iteration as one kernel (it does not under XLA's default threshold). Compiles one
    small program on the CPU device; starts JAX's backends if nothing had."""
    cpu = jax.devices("cpu")[0]
    x = jax.device_put(np.zeros(256, np.float32), cpu)
    text = jax.jit(_probe).lower(x).compile().as_text()
    return 'xla_cpu_small_call="true"' in text


def enable_small_loop_kernels(
    bytes_per_iteration: int = DEFAULT_BYTES_PER_ITERATION,
) -> int:
    """Let XLA:CPU compile small time loops (one trajectory, small batches) as one kernel each;
    returns the threshold in effect [bytes accessed per loop iteration].

    Call it **before the first JAX computation** of the process: the first cell of a notebook,
    the top of a script (importing jax and jaxatt first is fine, except with optimistix older
    than 0.1, which computes when diffrax imports it: there, set `XLA_FLAGS` before Python
    starts, on a jaxlib of at least 0.7.2). It needs jaxlib 0.7.2 or later
    (`FIRST_SAFE_JAXLIB`: older ones abort the process on some folded loops). It appends
    `--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=N` to the environment
    variable `XLA_FLAGS`, which JAX's CPU backend reads once when it starts, then compiles a
    small probe loop to check that the setting took effect. Child processes inherit the
    variable. Where `XLA_FLAGS` already sets the threshold, that setting is kept and returned.

    ```python
    import jax
    import jaxatt

    jaxatt.enable_small_loop_kernels()          # before anything is computed
    jax.config.update("jax_enable_x64", True)
    ```

    Measured on a 2-core AVX-512 Xeon, float64, the default threshold (benchmarks/README.md,
    "One kernel per small loop"): one trajectory of each family 1.06-5.9x faster per step
    (Chen 2022 M1 2.4x), the default `monte_carlo` call 1.9x at 1 sample and 1.3-2.6x at 32,
    unchanged from 128 to 10^4 samples; the first call of a large closed loop (trace and
    compile) up to 1.43x longer. Numbers agree with XLA's default configuration to rounding
    (the machine code differs, not the program), but a tuning path that crosses a chaotic
    regime (Chen 2022's chattering penalty) can end at other gains.

    **Arguments:**
    - `bytes_per_iteration`: loops whose body accesses fewer bytes per iteration are compiled
      as one kernel; an integer of at least 4096.

    **Raises:**
    - `ValueError`: a `bytes_per_iteration` that is not an integer of at least 4096, or an
      `XLA_FLAGS` whose threshold is not an integer.
    - `RuntimeError`: a jaxlib older than 0.7.2 (`FIRST_SAFE_JAXLIB`: its XLA:CPU aborts the
      process on some folded loops), refused before anything changes, even where `XLA_FLAGS`
      already sets the threshold; or the check found loops still compiled as separate
      kernels, because JAX's CPU backend had started before the call (`XLA_FLAGS` is then
      restored as it was).
    """
    if (
        isinstance(bytes_per_iteration, bool)
        or not isinstance(bytes_per_iteration, (int, np.integer))
        or bytes_per_iteration < MIN_BYTES_PER_ITERATION
    ):
        raise ValueError(
            "enable_small_loop_kernels: `bytes_per_iteration` must be an integer of at least "
            f"{MIN_BYTES_PER_ITERATION}, got {bytes_per_iteration!r}."
        )
    before = os.environ.get("XLA_FLAGS")
    existing = threshold_in_flags(before or "")
    found = jaxlib_version()
    if found < FIRST_SAFE_JAXLIB:
        raise RuntimeError(_unsafe_jaxlib(found, existing))
    if existing is not None:
        # The user's own setting wins; below 4096 bytes the probe cannot tell it from XLA's.
        if existing >= MIN_BYTES_PER_ITERATION and not small_loops_compile_as_one_kernel():
            raise RuntimeError(_too_late(f"XLA_FLAGS sets {OPTION}={existing}, but"))
        return existing
    setting = f"--xla_backend_extra_options={OPTION}={int(bytes_per_iteration)}"
    os.environ["XLA_FLAGS"] = f"{before} {setting}" if before and before.strip() else setting
    if not small_loops_compile_as_one_kernel():
        if before is None:
            del os.environ["XLA_FLAGS"]
        else:
            os.environ["XLA_FLAGS"] = before
        raise RuntimeError(_too_late("after setting XLA_FLAGS,"))
    return int(bytes_per_iteration)


def _unsafe_jaxlib(found: tuple[int, ...], existing: int | None) -> str:
    version, safe = (".".join(map(str, v)) for v in (found, FIRST_SAFE_JAXLIB))
    advice = (
        f"XLA_FLAGS sets {OPTION}={existing} in this process: remove it, or upgrade"
        if existing is not None
        else "Small loops stay separate kernels; to have them as one, upgrade"
    )
    return (
        f"enable_small_loop_kernels: jaxlib {version} aborts the process on some loops "
        "compiled as one kernel (those holding an operation XLA splits across threads: "
        f"jax.random.uniform(key, (1000, 4)) does); jaxlib >= {safe} runs them. "
        f"{advice} jax and jaxlib to >= {safe}."
    )


def _too_late(what: str) -> str:
    return (
        f"enable_small_loop_kernels: {what} XLA:CPU still compiles small loops as separate "
        "kernels: JAX's CPU backend had already started in this process, and it reads "
        "XLA_FLAGS only once. Call enable_small_loop_kernels() before the first JAX "
        "computation (the first cell of a notebook, the top of a script); with optimistix "
        "older than 0.1 (which diffrax 0.7.0 accepts) importing jaxatt itself computes, so "
        "there start Python with "
        f"XLA_FLAGS=--xla_backend_extra_options={OPTION}={DEFAULT_BYTES_PER_ITERATION}."
    )
