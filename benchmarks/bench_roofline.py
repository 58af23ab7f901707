"""Roofline of the batched Chen 2022 M1 closed loop: FLOPs and bytes per RK4 step from XLA's
cost analysis, achieved FLOP/s, and this machine's compute and memory-bandwidth roofs.

**Cost per step.** XLA's `compiled.cost_analysis()` counts the body of a while loop (a
`lax.scan`) **once**, whatever its trip count (checked in-run: the programs of `k` and `2k`
steps report the same FLOPs), so dividing a k-step program's count by k would be wrong. Instead
the step loop's body is compiled on its own: `jax.make_jaxpr` of the batched function doing
`k = --cost-steps` steps in one save interval, the scan of length k whose body holds no other
scan (the time loop over steps), its body jaxpr turned back into a function
(`jax.extend.core.jaxpr_as_fun`), jitted, lowered on the body's input shapes and compiled
alone: its `cost_analysis()` (flops, transcendentals, bytes accessed) is one RK4 step of the
whole batch, divided by the batch for one state-step. Two FLOP counts are kept: *executed*,
the compiled body's (what runs: XLA's loop fusion duplicates elementwise producers into each
consumer, and each copy counts), and *written*, the same body's HLO before optimization (each
operation of the program once: the useful work). "bytes accessed" is the compiled body's sum
over its kernels of the bytes they read and write (an upper bound of the memory traffic when
the batch's working set stays in cache). Time-only terms (J(t), d(t), omega_d(t)) are shared
by the batch, so the per-sample cost falls slightly with the batch.

Programs, each at every batch in `--batches`:

- `jaxatt monte_carlo_plain`: `bench_montecarlo.make_jaxatt("monte_carlo_plain", ...)`,
  `eqx.filter_jit` of `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=1e-3,
  save_every=steps/10, keep_trajectories=True, performance=Performance(scalarize=False))` of
  `jaxatt.scenarios.chen2022_two_phase_power.build("M1")` (classic RK4, 30 N m saturation),
  initial states `jaxatt.scenarios.chen2022_tuning.initial_states`: the plain vmapped program;
- `jaxatt monte_carlo`: `make_jaxatt("monte_carlo", ...)`, the same call with monte_carlo's
  default performance options (scalarized on CPU from 1000 samples; `--jaxatt-calls` picks
  the jaxatt programs);
- `hand scan`: `_reference.make_hand_scan` (`benchmarks/_reference.py`: the same equations
  written elementwise, one `lax.scan`, not jaxatt code).

**Pinned processes** (`--processes N`, N > 1): each jaxatt program at each batch is also run
as N processes of `batch / N` samples each (consecutive slices of the same batch), process i
pinned to core i (`os.sched_setaffinity` in the child before JAX starts its CPU client,
whose threads inherit the pin: XLA sees one core and splits no kernel), each compiling and
warming up its own program first; then each timed round sends all of them "go" at once and
waits until all have finished (the round's wall time, min over `--repeat` rounds). This is
what `monte_carlo` does under `jax.distributed` with one process per core (docs/scaling.md;
`bench_devices.py` times that recipe itself, with its gathers): one single-device program
per core, no communication during the loop. The row's FLOPs are N x the cost of one
process's step (cut from the program of `batch / N` samples as above), so its rates and
fractions of the derived peak are of the whole machine. Checked: the processes' final states
equal the one-process program's (1e-9; float32 1e-4).

**Chunks** (`--batch-size B`): the timed jaxatt runs pass `batch_size=B` to `monte_carlo`,
which runs each process's batch as a `lax.map` over chunks of B samples (one chunk's operands
can then stay in the L2 cache). The step's counts are still cut from the unchunked program of
the same batch: the chunked program runs the same per-sample operations on B samples at a time
(so per state-step the counts are the same), and its map loop would hide the step loop.

**Achieved FLOP/s** = FLOPs per batch step x steps / run time over `--horizon` (compile timed
apart; one warm-up call, then the min of `timeit.repeat(..., number=1, repeat=R)`), executed
and useful (written). The run includes the saves (11 of them), which the per-step count leaves
out.

**Roofs.** Compute, derived: cores x clock x float64 SIMD lanes (8 with avx512f, 4 with avx2
or avx, 2 with sse2; twice that for float32) x FMA units per core (`--fma-units`, default 2:
an assumption, /proc/cpuinfo does not say; Intel Xeon Silver/Bronze with AVX-512 have 1) x 2
(an FMA is two FLOPs), from `/proc/cpuinfo` (`--clock-ghz` overrides the reported clock; the
AVX frequency drop is ignored). Compute, measured: `jnp.dot` of two `--matmul-size` (2048)
square matrices, 2 n^3 FLOPs. Bandwidth, measured: `x = x + y` repeated in a `lax.fori_loop`
(in place, 3 arrays of traffic per pass) on arrays of `--bandwidth-mib` MiB (memory) and of
`--cache-kib` KiB (cache-resident: XLA's bytes accessed of a batched step are mostly cache
traffic). Also measured: the cost of one `pow` per element, since the two-phase law calls
`pow` per axis per RK4 stage and the roofline counts transcendentals apart from FLOPs.

Figure: next to the JSON file, with its name (`benchmarks/results/roofline.png` by default;
log-log; the compute roofs, derived and matmul, under the measured bandwidth roof; each
program at each batch, filled at its executed FLOPs, hollow at its written ones).

**Checks** (exit code 1 when one fails): exactly one step loop found in each program and its
FLOPs are positive; the hand scan's final states equal jaxatt's at every batch (1e-9; float32
1e-4); no jaxatt sample has a non-finite state.

**Recorded defaults** (estimated 4 to 6 minutes on 2 cores; each of the three programs is
compiled four times per batch, and the batch-16384 runs take about 30 s each):

    python benchmarks/bench_roofline.py   # batches 1024 16384, T 2 s, dt 1e-3, 2048^2 matmul

The roofline in one process per core (about 5 minutes here; `--batches` must be multiples of
`--processes`):

    python benchmarks/bench_roofline.py --batches 1024 16384 --jaxatt-calls monte_carlo \
        --processes 2

The same with each process's batch in chunks of 1024 under XLA's multi-output fusion (the
configuration that reached 22-23 % of the derived peak on 2026-12-07; about 2.5 minutes):

    XLA_FLAGS=--xla_backend_extra_options=xla_cpu_use_multi_output_fusion \
        python benchmarks/bench_roofline.py --batches 16384 --jaxatt-calls monte_carlo \
        --processes 2 --batch-size 1024

A small run (about 1.5 minutes on a loaded 2-core machine):

    python benchmarks/bench_roofline.py --batches 64 --horizon 0.2 --bandwidth-mib 64 \
        --matmul-size 1024 --repeat 1
"""

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import _reference as ref
import numpy as np


