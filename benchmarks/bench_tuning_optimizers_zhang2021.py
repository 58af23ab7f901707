"""Zhang 2021's PPC tuning problem under Adam (the recorded run's optimizer) and
L-BFGS with optax's two line searches: does what helped on notebook 02's problem
(`bench_tuning_optimizers.py`) help on the 6-DOF pose problem?

The problem is `jaxatt.scenarios.zhang2021_tuning`'s (`problem="ppc"`): its parameters (4
envelope rates, 6 surface gains), objective (sum of the four groups' convergence times plus
the force, torque and envelope-usage penalties; 600 s at dt = 0.05 s) and the recorded run's
batches (16 training and 32 held-out states from `jr.split(jr.key(0))`, `jaxatt tune
zhang2021 --samples 16 --steps 30 --validation-samples 32`). Every run stops at a step whose
loss is not finite (`on_nonfinite="stop"`, as the problem's `run` does) and is scored at its
best step. The loss-and-gradient program is compiled before any timing; each run's time is
its steps plus the compilation of its own update (with a line search, the update holds the
closed loop).

For each run: the losses, gradient norms, seconds, best step and its gains, and the held-out
summary of the problem's report at the best step (mean objective time, violations, peaks).
Nothing is asserted; benchmarks/README.md records a run.

Usage (from the repository root; the default sizes took 33 min on the 2-core machine):

    python benchmarks/bench_tuning_optimizers_zhang2021.py
    python benchmarks/bench_tuning_optimizers_zhang2021.py --samples 2 --held-out 2 \\
        --steps 2 --lbfgs-steps 2 --horizon 60        # smoke test
"""

import argparse
import pathlib
import sys
import time

from _baseline import tuning_provenance, write_result


HERE = pathlib.Path(__file__).resolve().parent


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--samples", type=int, default=16, help="training samples (recorded: 16)")
    p.add_argument("--held-out", type=int, default=32, help="held-out samples (recorded: 32)")
    p.add_argument("--steps", type=int, default=30, help="Adam steps (recorded: 30)")
    p.add_argument("--lbfgs-steps", type=int, default=10, help="steps of each L-BFGS run")
    p.add_argument(
        "--horizon", type=float, default=None, help="simulated seconds (default: the problem's)"
    )
    p.add_argument(
        "--runs",
        nargs="+",
        default=["adam", "lbfgs-backtracking", "lbfgs-zoom"],
        choices=["adam", "lbfgs-backtracking", "lbfgs-zoom"],
    )
    p.add_argument("--out", default=str(HERE / "results" / "tuning_optimizers_zhang2021.json"))
    args = p.parse_args(argv)
    if min(args.samples, args.held_out, args.steps, args.lbfgs_steps) < 1:
        p.error("--samples, --held-out, --steps and --lbfgs-steps must be positive")
    return args


def main(args) -> int:
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.random as jr
    import numpy as np
    import optax

    from jaxatt import tune
    from jaxatt.scenarios import zhang2021_tuning as zt

    problem = "ppc"
    template, params = zt.template(problem), zt.parameters(problem)
    objective = zt.objective() if args.horizon is None else zt.objective(horizon=args.horizon)
    train_key, held_out_key = jr.split(jr.key(0))
    train = zt.initial_states(train_key, args.samples, problem)
    held_out = zt.initial_states(held_out_key, args.held_out, problem)

    start = time.perf_counter()
    tune.loss_and_grad(
        tune.initial_unconstrained(template, params), template, params, objective, train
    )
    build_seconds = time.perf_counter() - start
    _, before = tune.evaluate(template, objective, held_out)
    paper = zt.held_out_summary(before)

    optimizers = {
        "adam": (optax.adam(zt.LEARNING_RATE[problem]), args.steps),
        "lbfgs-backtracking": (
            optax.lbfgs(
                linesearch=optax.scale_by_backtracking_linesearch(max_backtracking_steps=15)
            ),
            args.lbfgs_steps,
        ),
        "lbfgs-zoom": (optax.lbfgs(), args.lbfgs_steps),
    }
    result = tuning_provenance() | {
        "samples": args.samples,
        "held_out": args.held_out,
        "horizon": objective.simulation.t1,
        "loss_and_grad_build_seconds": build_seconds,
        "held_out_paper": paper,
        "runs": {},
    }
    runs = result["runs"]
    for name in args.runs:
        optimizer, steps = optimizers[name]
        start = time.perf_counter()
        tuned = tune.tune(
            template,
            params,
            objective,
            train,
            steps=steps,
            optimizer=optimizer,
            on_nonfinite="stop",
            progress=True,
        )
        seconds = time.perf_counter() - start
        _, best = tune.evaluate(tuned.best_module, objective, held_out)
        summary = zt.held_out_summary(best)
        runs[name] = {
            "steps": tuned.steps,
            "seconds": seconds,
            "stopped": tuned.stopped,
            "losses": [float(v) for v in tuned.losses],
            "gradient_norms": [float(v) for v in tuned.gradient_norms],
            "best_step": tuned.best_step,
            "best_gains": {k: np.asarray(v).tolist() for k, v in tuned.best_gains.items()},
            "held_out_best": summary,
            "held_out_reduction": zt.objective_time_reduction(paper, summary),
        }
        loss = runs[name]["losses"][tuned.best_step]
        reduction = runs[name]["held_out_reduction"]
        print(
            f"{name}: {tuned.steps} steps in {seconds:.0f} s, best step {tuned.best_step} "
            f"(training loss {loss:.1f}), held-out mean objective time "
            f"{summary['mean_objective_time']} s (paper's gains {paper['mean_objective_time']}"
            f" s; reduction {'n/a' if reduction is None else f'{100 * reduction:.1f} %'}), "
            f"violations {summary['violations']}, above the penalties' bounds: "
            f"{zt.held_out_over_bounds(summary) or 'none'}; stopped: {tuned.stopped}",
            flush=True,
        )
        # written after every run, so that a run cut short keeps the ones before it
        print(f"written {write_result(args.out, result)}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(parse_args()))
