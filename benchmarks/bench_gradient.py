r"""Cost of the gradient of a Monte Carlo settling-time objective of Chen 2022's M1 with respect
to its five reaching-law and surface gains: reverse mode against forward mode, with and without
`simulate(checkpoint=True)` (or `"recursive"`), with the metric reduced from a saved trajectory or
streamed, time and peak memory.

**Closed loop and batch.** `jaxatt.scenarios.chen2022_two_phase_power.build("M1")` (classic
RK4, dt = 1e-3 s, 30 N m per-axis saturation), `--batch` initial states from
`jaxatt.scenarios.chen2022_tuning.initial_states(jr.key(seed), n)`.

**Objective.** $L(u) = \frac1n\sum_k T_k$, with $T_k$ the convergence time of
$\|e_v\| < 10^{-3}$ of sample $k$: `jaxatt.metrics.ConvergenceTime("attitude_error_vector",
1e-3)` (`jaxatt.metrics.convergence_time`: the time spent outside the band, interpolated
linearly between saved samples, plus for a sample not settled by the horizon $T$ the time its
measured final decay still needs; continuous, so every sample has a gradient), evaluated by
`jaxatt.montecarlo.run_batch` (the batch runner of `monte_carlo` and of the tuning objectives)
on `Simulation(0, T, dt, save_every=S, checkpoint=...)`. This is
`jaxatt.tune.SettlingObjective`'s loss with `Mean()` and no penalties (checked in-run; the
objective streams its metrics); it is written out here so that each configuration sets the
checkpointing and whether the metric streams, with the objective's one metric alone. `S`
(`--save-every`) defaults to 10 steps = 10 ms: the resolution of the interpolated crossing,
and in reverse mode with `checkpoint=True` the length of each rematerialized interval.

**Parameters.** $u$: the five unconstrained variables of `chen2022_tuning.parameters()`
(rho, eta, lambda = e^u; p1/q1 = 1 + e^u; q2/p2 = sigmoid(u)), written into the loop with
`jaxatt.tune.apply` (as `jaxatt.tune.tune` does), at the paper's gains.

**Configurations** (`--configs`), each compiled and run in a **fresh subprocess**:

- `forward`: $L(u)$ alone (`eqx.filter_jit`).
- `reverse`: `jax.value_and_grad(L)(u)`, `simulate(checkpoint=True)`: each save interval is
  recomputed in the backward pass, so memory grows with the number of saves.
- `reverse-nockpt`: the same with `checkpoint=False`: the residuals of every RK4 step are kept,
  so memory grows with the number of steps.
- `reverse-recursive`: the same with `checkpoint="recursive"`: equinox's checkpointed scan
  (online treeverse) stores at most `--checkpoints` loop states (default equinox's choice,
  about $\sqrt{2N}$ for $N$ save intervals) and recomputes intervals as its schedule needs.
- `reverse-stream`, `reverse-stream-recursive`: `reverse` and `reverse-recursive` with the
  metric reduced on the fly (`run_batch(..., stream=True)`, as the tuning objectives run it):
  no saved trajectory is stored. In the other configurations the saved trajectory that the
  objective reads is stored.
- `jacfwd`: `jax.jacfwd(L)(u)`: the five tangents pushed forward with the primal in one pass
  (`checkpoint` has no effect in forward mode; `forward-nockpt` and `jacfwd-nockpt` exist to
  show it).

Times: compile = ahead-of-time `lower(...).compile()`; run = one warm-up call, then
`min(timeit.repeat(lambda: jax.block_until_ready(f(u, loop, x0s)), number=1, repeat=R))`
(fewer repeats when they would take over `--max-seconds`); ratios are run time over the forward
run time at the same horizon.

**Peak memory.** Each child reads `resource.getrusage(RUSAGE_SELF).ru_maxrss` at its end (and
after building its inputs and after compiling); the table reports it minus the peak RSS of a
baseline child that only imports and builds the inputs. The peak includes XLA's compilation
(its share is the "after compile" column); XLA's own static estimate of the run's temporary
buffers (`compiled.memory_analysis().temp_size_in_bytes`) is reported too, and a
configuration whose estimate exceeds `--max-temp-gib` is compiled but not run. Two horizons
(`--horizons`) show how each configuration's memory grows with the number of steps.

**Checks** (exit code 1 when one fails): the reverse-mode gradient (checkpoint=True) is finite
and matches `jacfwd` to `max|g_rev - g_fwd| / max|g_fwd| <= 1e-6` (float32: 1e-3) at every
horizon; `checkpoint=False` gives the same gradient (1e-9; float32 1e-4); every configuration
gives the same loss as `forward` (1e-12; float32 1e-5); the loss equals
`jaxatt.tune.SettlingObjective(T, dt, 1e-3, save_every=S)` at the first horizon (1e-12;
float32 1e-5); no sample has a non-finite state.

**Recorded defaults** (estimated 8 to 15 minutes on 2 cores, a third of it compiling: about
6 s for `forward`, 15 s for `jacfwd`, 25 to 30 s for each `reverse` on a loaded machine):

    python benchmarks/bench_gradient.py      # batch 256, horizons 10 30 s, dt 1e-3, S = 10

At small sizes XLA estimated about 3.3 KB of temporary buffers per sample per step for
`reverse-nockpt` (0.01 KB with `checkpoint=True`): about 8 GB at 10 s and 25 GB at 30 s for
batch 256, so on a 23 GiB machine `reverse-nockpt` runs at 10 s and is compiled but not run at
30 s (its estimate is still reported). The peak RSS of small runs is the compiler's (0.1 to
0.5 GiB); only larger runs show the run's own memory in it.

Small runs (about 6 and 2 minutes on a loaded 2-core machine; every child compiles anew):

    python benchmarks/bench_gradient.py --batch 8 --horizons 0.2 0.4 --repeat 1
    python benchmarks/bench_gradient.py --batch 8 --horizons 0.2 --configs forward reverse jacfwd
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile


try:  # imported as `benchmarks.bench_gradient`
    from . import _common as common
except ImportError:  # run as a script: benchmarks/ is sys.path[0]
    import _common as common


CONFIGS = {
    "forward": ("forward", True, False),
    "reverse": ("reverse", True, False),
    "reverse-nockpt": ("reverse", False, False),
    "reverse-recursive": ("reverse", "recursive", False),
    "reverse-stream": ("reverse", True, True),
    "reverse-stream-recursive": ("reverse", "recursive", True),
    "jacfwd": ("jacfwd", True, False),
    "forward-nockpt": ("forward", False, False),
    "jacfwd-nockpt": ("jacfwd", False, False),
}
"""Configuration name -> (mode, simulate's `checkpoint`, whether the metric streams)."""
TOLERANCE = 1e-3  # settling band on ||e_v||


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batch", type=int, default=256, help="initial states in the objective")
    p.add_argument(
        "--horizons", type=float, nargs="+", default=[10.0, 30.0], help="simulated times [s]"
    )
    p.add_argument(
        "--save-every", type=int, default=10, help="steps between saves (must divide each)"
    )
    p.add_argument(
        "--configs",
        nargs="+",
        choices=sorted(CONFIGS),
        default=["forward", "reverse", "reverse-nockpt", "jacfwd"],
    )
    p.add_argument(
        "--checkpoints",
        type=int,
        default=None,
        help="stored loop states of checkpoint='recursive' (default: equinox's choice)",
    )
    p.add_argument(
        "--max-temp-gib",
        type=float,
        default=None,
        help="do not run a configuration whose XLA temp-buffer estimate exceeds this; "
        "default 60%% of MemAvailable at start-up",
    )
    p.add_argument(
        "--child-timeout", type=float, default=1800.0, help="seconds before a child is killed"
    )
    p.add_argument(
        "--no-library-check",
        action="store_true",
        help="skip the comparison with jaxatt.tune.SettlingObjective (one more compile)",
    )
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)  # JSON: one configuration
    p.add_argument("--child-out", default=None, help=argparse.SUPPRESS)
    common.add_common_arguments(p)
    args = p.parse_args(argv)
    common.finish_arguments(p, args, args.horizons, "gradient.json")
    if args.batch < 1 or args.save_every < 1:
        p.error("--batch and --save-every must be positive")
    if args.checkpoints is not None and args.checkpoints < 1:
        p.error("--checkpoints must be positive")
    for horizon in args.horizons:
        if common.steps_of(horizon, args.dt) % args.save_every:
            p.error(f"--save-every {args.save_every} must divide the steps of horizon {horizon}")
    for name in ("forward", "reverse", "jacfwd"):
        if name not in args.configs:
            p.error(f"--configs must include {name!r} (the ratios and checks need it)")
    args.argv = sys.argv[1:] if argv is None else list(argv)
    return args


