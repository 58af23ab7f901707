"""Cost of the batched Chen 2022 M1 Monte Carlo against batch size and against horizon.

**Closed loop.** `jaxatt.scenarios.chen2022_two_phase_power.build("M1")` (classic RK4,
dt = 1e-3 s, 30 N m per-axis saturation), initial states from
`jaxatt.scenarios.chen2022_tuning.initial_states(jr.key(seed), n)`.

**What runs.** `_quick.make_jaxatt(call, T, dt, save_every)`: with `--jaxatt-call
monte_carlo_default` (default) `eqx.filter_jit` of `jaxatt.montecarlo.monte_carlo(loop, x0s,
0, T, dt=dt)`, every option at its default, what users call first (default metrics reduced on
the fly at every step, nothing saved; from 1000 samples on it runs the loop with
`performance=Performance(scalarize=True)`, so the batch sweep shows that switch; the final
states for the checks come from a separate, untimed call keeping one save at T); with
`monte_carlo` the former configuration, `monte_carlo(loop, x0s, 0, T, dt=dt, save_every=S,
keep_trajectories=True)`; with `monte_carlo_plain` that call with
`performance=jaxatt.simulation.Performance(scalarize=False)`, the plain vmapped program at
every batch. The loop is an argument, `S` is the largest divisor of the step count not above
steps/10 (11 saves).

1. **Batch sweep** (`--batches`, at `--horizon`): compile time, run time, state-steps per
   second (batch x RK4 steps / run time), time per step (run time / steps: one step of the whole
   batch) and per state-step. The output says where the throughput saturates: the smallest
   batch within 10 % of the best rate, and whether larger batches lose rate again.
2. **Horizon sweep** (`--horizons`, at `--horizon-batch`): the same against the horizon; the run
   time should be linear in the steps and the compile time independent of them.
3. **Chunks** (`--chunk`): at the largest batch over `--chunk-horizon` (2 s),
   `monte_carlo(loop, x0s, 0, T, dt=dt, batch_size=B)` (`lax.map` over chunks of B vmapped
   samples, default metrics streamed at every step; with `save_every=S` added unless the call
   is `monte_carlo_default`) for each B in `--chunk-sizes`, against the same call with
   `batch_size=None`: whether cache-sized chunks beat one vmap of everything.

Timing as in `bench_montecarlo.py`: ahead-of-time `lower(...).compile()` timed alone, one
warm-up call, then `min(timeit.repeat(lambda: jax.block_until_ready(f(loop, x0s)), number=1,
repeat=R))`, fewer repeats when they would take over `--max-seconds` (0: the warm-up call is
the measurement).

Figures: `<JSON stem>_batch.png` and `<JSON stem>_horizon.png` next to the JSON file
(`benchmarks/results/scaling_batch.png` and `scaling_horizon.png` by default).

**Checks** (exit code 1 when one fails): no sample has a non-finite state; the final states of
each smaller batch equal those of the same samples in the largest batch (1e-9; float32 1e-4);
chunked `monte_carlo` gives the unchunked metrics (1e-9; float32 1e-4; relative to the metric
where it exceeds 1, as for the effort, ~1e3) when both run the same program. Chunks under
`jaxatt.simulation.SCALARIZE_FROM` = 1000 samples are not scalarized while the unchunked batch
is: their difference is reported, not checked (their final states agree to ulps, but over a
sliding phase the two programs' rounding differences grow transiently: 6.8e-9 of the effort of
one sample in 16384 over 2 s, measured).

**Recorded defaults** (estimated 8 to 12 minutes on 2 cores, half of it the batch-16384 runs):

    python benchmarks/bench_scaling.py --chunk
    # batches 1 4 16 64 256 1024 4096 16384 at 10 s; horizons 1 3 10 30 s at batch 1024;
    # chunks 256 1024 4096 (and none) at batch 16384 over 2 s

A small run (about 2 minutes on a loaded 2-core machine):

    python benchmarks/bench_scaling.py --batches 1 16 256 --horizon 0.5 --horizons 0.25 0.5 1 \
        --horizon-batch 64 --chunk --chunk-sizes 64 --chunk-horizon 0.5 --repeat 1
"""

import argparse
import pathlib
import sys

import jax
import numpy as np


try:  # imported as `benchmarks.bench_scaling`
    from . import _common as common
except ImportError:  # run as a script: benchmarks/ is sys.path[0]
    import _common as common


