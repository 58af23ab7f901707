"""Helpers shared by `bench_gradient.py`, `bench_scaling.py`, `bench_compile.py`,
`bench_roofline.py`, `bench_lapack_free.py` and `bench_libm_free.py`: command-line flags,
machine description, the Chen 2022 M1 set-up, previous implementations restored in-process,
XLA's cost and memory analyses, and the end of a run (load average, JSON, exit code).

The timing convention (ahead-of-time `f.lower(*args).compile()` timed alone, one warm-up call,
then `min(timeit.repeat(lambda: jax.block_until_ready(f(x)), number=1, repeat=R))`, fewer
repeats when they would take over `--max-seconds`), the scenario checks and the initial states
are those of `bench_montecarlo.py` and `bench_quick.py` (`_quick.py`), imported rather than
copied. The jaxatt programs these scripts time run through `jaxatt.montecarlo.monte_carlo`
(`bench_montecarlo.make_jaxatt`, `_quick.JAXATT_CALLS`). Like `_quick.py`, a plain module: the
scripts run with benchmarks/ first on `sys.path`.

Nothing here creates a JAX array at import: each script enables float64 (or not) first.
"""

import argparse
import contextlib
import json
import os
import pathlib
import resource
import sys
import time

import _quick
import bench_montecarlo as montecarlo
import jax
import numpy as np


HERE = pathlib.Path(__file__).resolve().parent
RESULTS_DIR = HERE / "results"

# Re-exported: one definition of the conventions for every benchmark (`bench_quick.py` included).
time_jax = _quick.time_jax
run_time = _quick.run_time
default_save_every = _quick.default_save_every
fmt = montecarlo.fmt


def compile_timed(f, args) -> tuple:
    """`(compiled, seconds)`: ahead-of-time `f.lower(*args).compile()` (trace, lower, XLA
    compile; no run), for a `jax.jit` or `eqx.filter_jit` function."""
    start = time.perf_counter()
    compiled = f.lower(*args).compile()
    return compiled, time.perf_counter() - start