# ---------------------------------------------------------------------------------------------
# The objective and the measured functions (built in the child processes).


def make_loss(
    horizon: float,
    dt: float,
    save_every: int,
    checkpoint: bool | str,
    stream: bool = False,
    checkpoints: int | None = None,
):
    """`loss(u, template, x0s) -> (L, successful)`: the mean objective time (module docstring)
    of the loop `jaxatt.tune.apply(template, parameters, u)` over the batch `x0s`, run by
    `jaxatt.montecarlo.run_batch` (the batch runner of `monte_carlo` and of the tuning
    objectives) with simulate's `checkpoint` (and `checkpoints`) set, reducing the metric from
    the saved trajectory or on the fly (`stream`)."""
    import jax
    import jax.numpy as jnp

    from jaxatt import tune
    from jaxatt.metrics import ConvergenceTime
    from jaxatt.montecarlo import run_batch
    from jaxatt.scenarios import chen2022_tuning
    from jaxatt.simulation import Performance, Simulation

    parameters = chen2022_tuning.parameters()
    metrics = {"objective_time": ConvergenceTime("attitude_error_vector", TOLERANCE)}

    def loss(u, template, x0s):
        loop = tune.apply(template, parameters, u)
        n = jax.tree_util.tree_leaves(x0s)[0].shape[0]
        sim = Simulation(
            0.0,
            horizon,
            dt,
            save_every=save_every,
            checkpoint=checkpoint,
            checkpoints=checkpoints if checkpoint == "recursive" else None,
            performance=Performance().resolve(n),  # as SettlingObjective resolves it
        )
        out = run_batch(loop, x0s, sim, metrics, stream=stream)
        return jnp.mean(out.metrics["objective_time"]), out.successful

    return loss, parameters