SATURATION = 0.9
"""Throughput saturates at the smallest batch reaching this fraction of the best rate."""


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[1, 4, 16, 64, 256, 1024, 4096, 16384])
    p.add_argument("--horizon", type=float, default=10.0, help="horizon of the batch sweep [s]")
    p.add_argument("--horizons", type=float, nargs="+", default=[1.0, 3.0, 10.0, 30.0], help="[s]")
    p.add_argument("--horizon-batch", type=int, default=1024, help="batch of the horizon sweep")
    p.add_argument(
        "--jaxatt-call",
        choices=sorted(common.montecarlo.JAXATT_CALLS),
        default="monte_carlo_default",
    )
    p.add_argument("--chunk", action="store_true", help="also time lax.map chunk sizes")
    p.add_argument("--chunk-sizes", type=int, nargs="+", default=[256, 1024, 4096])
    p.add_argument(
        "--chunk-batch", type=int, default=None, help="batch of the chunk study (default max)"
    )
    p.add_argument(
        "--chunk-horizon", type=float, default=2.0, help="horizon of the chunk study [s]"
    )
    p.add_argument("--no-plot", action="store_true", help="skip the figures")
    common.add_common_arguments(p)
    args = p.parse_args(argv)
    common.finish_arguments(
        p, args, [args.horizon, *args.horizons, args.chunk_horizon], "scaling.json"
    )
    if args.chunk_batch is None:
        args.chunk_batch = max(args.batches)
    sizes = [*args.batches, args.horizon_batch, args.chunk_batch, *args.chunk_sizes]
    if min(sizes) < 1:
        p.error("batch and chunk sizes must be positive")
    return args


def measure(run, loop, x0s, steps: int, args) -> tuple[dict, object]:
    """One row: compile and run time, rates; and the output of the call."""
    compile_s, run_s, out, n = common.time_jax(run, (loop, x0s), args.repeat, args.max_seconds)
    batch = jax.tree_util.tree_leaves(x0s)[0].shape[0]
    row = {
        "batch": batch,
        "steps": steps,
        "compile_s": compile_s,
        "run_s": run_s,
        "timed_repeats": n,
        "state_steps_per_s": batch * steps / run_s,
        "time_per_step_s": run_s / steps,
        "time_per_state_step_s": run_s / (batch * steps),
    }
    return row, out