try:  # imported as `benchmarks.bench_roofline`
    from . import _common as common
except ImportError:  # run as a script: benchmarks/ is sys.path[0]
    import _common as common


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[1024, 16384])
    p.add_argument("--horizon", type=float, default=2.0, help="horizon of the timed runs [s]")
    p.add_argument(
        "--cost-steps", type=int, default=7, help="steps of the program the step loop is cut from"
    )
    p.add_argument("--matmul-size", type=int, default=2048, help="n of the n x n matmul")
    p.add_argument(
        "--bandwidth-mib", type=float, default=256.0, help="size of each array of x + y [MiB]"
    )
    p.add_argument(
        "--cache-kib", type=float, default=256.0, help="size of the cache-resident x + y [KiB]"
    )
    p.add_argument("--fma-units", type=int, default=2, help="FMA pipes per core (assumption)")
    p.add_argument("--clock-ghz", type=float, default=None, help="override the reported clock")
    p.add_argument(
        "--jaxatt-calls",
        nargs="+",
        choices=sorted(common.montecarlo.JAXATT_CALLS),
        default=["monte_carlo_plain", "monte_carlo"],
    )
    p.add_argument("--no-scan", action="store_true", help="skip the hand scan")
    p.add_argument("--no-plot", action="store_true", help="skip the figure")
    p.add_argument(
        "--processes",
        type=int,
        default=1,
        help="also run each jaxatt program as this many processes, one pinned to each core",
    )
    p.add_argument(
        "--batch-size",
        type=int,
        default=None,
        help="monte_carlo's batch_size for the timed jaxatt runs (lax.map chunks of that many "
        "samples per process; default: the whole batch at once)",
    )
    p.add_argument("--pinned-worker", nargs=5, help=argparse.SUPPRESS)
    common.add_common_arguments(p)
    args = p.parse_args(argv)
    common.finish_arguments(p, args, [args.horizon], "roofline.json")
    if min(args.batches) < 1 or args.cost_steps < 2 or args.matmul_size < 1:
        p.error("--batches must be positive, --cost-steps at least 2")
    if args.batch_size is not None and args.batch_size < 1:
        p.error(f"--batch-size must be a positive integer, got {args.batch_size}")
    if args.processes < 1 or any(b % args.processes for b in args.batches):
        p.error(f"--processes must be positive and divide every batch, got {args.processes}")
    return args


# ---------------------------------------------------------------------------------------------
# Peaks.