def make_function(mode: str, loss):
    """The jitted `f(u, template, x0s) -> (L, gradient dict or None, successful)`."""
    import equinox as eqx
    import jax

    if mode == "forward":

        def f(u, template, x0s):
            value, successful = loss(u, template, x0s)
            return value, None, successful

    elif mode == "reverse":

        def f(u, template, x0s):
            (value, successful), grad = jax.value_and_grad(loss, has_aux=True)(u, template, x0s)
            return value, grad, successful

    elif mode == "jacfwd":

        def f(u, template, x0s):
            def with_value(u):
                value, successful = loss(u, template, x0s)
                return value, (value, successful)

            grad, (value, successful) = jax.jacfwd(with_value, has_aux=True)(u)
            return value, grad, successful

    else:
        raise ValueError(f"unknown mode {mode!r}")
    return eqx.filter_jit(f)


def child(args, config: dict) -> dict:
    """One configuration in this (fresh) process: compile, run, time, peak RSS."""
    common.enable_precision(args.dtype)
    import numpy as np

    from jaxatt import tune

    loop, x0s = common.m1_setup(args.seed, args.batch, args.dtype)
    if config["mode"] == "baseline":
        return {"rss_inputs_mib": common.max_rss_mib(), "rss_peak_mib": common.max_rss_mib()}
    loss, parameters = make_loss(
        config["horizon"],
        args.dt,
        args.save_every,
        config["checkpoint"],
        config["stream"],
        args.checkpoints,
    )
    u = tune.initial_unconstrained(loop, parameters)
    inputs = (u, loop, x0s)
    out = {"rss_inputs_mib": common.max_rss_mib()}
    f = make_function(config["mode"], loss)
    compiled, out["compile_s"] = common.compile_timed(f, inputs)
    out["rss_after_compile_mib"] = common.max_rss_mib()
    out["xla_memory"] = common.xla_memory(compiled)
    temp_gib = out["xla_memory"].get("temp_size_in_bytes", 0) / 2**30
    if temp_gib > config["max_temp_gib"]:
        out["skipped"] = (
            f"XLA estimates {temp_gib:.3g} GiB of temporary buffers > --max-temp-gib "
            f"{config['max_temp_gib']:.3g}"
        )
        out["rss_peak_mib"] = common.max_rss_mib()
        return out
    run_s, (value, grad, successful), n = common.time_compiled(
        compiled, inputs, args.repeat, args.max_seconds
    )
    out.update(
        {
            "run_s": run_s,
            "timed_repeats": n,
            "loss": float(value),
            "grad": None if grad is None else [float(grad[name]) for name in parameters],
            "parameters": list(parameters),
            "failed_samples": int(np.sum(~np.asarray(successful))),
            "rss_peak_mib": common.max_rss_mib(),
            "device_peak_mib": common.device_peak_mib(),
        }
    )
    return out