def finite_diff(a, b) -> float:
    """max |a - b| / max(1, |b|) where both are finite (an absolute difference for entries of
    order one or less, a relative one for larger metrics such as the effort, ~1e3 N^2 m^2 s);
    inf if they are not finite at the same places."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    finite = np.isfinite(b)
    if not np.array_equal(finite, np.isfinite(a)):
        return float("inf")
    scale = np.maximum(1.0, np.abs(b[finite]))
    return float(np.max(np.abs(a[finite] - b[finite]) / scale, initial=0.0))


def figure_path(args, sweep: str) -> pathlib.Path:
    """`<JSON stem>_<sweep>.png` next to the JSON file (results/scaling_batch.png by default)."""
    out = pathlib.Path(args.out)
    return out.with_name(f"{out.stem}_{sweep}.png")


def saturation(rows) -> dict:
    """Where the state-step rate stops growing with the batch."""
    rates = [r["state_steps_per_s"] for r in rows]
    best = max(range(len(rows)), key=lambda k: rates[k])
    first = next(k for k in range(len(rows)) if rates[k] >= SATURATION * rates[best])
    last = len(rows) - 1
    return {
        "best_batch": rows[best]["batch"],
        "best_rate": rates[best],
        "saturation_batch": rows[first]["batch"],
        "saturation_fraction": SATURATION,
        "largest_batch": rows[last]["batch"],
        "largest_batch_rate_fraction_of_best": rates[last] / rates[best],
    }


def describe_saturation(s: dict) -> str:
    if s["saturation_batch"] == s["largest_batch"]:
        return (
            f"throughput has not saturated by batch {s['largest_batch']}: only the largest batch "
            f"reaches {100 * s['saturation_fraction']:.0f} % of the best rate "
            f"({s['best_rate']:.3g} state-steps/s at batch {s['best_batch']})"
        )
    text = (
        f"throughput saturates at batch {s['saturation_batch']} (the smallest batch within "
        f"{100 * (1 - s['saturation_fraction']):.0f} % of the best rate, "
        f"{s['best_rate']:.3g} state-steps/s at batch {s['best_batch']})"
    )
    fraction = s["largest_batch_rate_fraction_of_best"]
    if s["largest_batch"] == s["best_batch"]:
        return text + f"; larger batches add less than 10 % up to batch {s['largest_batch']}"
    if fraction < s["saturation_fraction"]:
        return text + (
            f"; beyond batch {s['best_batch']} the rate falls again, to {100 * fraction:.0f} % "
            f"of the best at batch {s['largest_batch']} (most likely a cache effect: see "
            "--chunk)"
        )
    return text + f"; the rate stays within 10 % of it up to batch {s['largest_batch']}"


def plot_batch(rows, sat, args, meta, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    batches = [r["batch"] for r in rows]
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    ax0.loglog(batches, [r["state_steps_per_s"] for r in rows], "o-", label="jaxatt M1")
    ax0.axvline(sat["saturation_batch"], color="0.6", ls=":", label="saturation (90 % of best)")
    ax0.set_xlabel("batch size")
    ax0.set_ylabel("state-steps per second")
    ax0.legend()
    ax1.loglog(batches, [r["time_per_step_s"] * 1e6 for r in rows], "o-", label="one batch step")
    ax1.loglog(
        batches, [r["time_per_state_step_s"] * 1e9 for r in rows], "s--", label="per state-step"
    )
    ax1.set_xlabel("batch size")
    ax1.set_ylabel("time per RK4 step: batch [us], per sample [ns]")
    ax1.legend()
    fig.suptitle(
        f"Chen 2022 M1, RK4 dt = {args.dt:g} s, T = {args.horizon:g} s, {args.dtype}, "
        f"{meta['device_kind']} ({meta['cpu']['model']}, {meta['cpu_count']} CPUs)"
    )
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_horizon(rows, args, meta, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    horizons = [r["horizon"] for r in rows]
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    ax0.loglog(horizons, [r["run_s"] for r in rows], "o-", label="run")
    ax0.loglog(horizons, [r["compile_s"] for r in rows], "s--", label="compile")
    ax0.set_xlabel("horizon [s]")
    ax0.set_ylabel("time [s]")
    ax0.legend()
    ax1.semilogx(horizons, [r["state_steps_per_s"] for r in rows], "o-")
    ax1.set_xlabel("horizon [s]")
    ax1.set_ylabel("state-steps per second")
    ax1.set_ylim(bottom=0)
    fig.suptitle(
        f"Chen 2022 M1, batch {args.horizon_batch}, RK4 dt = {args.dt:g} s, {args.dtype}, "
        f"{meta['device_kind']} ({meta['cpu']['model']}, {meta['cpu_count']} CPUs)"
    )
    fig.savefig(path, dpi=120)
    plt.close(fig)


def batch_sweep(loop, pool, args) -> tuple[list[dict], float]:
    """Rows of the batch sweep, and the largest difference of a smaller batch's final states
    from those of the same samples in the largest batch."""
    steps = common.steps_of(args.horizon, args.dt)
    run = common.montecarlo.make_jaxatt(
        args.jaxatt_call, args.horizon, args.dt, common.default_save_every(steps)
    )
    rows, finals = [], []
    print(f"batch sweep, T = {args.horizon:g} s ({steps} steps):")
    for batch in sorted(args.batches):
        x0s = common.take(pool, batch)
        row, (final, successful, _) = measure(run, loop, x0s, steps, args)
        if final is None:  # the default call keeps no trajectory: final states from another call
            check = common.montecarlo.make_jaxatt("monte_carlo", args.horizon, args.dt, steps)
            final = check(loop, x0s)[0]
        row["failed_samples"] = int(np.sum(~np.asarray(successful)))
        finals.append(np.asarray(final))
        rows.append(row)
        print(
            f"  batch {batch:>6}: compile {row['compile_s']:.2f} s, run {row['run_s']:.4g} s, "
            f"{row['state_steps_per_s']:.3g} state-steps/s, "
            f"{row['time_per_state_step_s'] * 1e9:.3g} ns per state-step",
            flush=True,
        )
    diffs = [common.montecarlo.max_abs_diff(f, finals[-1][: len(f)]) for f in finals[:-1]]
    return rows, max(diffs, default=0.0)


def horizon_sweep(loop, pool, args) -> tuple[list[dict], float | None]:
    """Rows of the horizon sweep, and the exponent of run time ~ steps^a (least squares)."""
    rows = []
    x0s = common.take(pool, args.horizon_batch)
    print(f"horizon sweep, batch {args.horizon_batch}:")
    for horizon in sorted(args.horizons):
        steps = common.steps_of(horizon, args.dt)
        run = common.montecarlo.make_jaxatt(
            args.jaxatt_call, horizon, args.dt, common.default_save_every(steps)
        )
        row, (_, successful, _) = measure(run, loop, x0s, steps, args)
        row["horizon"] = horizon
        row["failed_samples"] = int(np.sum(~np.asarray(successful)))
        rows.append(row)
        print(
            f"  T = {horizon:>6g} s: compile {row['compile_s']:.2f} s, run {row['run_s']:.4g} s, "
            f"{row['state_steps_per_s']:.3g} state-steps/s, "
            f"{row['time_per_step_s'] * 1e6:.3g} us per batch step",
            flush=True,
        )
    if len(rows) < 2:
        return rows, None
    log_steps = np.log([r["steps"] for r in rows])
    slope = float(np.polyfit(log_steps, np.log([r["run_s"] for r in rows]), 1)[0])
    print(f"  run time ~ steps^{slope:.3f} (1 = linear)")
    return rows, slope


def chunk_study(loop, pool, args) -> tuple[list[dict], float | None]:
    """Rows of `monte_carlo(..., batch_size=B)` for B = None and `--chunk-sizes`, and the
    largest difference of a chunked run's metrics from the unchunked ones."""
    import equinox as eqx

    from jaxatt.montecarlo import monte_carlo
    from jaxatt.simulation import Performance, samples_at_once

    steps = common.steps_of(args.chunk_horizon, args.dt)
    saving = (
        {}
        if args.jaxatt_call == "monte_carlo_default"
        else {"save_every": common.default_save_every(steps)}
    )
    x0s = common.take(pool, args.chunk_batch)
    print(
        f"chunks: monte_carlo(..., batch_size=B) at batch {args.chunk_batch}, "
        f"T = {args.chunk_horizon:g} s (default metrics only):"
    )
    rows, reference, reference_scalarized, worst = [], None, None, None
    for size in [None, *sorted(args.chunk_sizes)]:

        @eqx.filter_jit
        def chunked(loop, x0s, size=size):
            out = monte_carlo(
                loop,
                x0s,
                0.0,
                args.chunk_horizon,
                dt=args.dt,
                batch_size=size,
                **saving,
            )
            return out.metrics, out.successful

        row, (metrics, successful) = measure(chunked, loop, x0s, steps, args)
        row["batch_size"] = size
        at_once = samples_at_once(args.chunk_batch, batch_size=size, devices=len(jax.devices()))
        row["scalarized"] = Performance().resolve(at_once).scalarize  # what monte_carlo decides
        row["failed_samples"] = int(np.sum(~np.asarray(successful)))
        metrics = {k: np.asarray(v) for k, v in metrics.items()}
        note = ""
        if reference is None:
            reference, reference_scalarized = metrics, row["scalarized"]
        else:
            row["max_scaled_diff_metrics"] = max(
                finite_diff(metrics[k], ref) for k, ref in reference.items()
            )
            note = f", metrics differ by {row['max_scaled_diff_metrics']:.3g}"
            # Chunking alone must not change a number; a chunk that runs the other program
            # (plain vs scalarized) is reported only: over a sliding phase, rounding
            # differences between the two grow (|s|^a with a < 1 is steep near s = 0).
            if row["scalarized"] == reference_scalarized:
                worst = max(worst or 0.0, row["max_scaled_diff_metrics"])
            else:
                note += " (other program: reported, not checked)"
        rows.append(row)
        print(
            f"  batch_size {size or 'None':>6}: scalarized {row['scalarized']}, compile "
            f"{row['compile_s']:.2f} s, run {row['run_s']:.4g} s, "
            f"{row['state_steps_per_s']:.3g} state-steps/s{note}",
            flush=True,
        )
    for row in rows:
        row["speedup_over_unchunked"] = row["state_steps_per_s"] / rows[0]["state_steps_per_s"]
    return rows, worst


