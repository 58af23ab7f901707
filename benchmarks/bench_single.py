"""One trajectory per family: `simulate`'s step time against a baseline commit of the library.

A notebook, a reproduction and most tests run one trajectory at a time, where XLA:CPU's
per-kernel and per-iteration costs, not arithmetic, set the speed. This script times, for
each family of `bench_scalarize_families.py` (its loops, initial states, dt and sampling),

    simulate(loop, x0, 0, steps * dt, dt=dt, sampling=sampling, save_every=k, throw=False)

for each k of `--save-every` (1: the default, every step saved; 100: a sparse save), in two
worker processes: the library of `--baseline-commit` (unpacked with `git archive` into a
temporary folder, as `bench_defaults.py` does) and this checkout, one after the other. Each
worker reports the first call (trace, compile, run) and the minimum over `--repeat` warm calls,
and the final state and status. Checks (exit 1 otherwise): the two versions' final states
agree to `--rtol` (relative to the largest entry of each state) and have the same status.

Usage (from the repository root):

    python benchmarks/bench_single.py                      # -> results/single.json
    python benchmarks/bench_single.py --families chen2022_m1 --save-every 1 100 1000
    python benchmarks/bench_single.py --small-loop-kernels --out results/small_loops.json

`--small-loop-kernels` compares this checkout with itself instead: the baseline worker under
XLA's default small-loop threshold, the new one after `jaxatt.enable_small_loop_kernels()`
(XLA:CPU compiles small time loops as one kernel; `XLA_FLAGS` must not set the threshold).
"""

import argparse
import json
import os
import pathlib
import sys
import tempfile
import time

from _baseline import run_both, run_version, write_result
from bench_scalarize_families import FAMILIES