def spawn(args, config: dict) -> dict:
    """Run `child(args, config)` in a fresh Python process; its dict, or why it has none."""
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "child.json"
        command = [
            sys.executable,
            os.path.abspath(__file__),
            *args.argv,
            "--child",
            json.dumps(config),
            "--child-out",
            str(path),
        ]
        try:
            done = subprocess.run(
                command, capture_output=True, text=True, timeout=args.child_timeout
            )
        except subprocess.TimeoutExpired:
            return {"error": f"child timed out after {args.child_timeout:g} s"}
        if done.returncode != 0 or not path.exists():
            why = "killed (likely out of memory)" if done.returncode in (-9, 137) else "failed"
            return {
                "error": f"child {why}, return code {done.returncode}: "
                + done.stderr.strip()[-800:]
            }
        return json.loads(path.read_text())


# ---------------------------------------------------------------------------------------------
# The script.


def relative_difference(a, b) -> float:
    """max_i |a_i - b_i| / max_i |b_i| (inf when b is 0 and a is not)."""
    import numpy as np

    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    scale = np.max(np.abs(b))
    diff = np.max(np.abs(a - b))
    return float(diff / scale) if scale > 0 else (0.0 if diff == 0 else float("inf"))


def library_loss(args, horizon: float) -> float:
    """`jaxatt.tune.SettlingObjective(horizon, dt, 1e-3, save_every=S)` on the same batch."""
    from jaxatt import tune

    loop, x0s = common.m1_setup(args.seed, args.batch, args.dtype)
    objective = tune.SettlingObjective(horizon, args.dt, TOLERANCE, save_every=args.save_every)
    loss, _ = tune.evaluate(loop, objective, x0s)
    return float(loss)


def run_configurations(args, base: float) -> list[dict]:
    """One row per (horizon, configuration), each from its own child process."""
    rows = []
    for horizon in args.horizons:
        for name in args.configs:
            mode, checkpoint, stream = CONFIGS[name]
            config = {
                "mode": mode,
                "checkpoint": checkpoint,
                "stream": stream,
                "horizon": horizon,
                "max_temp_gib": args.max_temp_gib,
            }
            out = spawn(args, config)
            row = {"config": name, "steps": common.steps_of(horizon, args.dt), **config, **out}
            if "rss_peak_mib" in out:
                row["peak_minus_baseline_mib"] = out["rss_peak_mib"] - base
                row["compile_minus_baseline_mib"] = out["rss_after_compile_mib"] - base
            rows.append(row)
            status = out.get("error") or out.get("skipped")
            if not status:
                status = (
                    f"compile {out['compile_s']:.1f} s, run {out['run_s']:.3g} s, peak RSS - "
                    f"baseline {row['peak_minus_baseline_mib']:.0f} MiB, loss {out['loss']:.10g}"
                )
            print(f"  T = {horizon:g} s, {name:>24}: {status}", flush=True)
    for row in rows:
        forward = find(rows, row["horizon"], "forward")
        if "run_s" in row and forward is not None:
            row["ratio_to_forward"] = row["run_s"] / forward["run_s"]
    return rows


def find(rows, horizon: float, name: str) -> dict | None:
    """The row of configuration `name` at `horizon` that ran (has a run time), or None."""
    for row in rows:
        if row["horizon"] == horizon and row["config"] == name and "run_s" in row:
            return row
    return None