def main(args) -> int:
    common.enable_precision(args.dtype)
    meta = common.machine_meta()
    call = common.montecarlo.JAXATT_CALLS[args.jaxatt_call]
    common.print_meta(
        meta,
        f"scenario chen2022_two_phase_power M1, RK4 dt {args.dt} s, {args.dtype}; jaxatt call "
        f"({args.jaxatt_call}): {call}; S = steps/10 (11 saves)",
    )
    tol = 1e-9 if args.dtype == "float64" else 1e-4
    biggest = max(*args.batches, args.horizon_batch, args.chunk_batch if args.chunk else 1)
    loop, pool = common.m1_setup(args.seed, biggest, args.dtype)

    batch_rows, batch_diff = batch_sweep(loop, pool, args)
    sat = saturation(batch_rows)
    print("  " + describe_saturation(sat))
    horizon_rows, slope = horizon_sweep(loop, pool, args)
    chunk_rows, chunk_diff = chunk_study(loop, pool, args) if args.chunk else ([], None)
    failed = sum(r["failed_samples"] for r in batch_rows + horizon_rows + chunk_rows)

    print_tables(batch_rows, horizon_rows, chunk_rows, args, meta)
    print("  " + describe_saturation(sat))
    figures = []
    if not args.no_plot:
        path = figure_path(args, "batch")
        path.parent.mkdir(parents=True, exist_ok=True)
        plot_batch(batch_rows, sat, args, meta, path)
        figures.append(str(path))
        if horizon_rows:
            path = figure_path(args, "horizon")
            plot_horizon(horizon_rows, args, meta, path)
            figures.append(str(path))
        print("figures:", ", ".join(figures))

    checks = {
        "failed_samples": failed,
        "max_abs_diff_final_state_across_batches": batch_diff,
        "max_scaled_diff_chunked_metrics_same_program": chunk_diff,
        "tolerance": tol,
    }
    ok = failed == 0 and batch_diff <= tol and (chunk_diff is None or chunk_diff <= tol)
    print()
    print(f"check: samples with a non-finite state: {failed}")
    print(
        "check: max |final state| difference of each smaller batch from the same samples of "
        f"batch {max(args.batches)}: {batch_diff:.3g} (tolerance {tol:g})"
    )
    if chunk_diff is not None:
        print(
            "check: max |chunked - unchunked| / max(1, |unchunked|) metrics, chunks running "
            "the unchunked program: "
            f"{chunk_diff:.3g} (tolerance {tol:g})"
        )
    result = {
        "benchmark": "chen2022 M1 Monte Carlo scaling with batch size and horizon",
        "units": {
            "rate": "state-steps per second (batch x RK4 steps / run wall time)",
            "time_per_step_s": "run time / RK4 steps (one step of the whole batch)",
        },
        "settings": {**vars(args), "jaxatt_call_code": call, "saturation_fraction": SATURATION},
        "batch_sweep": batch_rows,
        "saturation": sat,
        "horizon_sweep": horizon_rows,
        "run_time_exponent_in_steps": slope,
        "chunks": chunk_rows,
        "figures": figures,
        "checks": checks,
    }
    return common.finish(result, meta, args.out, ok)


