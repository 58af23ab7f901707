"""Notebook 02's tuning run in two versions of the library: where their paths part, and why.

A tuning run of a sliding-mode loop is path-dependent: two versions whose forward values are
bit-identical but whose gradient programs round differently can end far apart
(benchmarks/README.md, "Short inner loops"). This script runs the problem of
`notebooks/02_tuning.ipynb` (`jaxatt.scenarios.chen2022_tuning`: its parameters, objective,
clipped Adam and seed-0 training and held-out batches) in two worker processes, the library of
`--baseline-commit` (unpacked with `git archive`, as `bench_single.py` does) and this checkout,
and reports for each

- the gradient at the paper's gains (`tune.loss_and_grad`), compared between the versions;
- every step's loss (`tune.tune`'s callback) and, where the version records them, its gradient
  norm and the step with the lowest loss (`TuneResult.gradient_norms`, `best_step`);
- the held-out mean settling time (256 samples) at the paper's gains, at the last gains and at
  the best step's.

Only the public API of both versions is used. Nothing is asserted: the paths are expected to
differ; the report says where and by how much.

Usage (from the repository root):

    python benchmarks/bench_tuning_path.py                       # -> results/tuning_path.json
    python benchmarks/bench_tuning_path.py --samples 64 --steps 10 --baseline-commit 561edba
"""

import argparse
import json
import os
import pathlib
import sys
import time

from _baseline import run_both, run_version, write_result
from _notebook02 import add_batch_arguments, notebook02


HERE = pathlib.Path(__file__).resolve().parent


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_batch_arguments(p)
    p.add_argument("--steps", type=int, default=30, help="Adam steps (notebook: 30)")
    p.add_argument("--baseline-commit", default="561edba", help="git revision to compare to")
    p.add_argument("--out", default=str(HERE / "results" / "tuning_path.json"))
    p.add_argument("--worker", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if min(args.samples, args.steps, args.held_out) < 1:
        p.error("--samples, --steps and --held-out must be positive")
    return args


def worker(args) -> None:
    import jax
    import numpy as np

    import jaxatt
    from jaxatt import tune

    problem, template, params, objective, train, held_out = notebook02(args.samples, args.held_out)
    u0 = tune.initial_unconstrained(template, params)
    (_, _), grads = tune.loss_and_grad(u0, template, params, objective, train)
    losses = []
    start = time.perf_counter()
    result = tune.tune(
        template,
        params,
        objective,
        train,
        steps=args.steps,
        optimizer=problem.optimizer(),
        progress=False,
        callback=lambda step, loss, aux: losses.append(loss),
    )
    seconds = time.perf_counter() - start

    def held_out_mean(module):
        _, metrics = tune.evaluate(module, objective, held_out)
        return float(np.mean(np.asarray(metrics["settling_time"])))

    best_module = getattr(result, "best_module", None)
    info = {
        "jaxatt": str(pathlib.Path(jaxatt.__file__).parent),
        "jax": jax.__version__,
        "load_average": os.getloadavg(),
        "tune_seconds": seconds,
        "gradient_at_paper_gains": {k: float(v) for k, v in grads.items()},
        "losses": losses,
        "gradient_norms": None
        if getattr(result, "gradient_norms", None) is None
        else [float(v) for v in result.gradient_norms],
        "best_step": getattr(result, "best_step", None),
        "held_out_paper": held_out_mean(template),
        "held_out_last": held_out_mean(result.module),
        "held_out_best": None if best_module is None else held_out_mean(best_module),
    }
    pathlib.Path(args.worker).write_text(json.dumps(info))


def run_worker(args, src: pathlib.Path, out: pathlib.Path) -> dict:
    cmd = ["--worker", str(out), "--samples", str(args.samples), "--steps", str(args.steps)]
    cmd += ["--held-out", str(args.held_out)]
    run_version(HERE / "bench_tuning_path.py", cmd, src)
    return json.loads(out.read_text())


def _reduction(run: dict, key: str) -> str:
    value = run[key]
    if value is None:
        return "not recorded"
    return f"{value:.4f} s ({100 * (1 - value / run['held_out_paper']):.1f} % under the paper's)"


def main(args) -> int:
    if args.worker:
        worker(args)
        return 0
    base, new = run_both(run_worker, args, args.baseline_commit)
    g_base, g_new = base["gradient_at_paper_gains"], new["gradient_at_paper_gains"]
    gradient_difference = max(abs(g_new[k] - g_base[k]) / abs(g_base[k]) for k in g_base)
    print(f"\nGradient at the paper's gains: largest relative difference {gradient_difference:.1e}")
    print(" step | baseline loss | new loss | relative difference | new gradient norm")
    parted = None
    for k, (a, b) in enumerate(zip(base["losses"], new["losses"])):
        difference = abs(b - a) / abs(a)
        if parted is None and difference > 1e-6:
            parted = k
        norm = "" if new["gradient_norms"] is None else f"{new['gradient_norms'][k]:.2e}"
        print(f" {k:4d} | {a:13.6f} | {b:8.6f} | {difference:19.1e} | {norm}")
    for label, run in (("baseline", base), ("new", new)):
        print(
            f"{label}: held-out mean at the paper's gains {run['held_out_paper']:.4f} s, "
            f"last gains {_reduction(run, 'held_out_last')}, best step "
            f"{run['best_step']}: {_reduction(run, 'held_out_best')}"
        )
    result = {
        "command": " ".join(sys.argv),
        "baseline_commit": args.baseline_commit,
        "samples": args.samples,
        "steps": args.steps,
        "held_out": args.held_out,
        "gradient_relative_difference_at_paper_gains": gradient_difference,
        "first_step_losses_differ_1e-6": parted,
        "baseline": base,
        "new": new,
    }
    print(f"written {write_result(args.out, result)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(parse_args()))