def check_rows(rows, args, tol) -> list[dict]:
    """The in-run checks (module docstring); each a dict with `ok`."""
    import numpy as np

    checks = []

    def check(horizon, what, value, tolerance, ok=True, **extra):
        ok = bool(ok and value <= tolerance)
        checks.append(
            {"horizon": horizon, "what": what, "value": value, "tolerance": tolerance}
            | extra
            | {"ok": ok}
        )

    for horizon in args.horizons:
        forward, reverse, jacfwd = (
            find(rows, horizon, c) for c in ("forward", "reverse", "jacfwd")
        )
        if None in (forward, reverse, jacfwd):
            check(horizon, "forward, reverse and jacfwd ran", float("inf"), 0.0, ok=False)
            continue
        check(
            horizon,
            "reverse gradient finite and equal to jacfwd",
            relative_difference(reverse["grad"], jacfwd["grad"]),
            tol["grad_reverse_vs_jacfwd"],
            ok=np.all(np.isfinite(reverse["grad"])),
            per_component=[
                relative_difference([a], [b]) for a, b in zip(reverse["grad"], jacfwd["grad"])
            ],
        )
        for row in rows:
            if row["horizon"] != horizon or "loss" not in row:
                continue
            check(
                horizon,
                f"{row['config']}: loss equals forward's, all samples finite",
                relative_difference([row["loss"]], [forward["loss"]]),
                tol["loss_between_configs"],
                ok=row["failed_samples"] == 0,
                failed_samples=row["failed_samples"],
            )
            if row["grad"] is not None and (row["checkpoint"] is not True or row["stream"]):
                other = reverse if row["mode"] == "reverse" else jacfwd
                check(
                    horizon,
                    f"{row['config']}: gradient equals {other['config']}'s",
                    relative_difference(row["grad"], other["grad"]),
                    tol["grad_checkpoint_vs_not"],
                )
    forward = find(rows, args.horizons[0], "forward")
    if not args.no_library_check and forward is not None:
        value = library_loss(args, args.horizons[0])
        check(
            args.horizons[0],
            "loss equals jaxatt.tune.SettlingObjective's (Mean, no penalties)",
            relative_difference([value], [forward["loss"]]),
            tol["loss_vs_SettlingObjective"],
            library_loss=value,
        )
    return checks


def memory_growth(rows, args) -> dict:
    """Per configuration: MiB per 1000 steps between the shortest and the longest horizon, of
    the peak RSS and of XLA's temp estimate (the RSS of small runs is the compiler's)."""
    growth = {}
    if len(args.horizons) < 2:
        return growth
    h0, h1 = min(args.horizons), max(args.horizons)
    for name in args.configs:
        a = next((r for r in rows if r["horizon"] == h0 and r["config"] == name), None)
        b = next((r for r in rows if r["horizon"] == h1 and r["config"] == name), None)
        if a is None or b is None or "xla_memory" not in a or "xla_memory" not in b:
            continue
        per_kstep = 1000 / (b["steps"] - a["steps"])
        temp = [r["xla_memory"].get("temp_size_in_bytes", 0) / 2**20 for r in (a, b)]
        growth[name] = {"xla_temp_mib_per_1000_steps": per_kstep * (temp[1] - temp[0])}
        if "run_s" in a and "run_s" in b:
            rss = b["peak_minus_baseline_mib"] - a["peak_minus_baseline_mib"]
            growth[name]["rss_mib_per_1000_steps"] = per_kstep * rss
    return growth