HERE = pathlib.Path(__file__).resolve().parent


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--families", nargs="+", choices=FAMILIES, default=list(FAMILIES))
    p.add_argument("--steps", type=int, default=2000, help="steps per run")
    p.add_argument("--save-every", type=int, nargs="+", default=[1, 100])
    p.add_argument("--repeat", type=int, default=5, help="warm calls (min reported)")
    p.add_argument("--rtol", type=float, default=1e-12, help="final states, relative")
    p.add_argument("--baseline-commit", default="49ba081", help="git revision to compare to")
    p.add_argument("--out", default=str(HERE / "results" / "single.json"))
    p.add_argument(
        "--small-loop-kernels",
        action="store_true",
        help="this checkout without, then with jaxatt.enable_small_loop_kernels()",
    )
    p.add_argument("--worker", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.steps < 1 or args.repeat < 1 or any(k < 1 or args.steps % k for k in args.save_every):
        p.error("--steps and --repeat must be positive and every --save-every divide --steps")
    if args.small_loop_kernels and not args.worker:
        from jaxatt._small_loops import OPTION, threshold_in_flags

        if threshold_in_flags(os.environ.get("XLA_FLAGS", "")) is not None:
            p.error(f"--small-loop-kernels: XLA_FLAGS already sets {OPTION}")
    return args


def worker(args) -> None:
    import timeit

    import jax
    import numpy as np

    import jaxatt

    threshold = jaxatt.enable_small_loop_kernels() if args.small_loop_kernels else None
    jax.config.update("jax_enable_x64", True)
    from bench_scalarize_families import family

    from jaxatt import simulate

    rows = []
    for name in args.families:
        loop, x0, dt, sampling = family(name, args.steps)
        for every in args.save_every:

            def call(loop=loop, x0=x0, dt=dt, sampling=sampling, every=every):
                out = simulate(
                    loop,
                    x0,
                    0.0,
                    args.steps * dt,
                    dt=dt,
                    sampling=sampling,
                    save_every=every,
                    throw=False,
                )
                return jax.block_until_ready(out)

            start = time.perf_counter()
            trajectory = call()
            first_s = time.perf_counter() - start
            run_s = min(timeit.repeat(call, number=1, repeat=args.repeat))
            final = np.concatenate(
                [np.ravel(leaf[-1]) for leaf in jax.tree.leaves(trajectory.states)]
            )
            rows.append(
                {
                    "family": name,
                    "save_every": every,
                    "steps": args.steps,
                    "first_call_s": first_s,
                    "run_s": run_s,
                    "us_per_step": run_s / args.steps * 1e6,
                    "status": int(trajectory.status),
                    "final": final.tolist(),
                }
            )
            print(
                f"  {name:18s} save_every {every:5d}: first call {first_s:6.2f} s, "
                f"{rows[-1]['us_per_step']:8.2f} us per step",
                flush=True,
            )
    info = {
        "jaxatt": str(pathlib.Path(jaxatt.__file__).parent),
        "jax": jax.__version__,
        "small_loop_threshold": threshold,
        "load_average": os.getloadavg(),
        "rows": rows,
    }
    pathlib.Path(args.worker).write_text(json.dumps(info))


def run_worker(args, src: pathlib.Path, out: pathlib.Path, *, small_loops: bool = False) -> dict:
    cmd = ["--worker", str(out), "--families", *args.families, "--steps", str(args.steps)]
    cmd += ["--save-every", *map(str, args.save_every), "--repeat", str(args.repeat)]
    cmd += ["--small-loop-kernels"] if small_loops else []
    run_version(HERE / "bench_single.py", cmd, src)
    return json.loads(out.read_text())


def run_small_loops(args) -> tuple[dict, dict]:
    """This checkout under XLA's default small-loop threshold, then with the one-kernel loops."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        base = run_worker(args, HERE.parent / "src", tmp / "base.json")
        new = run_worker(args, HERE.parent / "src", tmp / "new.json", small_loops=True)
    return base, new


def main(args) -> int:
    if args.worker:
        sys.path.insert(0, str(HERE))
        worker(args)
        return 0
    import numpy as np

    if args.small_loop_kernels:
        base, new = run_small_loops(args)
        baseline = "XLA's default small-loop threshold"
        against = f"jaxatt.enable_small_loop_kernels() ({new['small_loop_threshold']} bytes)"
    else:
        base, new = run_both(run_worker, args, args.baseline_commit)
        baseline, against = args.baseline_commit, "this checkout"
    print()
    print(
        f"One trajectory, {args.steps} steps, float64; baseline {baseline} against {against} "
        "(us per step: min of the warm calls; first: trace + compile + run)"
    )
    print(
        " family             | save_every | baseline us | new us | speed-up | baseline first s "
        "| new first s | max rel diff | status"
    )
    rows, ok = [], True
    for b, n in zip(base["rows"], new["rows"]):
        a, c = np.asarray(b["final"]), np.asarray(n["final"])
        diff = float(np.max(np.abs(a - c)) / max(np.max(np.abs(a)), 1e-300))
        same = b["status"] == n["status"] and diff <= args.rtol
        ok &= same
        row = {
            "family": b["family"],
            "save_every": b["save_every"],
            "baseline_us_per_step": b["us_per_step"],
            "new_us_per_step": n["us_per_step"],
            "speedup": b["us_per_step"] / n["us_per_step"],
            "baseline_first_call_s": b["first_call_s"],
            "new_first_call_s": n["first_call_s"],
            "max_relative_difference": diff,
            "status": [b["status"], n["status"]],
        }
        rows.append(row)
        print(
            f" {row['family']:18s} | {row['save_every']:10d} | {b['us_per_step']:11.2f} "
            f"| {n['us_per_step']:6.2f} | {row['speedup']:8.2f} | {b['first_call_s']:16.2f} "
            f"| {n['first_call_s']:11.2f} | {diff:12.1e} | {b['status']}, {n['status']}"
        )
    result = {
        "command": " ".join(sys.argv),
        "baseline_commit": None if args.small_loop_kernels else args.baseline_commit,
        "steps": args.steps,
        "baseline": {k: v for k, v in base.items() if k != "rows"},
        "new": {k: v for k, v in new.items() if k != "rows"},
        "rows": rows,
        "ok": ok,
    }
    out = write_result(args.out, result)
    print(f"{'PASSED' if ok else 'FAILED'}: final states within {args.rtol:g}, same status")
    print(f"wrote {out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(parse_args()))
