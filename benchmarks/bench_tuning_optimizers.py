"""Notebook 02's tuning problem under three optax optimizers: clipped Adam, and L-BFGS with
either of optax's line searches (what `tune.tune` passes them: `value`, `grad`, `value_fn`).

The problem is that of `notebooks/02_tuning.ipynb` (`jaxatt.scenarios.chen2022_tuning`: its
parameters, objective with the chattering penalty, seed-0 training and held-out batches of 256
samples). The loss-and-gradient program is compiled before any timing, so each run's time is
its steps plus the compilation of its own update (with a line search, the update holds the
closed loop). L-BFGS with the zoom line search runs `--steps` steps in two calls, the first
half written to a checkpoint and resumed (a resumed run is bit-identical to an uninterrupted
one), so the report has its best step after half the steps too.

For each run: the losses, gradient norms, best step and its gains, and the held-out mean
settling time, largest chattering (total variation of u over the last 5 s; the bound is
1 N m) and samples above the bound, at the tuning step (dt = 5e-3 s) and at the paper's
(1e-3 s). Nothing is asserted; benchmarks/README.md records a run.

Usage (from the repository root):

    python benchmarks/bench_tuning_optimizers.py        # -> results/tuning_optimizers.json
    python benchmarks/bench_tuning_optimizers.py --samples 32 --held-out 64 --steps 10
"""

import argparse
import pathlib
import sys
import tempfile
import time

from _baseline import tuning_provenance, write_result
from _notebook02 import add_batch_arguments, notebook02


HERE = pathlib.Path(__file__).resolve().parent


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_batch_arguments(p)
    p.add_argument("--steps", type=int, default=30, help="steps per run (notebook: 30)")
    p.add_argument("--out", default=str(HERE / "results" / "tuning_optimizers.json"))
    args = p.parse_args(argv)
    if min(args.samples, args.steps, args.held_out) < 2:
        p.error("--samples, --steps and --held-out must be at least 2")
    return args


def main(args) -> int:
    import numpy as np
    import optax

    from jaxatt import tune

    problem, template, params, objective, train, held_out = notebook02(args.samples, args.held_out)
    tune.loss_and_grad(
        tune.initial_unconstrained(template, params), template, params, objective, train
    )

    def held_out_summary(module) -> dict:
        out = {}
        for dt in (problem.DT, 1e-3):
            _, m = tune.evaluate(module, problem.objective(dt=dt), held_out)
            chattering = np.asarray(m["chattering"])
            out[f"dt={dt:g}"] = {
                "mean_settling_time": float(np.mean(np.asarray(m["settling_time"]))),
                "settled": int(np.sum(np.asarray(m["settled"]))),
                "max_chattering": float(chattering.max()),
                "above_chattering_bound": int(np.sum(chattering > problem.CHATTERING_BOUND)),
            }
        return out

    def record(result, seconds: float) -> dict:
        return {
            "seconds": seconds,
            "losses": [float(v) for v in result.losses],
            "gradient_norms": [float(v) for v in result.gradient_norms],
            "best_step": result.best_step,
            "best_gains": {k: float(v) for k, v in result.best_gains.items()},
            "held_out_best": held_out_summary(result.best_module),
        }

    common = dict(progress=False)
    runs = {}
    start = time.perf_counter()
    adam = tune.tune(
        template,
        params,
        objective,
        train,
        steps=args.steps,
        optimizer=problem.optimizer(),
        **common,
    )
    runs["adam (clip 1, adam 0.1)"] = record(adam, time.perf_counter() - start)

    half = args.steps // 2
    zoom = optax.lbfgs()
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "lbfgs.eqx"
        start = time.perf_counter()
        first = tune.tune(
            template,
            params,
            objective,
            train,
            steps=half,
            optimizer=zoom,
            checkpoint=path,
            **common,
        )
        first_seconds = time.perf_counter() - start
        start = time.perf_counter()
        full = tune.tune(
            template,
            params,
            objective,
            train,
            steps=args.steps,
            optimizer=zoom,
            checkpoint=path,
            resume=True,
            **common,
        )
        full_seconds = first_seconds + time.perf_counter() - start
    runs[f"lbfgs (zoom), {half} steps"] = record(first, first_seconds)
    runs["lbfgs (zoom)"] = record(full, full_seconds)

    backtracking = optax.lbfgs(
        linesearch=optax.scale_by_backtracking_linesearch(max_backtracking_steps=15)
    )
    start = time.perf_counter()
    armijo = tune.tune(
        template, params, objective, train, steps=args.steps, optimizer=backtracking, **common
    )
    runs["lbfgs (backtracking, 15)"] = record(armijo, time.perf_counter() - start)

    paper = held_out_summary(template)
    print(f"paper's gains: {paper}")
    for name, run in runs.items():
        best = run["held_out_best"][f"dt={problem.DT:g}"]["mean_settling_time"]
        reduction = 1 - best / paper[f"dt={problem.DT:g}"]["mean_settling_time"]
        run["held_out_reduction"] = reduction
        print(
            f"{name}: {len(run['losses'])} steps in {run['seconds']:.0f} s, best step "
            f"{run['best_step']} (loss {run['losses'][run['best_step']]:.4f}), held out "
            f"{100 * reduction:.1f} % under the paper's; {run['held_out_best']}; gains "
            f"{ {k: round(v, 4) for k, v in run['best_gains'].items()} }"
        )
    result = tuning_provenance() | {
        "samples": args.samples,
        "held_out": args.held_out,
        "steps": args.steps,
        "held_out_paper": paper,
        "runs": runs,
    }
    print(f"written {write_result(args.out, result)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(parse_args()))