def main(args) -> int:
    if args.child is not None:
        out = child(args, json.loads(args.child))
        pathlib.Path(args.child_out).write_text(json.dumps(out))
        return 0

    common.enable_precision(args.dtype)
    meta = common.machine_meta()
    if args.max_temp_gib is None:
        args.max_temp_gib = 0.6 * (meta["cpu"]["mem_available_gib"] or 8.0)
    f64 = args.dtype == "float64"
    tol = {
        "grad_reverse_vs_jacfwd": 1e-6 if f64 else 1e-3,
        "grad_checkpoint_vs_not": 1e-9 if f64 else 1e-4,
        "loss_between_configs": 1e-12 if f64 else 1e-5,
        "loss_vs_SettlingObjective": 1e-12 if f64 else 1e-5,
    }
    common.print_meta(
        meta,
        f"M1 gradient of the mean convergence time of ||e_v|| < {TOLERANCE:g} over {args.batch} "
        f"samples w.r.t. (rho, eta, lambda, p1/q1, q2/p2); RK4 dt {args.dt} s, save every "
        f"{args.save_every} steps ({args.save_every * args.dt * 1e3:g} ms), horizons "
        f"{args.horizons} s, {args.dtype}; one fresh subprocess per configuration; "
        f"configurations whose XLA temp estimate exceeds {args.max_temp_gib:.3g} GiB are not run",
    )
    baseline = spawn(args, {"mode": "baseline"})
    if "error" in baseline:
        print("baseline child:", baseline["error"])
        return 1
    print(f"baseline child (imports + inputs): peak RSS {baseline['rss_peak_mib']:.0f} MiB")
    rows = run_configurations(args, baseline["rss_peak_mib"])
    checks = check_rows(rows, args, tol)
    growth = memory_growth(rows, args)

    print_table(rows, args, meta)
    for name, g in growth.items():
        rss = g.get("rss_mib_per_1000_steps")
        print(
            f"memory growth {name:>24}: {common.fmt(rss)} MiB of peak RSS and "
            f"{g['xla_temp_mib_per_1000_steps']:.3g} MiB of XLA temp per 1000 steps"
        )
    print()
    for c in checks:
        verdict = "ok" if c["ok"] else "FAILED"
        print(
            f"check T = {c['horizon']:g} s: {c['what']}: {c['value']:.3g} "
            f"(tolerance {c['tolerance']:g}): {verdict}"
        )
    result = {
        "benchmark": "chen2022 M1 gradient of the mean settling time: reverse vs forward mode",
        "units": {
            "time": "s (run: min over timed repeats after a warm-up)",
            "memory": "MiB (peak RSS of the child minus the baseline child's)",
        },
        "settings": {
            **{k: v for k, v in vars(args).items() if k not in ("child", "child_out", "argv")},
            "tolerance": TOLERANCE,
            "objective": "mean over the batch of convergence_time(||e_v||, 1e-3) (time outside "
            "the band plus the extrapolated remaining decay; SettlingObjective's objective_time) "
            "by jaxatt.montecarlo.run_batch",
            "parameters": "chen2022_tuning.parameters() via jaxatt.tune.apply",
            "check_tolerances": tol,
        },
        "baseline": baseline,
        "rows": rows,
        "memory_growth": growth,
        "checks": checks,
    }
    return common.finish(result, meta, args.out, all(c["ok"] for c in checks))


def print_table(rows, args, meta) -> None:
    header = [
        ("T s", 5),
        ("config", 24),
        ("compile s", 9),
        ("run s", 9),
        ("x forward", 9),
        ("peak MiB", 8),
        ("after compile MiB", 17),
        ("XLA temp MiB", 12),
    ]
    line = " | ".join(f"{name:>{width}}" for name, width in header)
    print()
    print(
        f"Measured on {meta['device_kind']} ({meta['cpu']['model']}, {meta['cpu_count']} CPUs), "
        f"{args.dtype}, batch {args.batch}, {meta['date']}"
    )
    print(line)
    print("-" * len(line))
    for row in rows:
        if "error" in row:
            print(f"{row['horizon']:>5g} | {row['config']:>24} | {row['error'][:80]}")
            continue
        temp = row["xla_memory"].get("temp_size_in_bytes", float("nan")) / 2**20
        cells = [
            f"{row['horizon']:>5g}",
            f"{row['config']:>24}",
            f"{row['compile_s']:>9.2f}",
            f"{common.fmt(row.get('run_s'), '.4g'):>9}",
            f"{common.fmt(row.get('ratio_to_forward'), '.3g'):>9}",
            f"{row['peak_minus_baseline_mib']:>8.0f}",
            f"{row['compile_minus_baseline_mib']:>17.0f}",
            f"{temp:>12.4g}",
        ]
        print(" | ".join(cells) + (f"  ({row['skipped']})" if "skipped" in row else ""))
    print(
        "  peak MiB = child's max RSS at its end minus the baseline child's (imports + inputs); "
        "after compile MiB = the same right after compiling (XLA's compilation included); "
        "XLA temp = compiled.memory_analysis().temp_size_in_bytes; x forward = run time over "
        "the forward run's at the same horizon"
    )


if __name__ == "__main__":
    sys.exit(main(parse_args()))