def derived_peak(cpu: dict, dtype: str, fma_units: int, clock_ghz: float | None) -> dict:
    """cores x clock x SIMD lanes x FMA units x 2 [FLOP/s], and the assumptions behind it."""
    flags = set(cpu["flags"])
    if "avx512f" in flags:
        isa, lanes = "AVX-512", 8
    elif "avx2" in flags or "avx" in flags:
        isa, lanes = "AVX2" if "avx2" in flags else "AVX", 4
    else:
        isa, lanes = "SSE2", 2
    if dtype == "float32":
        lanes *= 2
    fma = "fma" in flags or "avx512f" in flags
    per_cycle = lanes * fma_units * (2 if fma else 1)
    cores = cpu["usable_cpus"] or cpu["logical_cpus"]
    clock = clock_ghz or cpu["clock_ghz"]
    peak = None if clock is None else cores * clock * 1e9 * per_cycle
    return {
        "flops_per_s": peak,
        "cores": cores,
        "clock_ghz": clock,
        "clock_source": "--clock-ghz" if clock_ghz else cpu["clock_source"],
        "isa": isa,
        "lanes": lanes,
        "fma": fma,
        "fma_units_per_core": fma_units,
        "flops_per_cycle_per_core": per_cycle,
        "assumptions": (
            f"{cores} cores (usable CPUs; a hyperthread counts as a core), {isa} {lanes} lanes "
            f"of {dtype}, {fma_units} {'FMA' if fma else 'add+mul'} units per core (assumed, "
            f"--fma-units), {'2 FLOPs per FMA' if fma else 'no FMA'}, clock {clock} GHz "
            f"({'--clock-ghz' if clock_ghz else cpu['clock_source']}), no AVX frequency drop"
        ),
    }


