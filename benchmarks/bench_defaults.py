"""Default-argument `monte_carlo` against the hand scan, and against main c16db23 (issue 18).

What a user gets without tuning anything: `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T,
dt=1e-3)` on Chen et al. (2022)'s closed loop M1 (default metrics, nothing else), timed
against the hand-written elementwise `lax.scan` of the same equations (`_reference.py`) in the
same process, at batches 1000, 3000 and 10 000, float64. The same measurement is made by a
second process that imports the library as it was at a baseline commit (default `c16db23`,
main before issue 18, unpacked with `git archive` into a temporary folder), so that the speed-up
over it and the equality of its results are measured in one run of this script.

Each worker process (one per library version, run one after the other, baseline first) times
for every batch: `default` (the call above), `sparse` (`save_every` = all steps: the sparsest
save, what the default aims to match) and the hand `scan`; the two jaxatt calls run inside a
`jit` compiled with the XLA options `monte_carlo` passes when called eagerly (none in libraries
before them; `_quick.UserProgram`); compile time (ahead-of-time lower +
compile) apart from run time (warm-up, then `--repeat` rounds of one call of each program in
turn, min per program: the three share the machine's load changes). Throughput in
state-steps per second (batch x RK4 steps / run time). Ratios `default/scan` are within one
process; `new/baseline` across the two processes, minutes apart, with the scan rates of both
reported as a check of how much the machine changed in between.

Checks (exit 1 on failure): the default metrics of the two versions agree to `--rtol` (1e-12)
relative with the same inf/NaN pattern, and so do the final states (from an untimed
`keep_trajectories=True, save_every=all steps` call); the final states agree with the hand
scan to 1e-9.

Usage (from the repository root; 2 s horizon as issue 18's measurements):

    python benchmarks/bench_defaults.py                  # -> results/defaults.json
    python benchmarks/bench_defaults.py --batches 1000 --horizon 0.5 --no-baseline  # smoke
"""

import argparse
import json
import os
import pathlib
import sys
import tempfile
import time

from _baseline import run_version, unpack_source


HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
DT = 1e-3


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[1000, 3000, 10000])
    p.add_argument("--horizon", type=float, default=2.0, help="simulated time [s]")
    p.add_argument("--repeat", type=int, default=3, help="timed calls per program (min)")
    p.add_argument("--max-seconds", type=float, default=40.0, help="cap on timed calls' time")
    p.add_argument("--baseline-commit", default="c16db23")
    p.add_argument("--no-baseline", action="store_true", help="skip the baseline process")
    p.add_argument("--rtol", type=float, default=1e-12)
    p.add_argument("--float32", action="store_true", help="run the workers in float32")
    p.add_argument(
        "--float32-accuracy",
        action="store_true",
        help="also run this checkout in float32 (x64 off) and report its speed and its "
        "metrics' and final states' differences to the float64 run",
    )
    p.add_argument("--out", default=str(HERE / "results" / "defaults.json"))
    p.add_argument("--worker", help=argparse.SUPPRESS)  # path of a worker's output (.npz)
    p.add_argument("--x0-from", help=argparse.SUPPRESS)  # a worker's output: its samples
    return p.parse_args(argv)