def time_compiled(compiled, args, repeat: int, max_seconds: float) -> tuple:
    """`(run_s, output, timed_repeats)` of a compiled program, as `time_jax` times it: one
    warm-up call, then the min over `repeat` timed calls, fewer when they would take over
    `max_seconds` (0 repeats: the warm-up call is the measurement)."""
    start = time.perf_counter()
    out = jax.block_until_ready(compiled(*args))
    warm = time.perf_counter() - start
    n = min(repeat, int(max_seconds // warm))
    run = run_time(lambda: jax.block_until_ready(compiled(*args)), n) if n else warm
    return run, out, n


@contextlib.contextmanager
def restored(replacements):
    """Set `(owner, name, value)` attributes for the duration, with fresh compile caches."""
    saved = [(owner, name, getattr(owner, name)) for owner, name, _ in replacements]
    for owner, name, value in replacements:
        setattr(owner, name, value)
    jax.clear_caches()
    try:
        yield
    finally:
        for owner, name, value in saved:
            setattr(owner, name, value)
        jax.clear_caches()


def relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a - b| / max(|a|, 1e-12) over the finite entries; inf if the two disagree on
    which entries are finite or on their values there (NaN equals NaN: a failed sample's
    peak is NaN in both)."""
    finite = np.isfinite(a)
    if not np.array_equal(finite, np.isfinite(b)) or not np.array_equal(
        a[~finite], b[~finite], equal_nan=True
    ):
        return float("inf")
    scale = np.maximum(np.abs(a[finite]), 1e-12)
    return float(np.max(np.abs(a[finite] - b[finite]) / scale, initial=0.0))


def tree_relative_difference(a, b) -> float:
    """Largest |a - b| / |b| over the finite entries of two pytrees (0 where both are 0); inf
    where their non-finite entries differ."""
    worst = 0.0
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
        finite = np.isfinite(y)
        if not np.array_equal(finite, np.isfinite(x)) or not np.array_equal(
            x[~finite], y[~finite], equal_nan=True
        ):
            return float("inf")
        scale = np.where(y[finite] == 0, 1.0, np.abs(y[finite]))
        worst = max(worst, float(np.max(np.abs(x[finite] - y[finite]) / scale, initial=0.0)))
    return worst


def round_robin(calls: dict, repeat: int) -> dict:
    """`{name: seconds}`: the fastest of `repeat` runs of each call, run in turns (one of each
    per round, after the caller's warm-up), so that the machine's changing speed touches all
    of them alike. A call returns JAX arrays; each run waits for them."""
    best = dict.fromkeys(calls, float("inf"))
    for _ in range(repeat):
        for name, call in calls.items():
            best[name] = min(best[name], run_time(lambda: jax.block_until_ready(call()), 1))
    return best


# ---------------------------------------------------------------------------------------------
# Flags.


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """`--dt --dtype --repeat --max-seconds --seed --out` (see `finish_arguments`)."""
    parser.add_argument("--dt", type=float, default=1e-3, help="RK4 step [s]")
    parser.add_argument(
        "--dtype",
        choices=["float64", "float32"],
        default="float64",
        help="working precision (x64 is enabled at start-up for float64)",
    )
    parser.add_argument("--repeat", type=int, default=3, help="timeit repeats per measurement")
    parser.add_argument(
        "--max-seconds",
        type=float,
        default=20.0,
        help="time budget for the repeats of one measurement (long runs repeat less)",
    )
    parser.add_argument("--seed", type=int, default=0, help="key of the initial states")
    parser.add_argument(
        "--out",
        default=None,
        help="JSON file; default benchmarks/results/<benchmark>.json (<benchmark>_float32.json "
        "for float32)",
    )


def finish_arguments(
    parser: argparse.ArgumentParser, args: argparse.Namespace, horizons, out_name: str
) -> argparse.Namespace:
    """Validate the common flags and every horizon in `horizons`; fill in `args.out`
    (benchmarks/results/`out_name`, with '_float32' before '.json' for float32)."""
    if args.dt <= 0:
        parser.error("--dt must be positive")
    for horizon in horizons:
        ratio = horizon / args.dt
        if horizon <= 0 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            parser.error(f"horizon {horizon} must be a positive whole multiple of --dt")
    if args.repeat < 1 or args.max_seconds <= 0:
        parser.error("--repeat and --max-seconds must be positive")
    if args.out is None:
        name = out_name
        if args.dtype == "float32":
            name = name.replace(".json", "_float32.json")
        args.out = str(RESULTS_DIR / name)
    return args


def results_path(args, name: str) -> pathlib.Path:
    """A figure next to the JSON file: `name` with the JSON's dtype suffix, if any."""
    out = pathlib.Path(args.out)
    if args.dtype == "float32":
        name = name.replace(".", "_float32.", 1)
    return out.parent / name


def enable_precision(dtype: str) -> None:
    """float64 needs `jax_enable_x64` before any array is built (DESIGN.md, Numerics)."""
    if dtype == "float64":
        jax.config.update("jax_enable_x64", True)


def steps_of(horizon: float, dt: float) -> int:
    return round(horizon / dt)


# ---------------------------------------------------------------------------------------------
# The machine.


def cpu_info() -> dict:
    """Model, SIMD/FMA flags, CPU counts, clock and memory from /proc and /sys (Linux).

    `clock_ghz` is the maximum of cpufreq when the kernel exposes it (not in most VMs),
    otherwise the "cpu MHz" /proc/cpuinfo reports for CPU 0 (the current clock, which a VM
    usually pins at the nominal one).
    """
    info = {
        "model": "unknown",
        "flags": [],
        "logical_cpus": os.cpu_count(),
        "usable_cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "clock_ghz": None,
        "clock_source": None,
        "mem_total_gib": None,
        "mem_available_gib": None,
    }
    try:
        text = pathlib.Path("/proc/cpuinfo").read_text()
    except OSError:
        text = ""
    for line in text.splitlines():
        key, _, value = (part.strip() for part in line.partition(":"))
        if key == "model name" and info["model"] == "unknown":
            info["model"] = value
        elif key == "flags" and not info["flags"]:
            wanted = ("sse2", "avx", "avx2", "fma", "avx512f", "avx512dq", "avx512vl")
            info["flags"] = [f for f in wanted if f in value.split()]
        elif key == "cpu MHz" and info["clock_ghz"] is None:
            info["clock_ghz"] = float(value) / 1000
            info["clock_source"] = "/proc/cpuinfo 'cpu MHz' (current clock of CPU 0)"
    try:
        khz = pathlib.Path("/sys/devices/system/cpu/cpu0/cpufreq/cpuinfo_max_freq").read_text()
        info["clock_ghz"] = int(khz) / 1e6
        info["clock_source"] = "cpufreq cpuinfo_max_freq (maximum, turbo included)"
    except (OSError, ValueError):
        pass
    try:
        for line in pathlib.Path("/proc/meminfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key in ("MemTotal", "MemAvailable"):
                name = "mem_total_gib" if key == "MemTotal" else "mem_available_gib"
                info[name] = int(value.split()[0]) / 2**20
    except OSError:
        pass
    return info


def machine_meta() -> dict:
    """bench_montecarlo's metadata (date, devices, device kind, versions, load average at the
    start) plus the CPU description above, diffrax/optax versions and the JAX settings."""
    import diffrax
    import optax

    meta = montecarlo.machine_meta()
    meta["versions"].update({"diffrax": diffrax.__version__, "optax": optax.__version__})
    meta["cpu"] = cpu_info()
    meta["backend"] = jax.default_backend()
    meta["jax_enable_x64"] = bool(jax.config.jax_enable_x64)
    meta["jax_compilation_cache_dir"] = jax.config.jax_compilation_cache_dir
    meta["XLA_FLAGS"] = os.environ.get("XLA_FLAGS")
    meta["jaxatt_file"] = sys.modules["jaxatt"].__file__  # which copy of the library ran
    return meta


def print_meta(meta: dict, description: str) -> None:
    cpu = meta["cpu"]
    print(
        "devices:", meta["devices"], "| kind:", meta["device_kind"], "| backend:", meta["backend"]
    )
    print(
        f"CPU: {cpu['model']}, {cpu['logical_cpus']} logical CPUs ({cpu['usable_cpus']} usable), "
        f"{fmt(cpu['clock_ghz'])} GHz, flags {' '.join(cpu['flags']) or '-'}, "
        f"{fmt(cpu['mem_total_gib'])} GiB RAM ({fmt(cpu['mem_available_gib'])} available)"
    )
    print("versions:", ", ".join(f"{k} {v}" for k, v in meta["versions"].items()))
    print(
        "load average (1, 5, 15 min) at start: "
        + ", ".join(f"{x:.2f}" for x in meta["load_average_start"])
        + f"; EQX_ON_ERROR={meta['EQX_ON_ERROR']}, XLA_FLAGS={meta['XLA_FLAGS']}"
    )
    print(description, flush=True)


def finish(result: dict, meta: dict, out: str, ok: bool) -> int:
    """Print the checks' verdict and the load average, write the JSON; the exit code."""
    meta["load_average_end"] = os.getloadavg()
    print("check:", "PASSED" if ok else "FAILED")
    print(
        "load average (1, 5, 15 min) at start "
        + ", ".join(f"{x:.2f}" for x in meta["load_average_start"])
        + ", at end "
        + ", ".join(f"{x:.2f}" for x in meta["load_average_end"])
        + f" ({meta['cpu_count']} CPUs; above that, other processes shared the cores)"
    )
    result = {**result, "meta": meta, "passed": ok}
    path = pathlib.Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=2, default=_json_default) + "\n")
    print(f"wrote {path}")
    return 0 if ok else 1


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, pathlib.Path):
        return str(x)
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def device_peak_mib() -> float | None:
    """Peak bytes in use on the default device [MiB] where the backend reports it (GPU, TPU;
    not XLA:CPU, whose buffers count in the RSS)."""
    stats = jax.devices()[0].memory_stats() or {}
    peak = stats.get("peak_bytes_in_use")
    return None if peak is None else peak / 2**20


def max_rss_mib() -> float:
    """Peak resident set size of this process so far [MiB] (`ru_maxrss`: KiB on Linux)."""
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / (2**20 if sys.platform == "darwin" else 2**10)


# ---------------------------------------------------------------------------------------------
# The scenario.


def m1_setup(seed: int, n: int, dtype):
    """Chen 2022's M1 closed loop (checked against `_reference.py`) and `n` initial
    states `chen2022_tuning.initial_states(jr.key(seed), n)` as a `QuaternionState` of
    `dtype`. The loop's arrays are in the default float dtype: call after `enable_precision`."""
    import jax.numpy as jnp

    from jaxatt.plants import QuaternionState
    from jaxatt.scenarios import chen2022_two_phase_power as chen

    loop = chen.build("M1")
    montecarlo.check_scenario(loop)
    q, omega = montecarlo.initial_states(seed, n, dtype)
    return loop, QuaternionState(jnp.asarray(q), jnp.asarray(omega))


def take(tree, n: int):
    """The first `n` samples of a batched pytree."""
    return jax.tree_util.tree_map(lambda x: x[:n], tree)


# ---------------------------------------------------------------------------------------------
# XLA's analyses of a compiled program.


def _jax_compiled(compiled):
    """The `jax.stages.Compiled` inside an `eqx.filter_jit(...).lower(...).compile()`."""
    inner = getattr(compiled, "compiled", None)
    return inner if isinstance(inner, jax.stages.Compiled) else compiled


def xla_cost(compiled) -> dict:
    """`flops`, `transcendentals` and `bytes accessed` from `compiled.cost_analysis()`.

    A `jax.stages.Lowered` works too: its counts are those of the HLO before XLA's optimizations
    (every operation once, every intermediate materialized), while a compiled program's count
    what runs after fusion (elementwise producers that fusion duplicates are counted in each
    copy). XLA's HloCostAnalysis counts a while loop's body (a `lax.scan`) **once**, whatever
    its trip count: divide by the step count only for loop-free programs.
    """
    cost = _jax_compiled(compiled).cost_analysis()
    if isinstance(cost, (list, tuple)):  # older jaxlibs: one dict per HLO module
        cost = cost[0] if cost else {}
    cost = cost or {}
    return {
        "flops": float(cost.get("flops", float("nan"))),
        "transcendentals": float(cost.get("transcendentals", 0.0)),
        "bytes_accessed": float(cost.get("bytes accessed", float("nan"))),
    }


def xla_memory(compiled) -> dict:
    """XLA's static buffer sizes of a compiled program [bytes] (`memory_analysis()`)."""
    stats = _jax_compiled(compiled).memory_analysis()
    if stats is None:
        return {}
    names = (
        "argument_size_in_bytes",
        "output_size_in_bytes",
        "alias_size_in_bytes",
        "temp_size_in_bytes",
        "generated_code_size_in_bytes",
    )
    return {name: int(getattr(stats, name, 0)) for name in names}