def print_tables(batch_rows, horizon_rows, chunk_rows, args, meta) -> None:
    def table(title, key, rows, extra=()):
        columns = [
            (key, 10),
            ("compile s", 9),
            ("run s", 9),
            ("st-st/s", 9),
            ("us / step", 9),
            ("ns / st-st", 10),
            *extra,
        ]
        line = " | ".join(f"{name:>{width}}" for name, width in columns)
        print()
        print(title)
        print(line)
        print("-" * len(line))
        for row in rows:
            label = row[key] if row[key] is not None else "None"
            cells = [
                f"{label:>10}",
                f"{row['compile_s']:>9.2f}",
                f"{row['run_s']:>9.4g}",
                f"{row['state_steps_per_s']:>9.3g}",
                f"{row['time_per_step_s'] * 1e6:>9.4g}",
                f"{row['time_per_state_step_s'] * 1e9:>10.4g}",
            ]
            cells += [f"{common.fmt(row.get(name), '.3g'):>{width}}" for name, width in extra]
            print(" | ".join(cells))

    where = f"{meta['device_kind']} ({meta['cpu']['model']}, {meta['cpu_count']} CPUs)"
    table(
        f"batch sweep, T = {args.horizon:g} s, {args.dtype}, measured on {where}, {meta['date']}",
        "batch",
        batch_rows,
    )
    if horizon_rows:
        table(f"horizon sweep, batch {args.horizon_batch}", "horizon", horizon_rows)
    if chunk_rows:
        table(
            f"chunks, batch {args.chunk_batch}, T = {args.chunk_horizon:g} s (monte_carlo, "
            "metrics only)",
            "batch_size",
            chunk_rows,
            extra=[("speedup_over_unchunked", 22)],
        )
    print(
        "  st-st/s = state-steps per second; us / step = run time per RK4 step of the whole "
        "batch; ns / st-st = run time per state-step; run s = min over up to "
        f"{args.repeat} repeats after a warm-up (fewer over {args.max_seconds:g} s)"
    )


if __name__ == "__main__":
    sys.exit(main(parse_args()))