def worker(args) -> None:
    """Time one library version (whatever `import jaxatt` finds) and save rows and results."""
    import jax

    if not args.float32:
        jax.config.update("jax_enable_x64", True)
    import _quick
    import _reference as ref
    import jax.numpy as jnp
    import numpy as np

    import jaxatt
    from jaxatt.montecarlo import monte_carlo
    from jaxatt.plants import QuaternionState
    from jaxatt.scenarios import chen2022_two_phase_power as chen

    dtype = np.dtype(jnp.result_type(float))
    horizon, n_steps = args.horizon, round(args.horizon / DT)
    loop = chen.build("M1")
    _quick.check_scenario(loop)
    if args.x0_from:  # the float64 worker's samples, rounded (a float32 process draws others)
        with np.load(args.x0_from) as saved:
            q, omega = saved["x0/q"].astype(dtype), saved["x0/omega"].astype(dtype)
    else:
        q, omega = _quick.initial_states(0, max(args.batches), dtype)
    arrays_x0 = {"x0/q": q, "x0/omega": omega}

    # Each jit gets the XLA options monte_carlo passes when called eagerly (none before them).
    @_quick.UserProgram
    def default(loop, x0s):
        return monte_carlo(loop, x0s, 0.0, horizon, dt=DT)

    @_quick.UserProgram
    def sparse(loop, x0s):
        return monte_carlo(loop, x0s, 0.0, horizon, dt=DT, save_every=n_steps)

    @_quick.UserProgram
    def final_states(loop, x0s):
        out = monte_carlo(
            loop, x0s, 0.0, horizon, dt=DT, save_every=n_steps, keep_trajectories=True
        )
        s = out.trajectories.states
        return jnp.concatenate([s.plant.q[:, -1], s.plant.omega[:, -1], s.reference[:, -1]], -1)

    scan = ref.make_hand_scan(n_steps, DT, dtype)
    rows, arrays = [], {}
    for batch in args.batches:
        x0s = QuaternionState(jnp.asarray(q[:batch]), jnp.asarray(omega[:batch]))
        row = {"batch": batch, "rk4_steps": n_steps}
        programs = {
            "default": (default, (loop, x0s)),
            "sparse": (sparse, (loop, x0s)),
            "scan": (scan, (x0s.q, x0s.omega)),
        }
        compiled, outs, best = {}, {}, {}
        for name, (f, f_args) in programs.items():
            start = time.perf_counter()
            compiled[name] = f.lower(*f_args).compile()
            row[name] = {"compile_s": time.perf_counter() - start}
            start = time.perf_counter()
            outs[name] = jax.block_until_ready(compiled[name](*f_args))  # warm-up
            best[name] = time.perf_counter() - start
        # Interleaved repeats (round robin), min per program: the machine's load changes.
        repeats = min(args.repeat, int(args.max_seconds // sum(best.values())))
        for _ in range(repeats):
            for name, (_, f_args) in programs.items():
                start = time.perf_counter()
                jax.block_until_ready(compiled[name](*f_args))
                best[name] = min(best[name], time.perf_counter() - start)
        for name in programs:
            row[name].update(
                run_s=best[name],
                state_steps_per_s=batch * n_steps / best[name],
                timed_repeats=repeats,
            )
            print(f"  batch {batch} {name}: {row[name]}", file=sys.stderr, flush=True)
        for metric, value in outs["default"].metrics.items():
            arrays[f"{batch}/metric/{metric}"] = np.asarray(value)
        arrays[f"{batch}/status"] = np.asarray(outs["default"].status)
        arrays[f"{batch}/scan_final"] = np.asarray(outs["scan"])
        arrays[f"{batch}/final"] = np.asarray(final_states(loop, x0s))
        row["ratio_default_scan"] = (
            row["default"]["state_steps_per_s"] / row["scan"]["state_steps_per_s"]
        )
        row["ratio_sparse_scan"] = (
            row["sparse"]["state_steps_per_s"] / row["scan"]["state_steps_per_s"]
        )
        rows.append(row)
    info = {
        "jaxatt_file": jaxatt.__file__,
        "dtype": dtype.name,
        "device": str(jax.devices()[0]),
        "device_kind": jax.devices()[0].device_kind,
        "jax": jax.__version__,
        "load_average": os.getloadavg(),
        "rows": rows,
    }
    np.savez(args.worker, info=json.dumps(info), **arrays, **arrays_x0)


def run_worker(
    args, src: pathlib.Path, out: pathlib.Path, x0_from: pathlib.Path | None = None
) -> tuple[dict, dict]:
    import numpy as np

    cmd = [
        "--worker",
        str(out),
        "--batches",
        *map(str, args.batches),
        "--horizon",
        str(args.horizon),
    ]
    cmd += ["--repeat", str(args.repeat), "--max-seconds", str(args.max_seconds)]
    cmd += ["--float32"] if args.float32 else []
    cmd += ["--x0-from", str(x0_from)] if x0_from else []
    run_version(HERE / "bench_defaults.py", cmd, src)
    data = np.load(out)
    return json.loads(str(data["info"])), {k: data[k] for k in data.files if k != "info"}


def compare(a: dict, b: dict, rtol: float) -> dict:
    """Largest relative difference of every array both hold, and whether inf/NaN agree."""
    import numpy as np

    worst, per_sample, pattern = 0.0, 0.0, True
    for key in sorted(set(a) & set(b)):
        x, y = np.asarray(a[key], np.float64), np.asarray(b[key], np.float64)
        pattern &= bool(np.array_equal(np.isnan(x), np.isnan(y)))
        pattern &= bool(np.array_equal(np.isposinf(x), np.isposinf(y)))
        finite = np.isfinite(x) & np.isfinite(y)
        scale = np.maximum(np.abs(y[finite]), np.finfo(np.float64).tiny)
        if finite.any():
            worst = max(worst, float(np.max(np.abs(x[finite] - y[finite]) / scale)))
        if x.ndim == 2 and np.all(finite):  # final states: relative to each sample's largest
            diff = np.max(np.abs(x - y), axis=1) / np.max(np.abs(y), axis=1)
            per_sample = max(per_sample, float(np.max(diff)))
    return {
        "max_rel_diff": worst,
        "max_rel_diff_per_sample_norm": per_sample,
        "same_nonfinite": pattern,
        "passed": pattern and worst <= rtol,
    }


def float32_accuracy(batches, f32: dict, f64: dict) -> list[dict]:
    """Per batch: largest |float32 - float64| of each default metric (absolute, and relative
    to the float64 value) over the samples both finished, the samples whose settling
    verdict (finite or not) differs, and the largest final-state difference."""
    import numpy as np

    out = []
    for batch in batches:
        row = {"batch": batch}
        for key in sorted(k for k in f64 if k.startswith(f"{batch}/metric/")):  # same samples
            x, y = np.asarray(f32[key], np.float64), np.asarray(f64[key], np.float64)
            both = np.isfinite(x) & np.isfinite(y)
            name = key.rsplit("/", 1)[1]
            row[name] = {
                "max_abs_diff": float(np.max(np.abs(x - y)[both])) if both.any() else 0.0,
                "max_rel_diff": float(np.max(np.abs(x - y)[both] / np.abs(y[both])))
                if both.any()
                else 0.0,
                "finite_verdict_differs": int(np.sum(np.isfinite(x) != np.isfinite(y))),
            }
        final32, final64 = f32[f"{batch}/final"], f64[f"{batch}/final"]
        row["final_state_max_abs_diff"] = float(np.max(np.abs(final32 - final64)))
        out.append(row)
    return out


def main(args) -> int:
    if args.worker:
        sys.path.insert(0, str(HERE))
        worker(args)
        return 0
    import numpy as np

    result = {"command": " ".join(sys.argv), "horizon_s": args.horizon, "dt": DT}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        if not args.no_baseline:
            source = unpack_source(args.baseline_commit, tmp)
            start = time.time()
            base_info, base = run_worker(args, source, tmp / "base.npz")
            base_info["wall_s"] = time.time() - start
            result["baseline"] = dict(base_info, commit=args.baseline_commit)
        start = time.time()
        new_info, new = run_worker(args, ROOT / "src", tmp / "new.npz")
        new_info["wall_s"] = time.time() - start
        result["new"] = new_info
        if args.float32_accuracy and not args.float32:
            f32_info, f32 = run_worker(
                argparse.Namespace(**dict(vars(args), float32=True)),
                ROOT / "src",
                tmp / "f32.npz",
                x0_from=tmp / "new.npz",
            )
            result["float32"] = f32_info
            result["float32_vs_float64"] = float32_accuracy(args.batches, f32, new)
    checks = []
    for batch in args.batches:
        scan_tol = 1e-9 if new_info["dtype"] == "float64" else 1e-4
        diff = float(np.max(np.abs(new[f"{batch}/final"] - new[f"{batch}/scan_final"])))
        checks.append(
            {
                "batch": batch,
                "what": "final vs scan",
                "max_abs_diff": diff,
                "passed": diff <= scan_tol,
            }
        )
        if args.no_baseline:
            continue
        for what in ("metric", "final"):
            pick = {k: v for k, v in new.items() if k.startswith(f"{batch}/{what}")}
            ref = {k: v for k, v in base.items() if k.startswith(f"{batch}/{what}")}
            if set(pick) != set(ref):
                checks.append(
                    {
                        "batch": batch,
                        "what": what,
                        "passed": False,
                        "error": f"keys differ: {sorted(pick)} vs {sorted(ref)}",
                    }
                )
                continue
            checks.append(dict(compare(pick, ref, args.rtol), batch=batch, what=what))
    result["checks"] = checks

    print(
        f"\nChen 2022 M1, {args.horizon:g} s at dt {DT:g} s, {new_info['dtype']}; "
        "st-st/s = state-steps per second"
    )
    head = (
        f"{'batch':>6} | {'default':>9} | {'sparse':>9} | {'scan':>9} | {'def/scan':>8} | "
        f"{'main def':>9} | {'main scan':>9} | {'def/main':>8} | {'compile s':>9}"
    )
    print(head + "\n" + "-" * len(head))
    base_rows = {r["batch"]: r for r in result.get("baseline", {}).get("rows", [])}
    for row in new_info["rows"]:
        b = base_rows.get(row["batch"])
        rate = row["default"]["state_steps_per_s"]
        main_rate = b["default"]["state_steps_per_s"] if b else float("nan")
        main_scan = b["scan"]["state_steps_per_s"] if b else float("nan")
        row["ratio_default_main"] = rate / main_rate
        print(
            f"{row['batch']:>6} | {rate:>9.3g} | {row['sparse']['state_steps_per_s']:>9.3g} | "
            f"{row['scan']['state_steps_per_s']:>9.3g} | {row['ratio_default_scan']:>8.2f} | "
            f"{main_rate:>9.3g} | {main_scan:>9.3g} | {rate / main_rate:>8.2f} | "
            f"{row['default']['compile_s']:>9.1f}"
        )
    for check in checks:
        print("check:", check)
    if "float32" in result:
        for row32, row in zip(result["float32"]["rows"], new_info["rows"]):
            rate32 = row32["default"]["state_steps_per_s"]
            print(
                f"float32 batch {row32['batch']}: default {rate32:.3g} st-st/s "
                f"({rate32 / row['default']['state_steps_per_s']:.2f}x float64 in another "
                f"process; {row32['ratio_default_scan']:.2f}x the float32 scan)"
            )
        for row in result["float32_vs_float64"]:
            print("float32 vs float64:", row)
    pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(args.out).write_text(json.dumps(result, indent=1))
    print(f"wrote {args.out}")
    return 0 if all(c["passed"] for c in checks) else 1


if __name__ == "__main__":
    sys.exit(main(parse_args()))
