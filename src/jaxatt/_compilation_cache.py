"""The persistent compilation cache: compile jaxatt's programs once per machine, not per process.

XLA's compile dominates a first call (a Chen 2022 closed loop takes seconds, a tuning step
more). JAX can store compiled executables on disk and reuse them in later processes whose
programs are identical (same code, shapes, dtypes, flags, jax version and device) - but only
programs without host callbacks. jaxatt's compiled programs hold none: failures come back as
integer status codes (`jaxatt.simulation.Status`) and are raised on the host after the program
returns, and arguments are checked on the host before anything is traced (an `eqx.error_if`
remains only for checks of values a *user's* own `jit` traces, e.g. `simulate(..., throw=True)`
called inside `jax.jit`).

`jaxatt.enable_compilation_cache()` turns the cache on for the current process (the CLI does it
by default); see `docs/scaling.md`.
"""

import os
import pathlib

import jax


ENV_VAR = "JAXATT_CACHE_DIR"
"""Environment variable: the cache folder, or `off` to keep the CLI from using a cache."""

_OFF = {"off", "none", "0", "false", "no", ""}


def default_cache_dir() -> pathlib.Path:
    """`$JAXATT_CACHE_DIR` if set, else `$XDG_CACHE_HOME/jaxatt/xla` (`~/.cache/jaxatt/xla`)."""
    env = os.environ.get(ENV_VAR)
    if env is not None and env.strip().lower() not in _OFF:
        return pathlib.Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "jaxatt" / "xla"


def cache_disabled_by_env() -> bool:
    """Whether `JAXATT_CACHE_DIR` asks for no cache (`off`, `none`, `0`, `false`, `no`, empty)."""
    env = os.environ.get(ENV_VAR)
    return env is not None and env.strip().lower() in _OFF


def enable_compilation_cache(
    path: str | os.PathLike | None = None, *, min_compile_time: float = 0.0
) -> pathlib.Path:
    """Turn on JAX's persistent compilation cache for this process; returns its folder.

    Call it once, early (a notebook's first cell, the top of a script); it also works after
    programs were compiled: later compilations use the cache.

    ```python
    import jaxatt
    jaxatt.enable_compilation_cache()            # ~/.cache/jaxatt/xla, or $JAXATT_CACHE_DIR
    ```

    **Arguments:**
    - `path`: the cache folder (created if missing). Default: the environment variable
      `JAXATT_CACHE_DIR`, else `$XDG_CACHE_HOME/jaxatt/xla` (`~/.cache/jaxatt/xla`).
    - `min_compile_time`: programs that compiled faster than this [s] are not written
      (JAX's `jax_persistent_cache_min_compile_time_secs`, whose own default is 1 s). jaxatt
      writes every program by default: a notebook compiles hundreds of small ones (plots,
      metrics, eager operations) at 50-100 ms each on a CPU.

    Entries are keyed by the program, the jax/jaxlib version, XLA flags and the device, so a
    stale entry is never used for a different program; the folder can be deleted at any time.
    The cache is not size-limited by default (JAX's `jax_compilation_cache_max_size`).
    """
    if min_compile_time < 0:
        raise ValueError(
            "enable_compilation_cache: `min_compile_time` must be >= 0 [s], got "
            f"{min_compile_time!r}."
        )
    folder = default_cache_dir() if path is None else pathlib.Path(path).expanduser()
    folder.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_enable_compilation_cache", True)
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", float(min_compile_time))
    # -1: every entry is written whatever its size (0 would let JAX pick a filesystem minimum).
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    _reset()
    return folder


def disable_compilation_cache() -> None:
    """Turn the persistent compilation cache off for this process (entries stay on disk)."""
    jax.config.update("jax_enable_compilation_cache", False)
    _reset()


def _reset() -> None:
    # JAX decides once per process, at the first compilation, whether the cache is used; reset
    # that decision so that the new setting applies to later compilations.
    from jax.experimental.compilation_cache import compilation_cache

    compilation_cache.reset_cache()