def bandwidth(array_bytes: float, total_bytes: float, args) -> dict:
    """Bytes/s of `x = x + y` repeated in a `lax.fori_loop` on two float64/32 arrays of
    `array_bytes` each (3 arrays of traffic per pass, in place: no allocation in the loop),
    with enough passes to move about `total_bytes`."""
    import jax
    import jax.numpy as jnp

    dtype = jnp.result_type(float)
    n = max(1, int(array_bytes // np.dtype(dtype).itemsize))
    passes = max(1, int(np.ceil(total_bytes / (3 * n * np.dtype(dtype).itemsize))))
    x = jnp.arange(n, dtype=dtype)
    y = jnp.full(n, 1e-9, dtype=dtype)

    @jax.jit
    def repeated_add(x, y):
        return jax.lax.fori_loop(0, passes, lambda i, x: x + y, x)

    _, run_s, _, reps = common.time_jax(repeated_add, (x, y), args.repeat, args.max_seconds)
    moved = 3 * n * np.dtype(dtype).itemsize * passes
    return {
        "array_bytes": n * np.dtype(dtype).itemsize,
        "passes": passes,
        "bytes": moved,
        "run_s": run_s,
        "timed_repeats": reps,
        "bytes_per_s": moved / run_s,
    }


def measured_peaks(args, dtype) -> dict:
    """Matmul FLOP/s, `x + y` bytes/s (memory- and cache-sized), ns per `pow`, timed here."""
    import jax
    import jax.numpy as jnp
    import jax.random as jr

    n = args.matmul_size
    ka, kb = jr.split(jr.key(args.seed + 7))
    a = jr.normal(ka, (n, n), dtype)
    b = jr.normal(kb, (n, n), dtype)
    matmul = jax.jit(jnp.dot)
    _, run_s, _, reps = common.time_jax(matmul, (a, b), args.repeat, args.max_seconds)
    out = {"matmul": {"n": n, "run_s": run_s, "timed_repeats": reps}}
    out["matmul"]["flops_per_s"] = 2 * n**3 / run_s

    out["bandwidth"] = bandwidth(args.bandwidth_mib * 2**20, 8 * args.bandwidth_mib * 2**20, args)
    out["cache_bandwidth"] = bandwidth(args.cache_kib * 2**10, 2**30, args)

    m = 2**20
    base = jr.uniform(ka, (m,), dtype, 0.1, 2.0)
    exponent = jnp.where(jnp.arange(m) % 2 == 0, 5 / 9, 31 / 11).astype(dtype)
    power = jax.jit(jnp.power)
    _, run_s, _, reps = common.time_jax(power, (base, exponent), args.repeat, args.max_seconds)
    out["pow"] = {"elements": m, "run_s": run_s, "ns_per_element": run_s / m * 1e9}
    return out


# ---------------------------------------------------------------------------------------------
# Cost of one step.


def _sub_jaxprs(eqn):
    for value in eqn.params.values():
        for sub in value if isinstance(value, (list, tuple)) else (value,):
            if hasattr(getattr(sub, "jaxpr", sub), "eqns"):
                yield sub


def step_loops(jaxpr, length: int) -> list:
    """The `scan` equations of trip count `length` whose bodies hold no other scan."""
    found = []

    def has_scan(j) -> bool:
        j = getattr(j, "jaxpr", j)
        return any(e.primitive.name == "scan" or any(map(has_scan, _sub_jaxprs(e))) for e in j.eqns)

    def walk(j):
        for eqn in getattr(j, "jaxpr", j).eqns:
            if eqn.primitive.name == "scan" and eqn.params["length"] == length:
                if not has_scan(eqn.params["jaxpr"]):
                    found.append(eqn)
            for sub in _sub_jaxprs(eqn):
                walk(sub)

    walk(jaxpr)
    return found


def _traceable(function):
    """`function` as something to trace inside another transformation: a `_quick.UserProgram`
    compiles with XLA options (512-bit vectors for a scalarized loop), which JAX accepts on a
    top-level `jit` only, so its plain function is traced instead. XLA's FLOP, transcendental
    and byte counts are those of the HLO, which the options do not change."""
    return getattr(function, "fn", function)


def step_cost(function, args, k: int) -> dict:
    """XLA's cost of one step of `function`, built to do `k` steps.

    `function(*args)` must run its time loop as a `lax.scan` of length `k`; that loop's body
    is compiled alone (module docstring). `step`: the compiled body's counts (what runs);
    `written`: the counts of its HLO before optimization (each operation of the program once).
    """
    import jax
    from jax.extend.core import jaxpr_as_fun

    loops = step_loops(jax.make_jaxpr(_traceable(function))(*args), k)
    if len(loops) != 1:
        return {"error": f"found {len(loops)} step loops of length {k}, expected 1"}
    body = loops[0].params["jaxpr"]
    specs = [jax.ShapeDtypeStruct(a.shape, a.dtype) for a in body.in_avals]
    lowered = jax.jit(jaxpr_as_fun(body)).lower(*specs)
    return {"written": common.xla_cost(lowered), "step": common.xla_cost(lowered.compile())}


def rates(cost: dict, batch: int, steps: int, run_s: float, peak: dict, measured: dict) -> dict:
    """Per-state-step counts, achieved rates and fractions of the roofs for one timed run.

    "executed" counts are those of the compiled step (what XLA runs, recomputation in fusions
    included); "written" (useful) ones those of the step as the program states it.
    """
    step, written = cost["step"], cost["written"]
    out = {
        "step_cost_batch": step,
        "step_cost_batch_written": written,
        "flops_per_state_step": step["flops"] / batch,
        "written_flops_per_state_step": written["flops"] / batch,
        "transcendentals_per_state_step": step["transcendentals"] / batch,
        "bytes_per_state_step": step["bytes_accessed"] / batch,
        "arithmetic_intensity": step["flops"] / step["bytes_accessed"],
        "useful_arithmetic_intensity": written["flops"] / step["bytes_accessed"],
        "ns_per_state_step": run_s / (batch * steps) * 1e9,
        "achieved_flops_per_s": step["flops"] * steps / run_s,
        "useful_flops_per_s": written["flops"] * steps / run_s,
        "achieved_bytes_per_s": step["bytes_accessed"] * steps / run_s,
    }
    for key in ("achieved_flops_per_s", "useful_flops_per_s"):
        prefix = key.split("_")[0]
        out[f"{prefix}_fraction_of_derived_peak"] = (
            out[key] / peak["flops_per_s"] if peak["flops_per_s"] else None
        )
        out[f"{prefix}_fraction_of_matmul"] = out[key] / measured["matmul"]["flops_per_s"]
    out["transcendental_time_share_upper_bound"] = (
        out["transcendentals_per_state_step"]
        * measured["pow"]["ns_per_element"]
        / out["ns_per_state_step"]
    )
    return out


def program_flops(function, args) -> float:
    """XLA's flops of the whole compiled `function(*args)` (loop bodies counted once)."""
    import jax

    return common.xla_cost(jax.jit(_traceable(function)).lower(*args).compile())["flops"]


def measure_program(name, loop, x0s, args, peak, measured, *, body_once: bool):
    """`(row, final states or None, 2k/k flops ratio or None)` of one program at one batch.

    `name` is "jaxatt <call>" (`bench_montecarlo.make_jaxatt(call, ...)`) or "hand scan". The
    step cost comes from a `--cost-steps` program, the rates from a run over `--horizon`; with
    `body_once`, XLA's flops of the whole 2k- and k-step programs are compared too.
    """
    dtype = np.dtype(args.dtype)
    k, dt = args.cost_steps, args.dt
    steps = common.steps_of(args.horizon, dt)
    batch = x0s.q.shape[0]
    if name.startswith("jaxatt"):
        call = name.split()[1]
        make = common.montecarlo.make_jaxatt
        timed = make(call, args.horizon, dt, common.default_save_every(steps), args.batch_size)
        inputs = (loop, x0s)
        short, long = make(call, k * dt, dt, k), make(call, 2 * k * dt, dt, 2 * k)
    else:
        timed = ref.make_hand_scan(steps, dt, dtype)
        inputs = (x0s.q, x0s.omega)
        short, long = ref.make_hand_scan(k, dt, dtype), ref.make_hand_scan(2 * k, dt, dtype)
    row = {"program": name, "batch": batch, "steps": steps}
    if name.startswith("jaxatt"):
        row["batch_size"] = args.batch_size
    cost = step_cost(short, inputs, k)
    if "error" in cost:
        print(f"  {name:>24}, batch {batch:>6}: {cost['error']}")
        return {**row, "error": cost["error"]}, None, None
    ratio = program_flops(long, inputs) / program_flops(short, inputs) if body_once else None
    compile_s, run_s, out, reps = common.time_jax(timed, inputs, args.repeat, args.max_seconds)
    if name.startswith("jaxatt"):
        final = np.asarray(out[0])
        row["failed_samples"] = int(np.sum(~np.asarray(out[1])))
    else:
        final = np.asarray(out)
    row.update({"compile_s": compile_s, "run_s": run_s, "timed_repeats": reps})
    row.update(rates(cost, batch, steps, run_s, peak, measured))
    print(
        f"  {name:>24}, batch {batch:>6}: {row['flops_per_state_step']:.4g} FLOP run "
        f"({row['written_flops_per_state_step']:.4g} written), "
        f"{row['transcendentals_per_state_step']:.3g} transcendentals, "
        f"{row['bytes_per_state_step']:.4g} B per state-step; run {run_s:.4g} s, "
        f"{row['achieved_flops_per_s']:.3g} FLOP/s",
        flush=True,
    )
    return row, final, ratio


# ---------------------------------------------------------------------------------------------
# One process per core.


def _slice(tree, start: int, stop: int):
    import jax

    return jax.tree_util.tree_map(lambda x: x[start:stop], tree)


def pinned_worker(args) -> int:
    """One of `--processes` pinned processes (`--pinned-worker CALL BATCH PART CORE OUT`):
    pin this process to CORE, compile and warm up `CALL` on slice PART of the first BATCH
    samples, say `READY <compile s>`, run once per "go" line on stdin (saying `DONE` after
    each), save the final states to OUT."""
    call, batch, part, core, out_path = args.pinned_worker
    os.sched_setaffinity(0, {int(core)})  # before JAX's CPU client sizes its thread pool
    import jax

    batch, part = int(batch), int(part)
    common.enable_precision(args.dtype)
    steps = common.steps_of(args.horizon, args.dt)
    loop, pool = common.m1_setup(args.seed, max(args.batches), np.dtype(args.dtype))
    size = batch // args.processes
    x0s = _slice(pool, part * size, (part + 1) * size)
    timed = common.montecarlo.make_jaxatt(
        call, args.horizon, args.dt, common.default_save_every(steps), args.batch_size
    )
    start = time.perf_counter()
    compiled = timed.lower(loop, x0s).compile()
    compile_s = time.perf_counter() - start
    out = jax.block_until_ready(compiled(loop, x0s))
    print(f"READY {compile_s}", flush=True)
    for line in sys.stdin:
        if line.strip() != "go":
            break
        out = jax.block_until_ready(compiled(loop, x0s))
        print("DONE", flush=True)
    np.save(out_path, np.asarray(out[0]))
    return 0


def _expect(process, word: str, log: pathlib.Path) -> str:
    line = process.stdout.readline()
    if not line.startswith(word):
        process.kill()
        tail = log.read_text()[-3000:]
        raise SystemExit(f"pinned worker: expected {word!r}, got {line!r}\n{tail}")
    return line


def time_pinned(call: str, batch: int, args) -> dict:
    """Compile time (the slowest process's), run time (min over `--repeat` rounds of all
    processes started together) and final states (in batch order) of `call` in
    `--processes` pinned processes."""
    n, cores = args.processes, os.cpu_count() or 1
    argv = sys.argv[1:]  # the same settings; each worker adds its --pinned-worker
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        procs, logs = [], []
        for i in range(n):
            logs.append(tmp / f"worker{i}.log")
            worker = [call, str(batch), str(i), str(i % cores), str(tmp / f"final{i}.npy")]
            procs.append(
                subprocess.Popen(
                    [sys.executable, __file__, *argv, "--pinned-worker", *worker],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.PIPE,
                    stderr=logs[-1].open("w"),
                    text=True,
                )
            )
        compile_s = max(float(_expect(p, "READY", log).split()[1]) for p, log in zip(procs, logs))
        rounds = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            for p in procs:
                p.stdin.write("go\n")
                p.stdin.flush()
            for p, log in zip(procs, logs):
                _expect(p, "DONE", log)
            rounds.append(time.perf_counter() - start)
        for p, log in zip(procs, logs):
            p.stdin.write("quit\n")
            p.stdin.close()
            if p.wait() != 0:
                raise SystemExit(f"pinned worker failed\n{log.read_text()[-3000:]}")
        final = np.concatenate([np.load(tmp / f"final{i}.npy") for i in range(n)])
    return {"compile_s": compile_s, "run_s": min(rounds), "rounds_s": rounds, "final": final}


def measure_pinned(name, loop, x0s, args, peak, measured, reference_final):
    """The row of jaxatt program `name` at this batch in `--processes` pinned processes, and
    the largest difference of its final states from the one-process program's."""
    n, k = args.processes, args.cost_steps
    batch, steps = x0s.q.shape[0], common.steps_of(args.horizon, args.dt)
    call = name.split()[1]
    short = common.montecarlo.make_jaxatt(call, k * args.dt, args.dt, k)
    cost = step_cost(short, (loop, _slice(x0s, 0, batch // n)), k)
    row = {"program": f"{name}, {n} pinned processes", "batch": batch, "steps": steps}
    row.update(processes=n, batch_per_process=batch // n, batch_size=args.batch_size)
    if "error" in cost:
        return {**row, "error": cost["error"]}
    timing = time_pinned(call, batch, args)
    machine = {key: {m: v * n for m, v in cost[key].items()} for key in ("step", "written")}
    row.update({key: timing[key] for key in ("compile_s", "run_s", "rounds_s")})
    row.update(rates(machine, batch, steps, timing["run_s"], peak, measured))
    row["max_abs_diff_vs_one_process"] = common.montecarlo.max_abs_diff(
        reference_final, timing["final"]
    )
    print(
        f"  {row['program']:>38}, batch {batch:>6}: {row['written_flops_per_state_step']:.4g} "
        f"written FLOP per state-step; run {row['run_s']:.4g} s, useful "
        f"{row['useful_flops_per_s']:.3g} FLOP/s; final states vs one process "
        f"{row['max_abs_diff_vs_one_process']:.3g}",
        flush=True,
    )
    return row


def main(args) -> int:
    common.enable_precision(args.dtype)
    dtype = np.dtype(args.dtype)
    meta = common.machine_meta()
    steps = common.steps_of(args.horizon, args.dt)
    save_every = common.default_save_every(steps)
    k = args.cost_steps
    common.print_meta(
        meta,
        f"Chen 2022 M1 roofline: batches {args.batches}, timed over {args.horizon:g} s "
        f"({steps} RK4 steps, dt {args.dt:g} s, save_every {save_every}), cost of one step cut "
        f"from a {k}-step program, {args.dtype}",
    )
    tol = 1e-9 if dtype == np.float64 else 1e-4
    loop, pool = common.m1_setup(args.seed, max(args.batches), dtype)

    peak = derived_peak(meta["cpu"], args.dtype, args.fma_units, args.clock_ghz)
    if meta["backend"] != "cpu":  # the derivation is of the host CPU, not of this device
        peak.update(flops_per_s=None, assumptions=f"not derived for backend {meta['backend']}")
    measured = measured_peaks(args, dtype)
    print(f"derived peak: {common.fmt(peak['flops_per_s'])} FLOP/s: {peak['assumptions']}")
    print(
        f"measured: matmul {measured['matmul']['flops_per_s']:.3g} FLOP/s "
        f"({args.matmul_size}^2, jnp.dot), x + y {measured['bandwidth']['bytes_per_s']:.3g} "
        f"B/s ({args.bandwidth_mib:g} MiB arrays), "
        f"{measured['cache_bandwidth']['bytes_per_s']:.3g} B/s ({args.cache_kib:g} KiB arrays), "
        f"pow {measured['pow']['ns_per_element']:.3g} ns per element",
        flush=True,
    )

    programs = [f"jaxatt {call}" for call in args.jaxatt_calls]
    programs += [] if args.no_scan else ["hand scan"]
    rows, body_once = [], {}
    for batch in sorted(args.batches):
        x0s = common.take(pool, batch)
        finals = {}
        for name in programs:
            row, final, ratio = measure_program(
                name, loop, x0s, args, peak, measured, body_once=name not in body_once
            )
            if ratio is not None:
                body_once[name] = ratio
            rows.append(row)
            if final is not None:
                finals[name] = final
            if args.processes > 1 and name.startswith("jaxatt") and final is not None:
                rows.append(measure_pinned(name, loop, x0s, args, peak, measured, final))
        for row in rows:
            compared = row["program"] in finals and row["program"] != "hand scan"
            if row["batch"] == batch and "hand scan" in finals and compared:
                row["max_abs_diff_scan_vs_jaxatt"] = common.montecarlo.max_abs_diff(
                    finals["hand scan"], finals[row["program"]]
                )
    diffs = [r["max_abs_diff_scan_vs_jaxatt"] for r in rows if "max_abs_diff_scan_vs_jaxatt" in r]
    pinned = [r["max_abs_diff_vs_one_process"] for r in rows if "max_abs_diff_vs_one_process" in r]
    failed = sum(r.get("failed_samples", 0) for r in rows)
    ok = all("error" not in r and r["step_cost_batch"]["flops"] > 0 for r in rows)
    ok &= failed == 0 and all(d <= tol for d in diffs + pinned)

    print_table(rows, peak, measured, args, meta)
    print(
        f"  XLA's flops of the whole {2 * k}-step program / the {k}-step program: "
        + ", ".join(f"{name} {x:.3f}" for name, x in body_once.items())
        + " (1 = a while body is counted once, whatever the trip count)"
    )
    figure = None
    if not args.no_plot:
        figure = common.results_path(args, pathlib.Path(args.out).stem + ".png")
        figure.parent.mkdir(parents=True, exist_ok=True)
        plot(rows, peak, measured, args, meta, figure)
        print(f"figure: {figure}")

    print()
    if diffs:
        print(f"check: max |hand scan - jaxatt| final states: {max(diffs):.3g} (tolerance {tol:g})")
    if pinned:
        print(
            f"check: max |pinned processes - one process| final states: {max(pinned):.3g} "
            f"(tolerance {tol:g})"
        )
    print(f"check: jaxatt samples with a non-finite state: {failed}")
    print(f"check: one step loop found in every program: {all('error' not in r for r in rows)}")
    result = {
        "benchmark": "chen2022 M1 roofline (XLA cost analysis of one RK4 step, measured roofs)",
        "units": {
            "flops_per_state_step": "XLA flops of one step of the batch / batch",
            "achieved_flops_per_s": "XLA flops per batch step x steps / run time",
            "arithmetic_intensity": "flop / byte (XLA bytes accessed)",
        },
        "settings": {**vars(args), "steps": steps, "save_every": save_every},
        "derived_peak": peak,
        "measured": measured,
        "rows": rows,
        "xla_program_flops_ratio_2k_over_k": body_once,
        "figure": None if figure is None else str(figure),
        "checks": {
            "max_abs_diff_scan_vs_jaxatt": diffs,
            "max_abs_diff_pinned_vs_one_process": pinned,
            "failed_samples": failed,
            "tolerance": tol,
        },
    }
    return common.finish(result, meta, args.out, ok)


def print_table(rows, peak, measured, args, meta) -> None:
    header = [
        ("program", 38),
        ("batch", 6),
        ("FLOP/st-st", 10),
        ("written", 7),
        ("transc.", 7),
        ("B/st-st", 8),
        ("FLOP/B", 6),
        ("ns/st-st", 8),
        ("GFLOP/s", 7),
        ("useful", 6),
        ("% peak", 6),
        ("% useful", 8),
        ("% matmul", 8),
        ("transc. share <=", 16),
    ]
    line = " | ".join(f"{name:>{width}}" for name, width in header)
    print()
    print(
        f"Measured on {meta['device_kind']} ({meta['cpu']['model']}, {meta['cpu_count']} CPUs), "
        f"{args.dtype}, {meta['date']}; derived peak {common.fmt(peak['flops_per_s'])} FLOP/s, "
        f"matmul {measured['matmul']['flops_per_s']:.3g} FLOP/s, x + y "
        f"{measured['bandwidth']['bytes_per_s']:.3g} B/s (memory), "
        f"{measured['cache_bandwidth']['bytes_per_s']:.3g} B/s (cache)"
    )
    print(line)
    print("-" * len(line))
    for r in rows:
        if "error" in r:
            print(f"{r['program']:>38} | {r['batch']:>6} | {r['error']}")
            continue
        frac = r["achieved_fraction_of_derived_peak"]
        useful = r["useful_fraction_of_derived_peak"]
        cells = [
            f"{r['program']:>38}",
            f"{r['batch']:>6}",
            f"{r['flops_per_state_step']:>10.4g}",
            f"{r['written_flops_per_state_step']:>7.4g}",
            f"{r['transcendentals_per_state_step']:>7.3g}",
            f"{r['bytes_per_state_step']:>8.4g}",
            f"{r['arithmetic_intensity']:>6.3g}",
            f"{r['ns_per_state_step']:>8.4g}",
            f"{r['achieved_flops_per_s'] / 1e9:>7.3g}",
            f"{r['useful_flops_per_s'] / 1e9:>6.3g}",
            f"{'-' if frac is None else f'{100 * frac:.2g}':>6}",
            f"{'-' if useful is None else f'{100 * useful:.3g}':>8}",
            f"{100 * r['achieved_fraction_of_matmul']:>8.2g}",
            f"{r['transcendental_time_share_upper_bound']:>16.2g}",
        ]
        print(" | ".join(cells))
    print(
        "  st-st = state-step (one sample, one RK4 step). FLOP, transc. (transcendentals), B = "
        "XLA cost analysis of the compiled step loop body (what runs, recomputation in fusions "
        "included), / batch; written = FLOP of the same body before XLA's optimizations (the "
        "program's own operations). ns/st-st from the timed run; GFLOP/s = executed FLOP rate, "
        "useful = written FLOP rate; % peak and % matmul of the executed rate, % useful = "
        "useful rate / derived peak; N pinned processes = the machine's rates with one process "
        "per core (N x one process's step cost; module docstring); transc. share "
        "<= = transcendentals x measured ns per pow / ns per state-step (an upper bound of "
        "the time in pow, sqrt, sin, ...)"
    )


def plot(rows, peak, measured, args, meta, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bandwidth = measured["bandwidth"]["bytes_per_s"]
    intensities = [
        r[key]
        for r in rows
        if "error" not in r
        for key in ("arithmetic_intensity", "useful_arithmetic_intensity")
    ]
    lo = min([1 / 16, *intensities]) / 2
    hi = max([64, *intensities]) * 2
    x = np.logspace(np.log10(lo), np.log10(hi), 200)
    fig, ax = plt.subplots(figsize=(7, 5), layout="constrained")
    roofs = [("matmul (measured)", measured["matmul"]["flops_per_s"], "--")]
    if peak["flops_per_s"]:
        roofs.insert(0, (f"derived peak ({peak['isa']}, FMA)", peak["flops_per_s"], "-"))
    for label, top, style in roofs:
        ax.loglog(x, np.minimum(top, bandwidth * x), style, color="k", lw=1.2, label=label)
    ax.loglog(x, bandwidth * x, ":", color="0.5", lw=1, label=f"memory: {bandwidth / 1e9:.3g} GB/s")
    cache = measured["cache_bandwidth"]["bytes_per_s"]
    ax.loglog(
        x,
        np.minimum(roofs[0][1], cache * x),
        "-.",
        color="0.5",
        lw=1,
        label=f"cache ({args.cache_kib:g} KiB arrays): {cache / 1e9:.3g} GB/s",
    )
    markers = {
        "jaxatt monte_carlo_plain": ("o", "C0"),
        "jaxatt monte_carlo": ("D", "C2"),
        "hand scan": ("s", "C1"),
    }
    for r in rows:
        if r["program"].endswith("pinned processes"):
            markers.setdefault(r["program"], ("^", "C3"))
    for name, (marker, color) in markers.items():
        pts = [r for r in rows if r["program"] == name and "error" not in r]
        for r in pts:
            executed = (r["arithmetic_intensity"], r["achieved_flops_per_s"])
            useful = (r["useful_arithmetic_intensity"], r["useful_flops_per_s"])
            first = r is pts[0]
            ax.loglog(*executed, marker, color=color, ms=8, label=f"M1 {name}" if first else None)
            ax.loglog(
                *useful,
                marker,
                color=color,
                ms=8,
                mfc="none",
                label=f"M1 {name}, written FLOPs" if first else None,
            )
            ax.plot(*zip(executed, useful), color=color, lw=0.6)
            ax.annotate(f"  batch {r['batch']}", executed, fontsize=8)
    ax.set_xlabel("arithmetic intensity [FLOP / byte of XLA's bytes accessed per step]")
    ax.set_ylabel("FLOP/s")
    ax.set_title(
        f"Chen 2022 M1, RK4, {args.dtype}: {meta['device_kind']} ({meta['cpu']['model']}, "
        f"{meta['cpu_count']} CPUs)",
        fontsize=10,
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    arguments = parse_args()
    sys.exit(pinned_worker(arguments) if arguments.pinned_worker else main(arguments))
