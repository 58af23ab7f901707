"""Does the default program choice hold for every plant family? Scalarized against plain.

`monte_carlo` scalarizes the time loop on CPU from `SCALARIZE_FROM` = 1000 samples run at once
(`jaxatt.simulation.Performance(scalarize=None)`). That threshold was measured on Chen 2022's
rigid-body loop only. This script checks it on every scenario family jaxatt reproduces: for
each, the default call `monte_carlo(loop, x0s, 0, T, dt=dt, sampling=...)` (the family's
default metrics reduced on the fly, nothing saved) compiled twice, with
`Performance(scalarize=True)` and `Performance(scalarize=False)`, each with the XLA options
`monte_carlo` passes for it (`_quick.UserProgram`), at each batch of `--batches`.

Programs are timed round robin (one warm-up each, then `--repeat` rounds, min per program);
compile time is `lower(...).compile()` alone. T is `--steps` steps of the scenario's own dt.
The batch is the scenario's initial state repeated, its floating leaves scaled by
1 + 1e-3 u (u uniform in [-1, 1], one draw per sample and leaf entry; unit quaternions
normalized again) so that samples differ. Throughput is in state-steps per second (batch x
steps / run time).

Checks: the two programs' metrics have the same non-finite pattern and agree to `--rtol`
(relative per entry, 1e-6: the two programs round differently, and the finite-time and
sliding-mode laws amplify last-bit differences while they converge; measured up to 2.4e-8,
Wu 2018's safe approach). Exit 1 otherwise.

Families (scenario module, loop, sampling, dt):

- `chen2022_m1`: `chen2022_two_phase_power.build("M1")`, dt 1e-3 s;
- `rigid_body_pd`: `rigid_body_pd.build()` (MRP PD, shadow switching), dt 1e-3 s;
- `yu2022_ftac`: `yu2022_ftac_mrp.build("FTAC")` (finite-time law, super-twisting
  observer), dt 1e-4 s;
- `zhang2021_hover`: `zhang2021_hover.build()` (relative pose, prescribed performance), dt
  0.01 s;
- `wu2018`: `wu2018.build()` (safe approach, J2 plant), case 2, dt 0.02 s;
- `zhang2017_pd`, `zhang2017_pd_alpha`: relative orbit, integer and fractional PD sliding
  mode (`ZeroOrderHold(0.01)`, as the scenario; the fractional law's full memory sized for
  the run's steps), dt 0.01 s;
- `yue2018`: 6-DOF adaptive terminal sliding mode, dt 0.01 s;
- `shi2024`: liquid-filled flexible spacecraft, observer, smoother, dt 1e-3 s;
- `duan2024`: two-layer consensus of 2 x 4 agents, periodic intermittent link, dt 0.01 s;
- `flyaround`: relative orbit and attitude with body-fixed thrust, dt 0.1 s.

Usage (from the repository root):

    python benchmarks/bench_scalarize_families.py   # -> results/scalarize_families.json
"""

import argparse
import functools
import sys

import _common as common
import _quick
import jax
import jax.numpy as jnp
import jax.random as jr

from jaxatt.montecarlo import monte_carlo
from jaxatt.scenarios import (
    chen2022_two_phase_power as chen,
    duan2024,
    flyaround,
    rigid_body_pd,
    shi2024,
    wu2018,
    yu2022_ftac_mrp as yu,
    yue2018,
    zhang2017,
    zhang2021_hover as zhang2021,
)
from jaxatt.simulation import SCALARIZE_FROM, Continuous, Performance, ZeroOrderHold


FAMILIES = (
    "chen2022_m1",
    "rigid_body_pd",
    "yu2022_ftac",
    "zhang2021_hover",
    "wu2018",
    "zhang2017_pd",
    "zhang2017_pd_alpha",
    "yue2018",
    "shi2024",
    "duan2024",
    "flyaround",
)


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[SCALARIZE_FROM, 4000])
    p.add_argument("--steps", type=int, default=500, help="RK4 steps per run")
    p.add_argument("--rtol", type=float, default=1e-6, help="tolerance of the checks (relative)")
    p.add_argument("--families", nargs="+", choices=FAMILIES, default=list(FAMILIES))
    p.add_argument("--dtype", choices=["float64", "float32"], default="float64")
    p.add_argument("--repeat", type=int, default=3, help="timed rounds (min per program)")
    p.add_argument("--seed", type=int, default=0, help="key of the perturbations")
    p.add_argument("--out", default=None, help="JSON file (default: results/)")
    args = p.parse_args(argv)
    if min(args.batches) < 1 or args.steps < 1 or args.repeat < 1:
        p.error("--batches, --steps and --repeat must be positive")
    if args.out is None:
        suffix = "_float32" if args.dtype == "float32" else ""
        args.out = str(common.RESULTS_DIR / f"scalarize_families{suffix}.json")
    return args


def family(name: str, steps: int):
    """`(loop, x0, dt, sampling)` of a family, as its scenario builds them (Zhang 2017's
    fractional law with its full memory sized for `steps` steps)."""
    continuous = Continuous()
    if name == "chen2022_m1":
        return chen.build("M1"), chen.initial_state("D1"), chen.DT, continuous
    if name == "rigid_body_pd":
        return rigid_body_pd.build(), rigid_body_pd.initial_state(), 1e-3, continuous
    if name == "yu2022_ftac":
        return yu.build("FTAC"), yu.initial_state(), yu.DT, continuous
    if name == "zhang2021_hover":
        return zhang2021.build(), zhang2021.initial_state(), zhang2021.DT, continuous
    if name == "wu2018":
        return wu2018.build(), wu2018.initial_state(wu2018.CASES["case2"]), wu2018.DT, continuous
    if name.startswith("zhang2017"):
        law = "pd" if name == "zhang2017_pd" else "pd_alpha"
        hold = ZeroOrderHold(zhang2017.STEP)
        loop = zhang2017.build(law, horizon=steps * zhang2017.STEP)
        return loop, zhang2017.initial_state(), zhang2017.STEP, hold
    if name == "yue2018":
        return yue2018.build(), yue2018.initial_state(), yue2018.DT, continuous
    if name == "shi2024":
        return shi2024.build(), shi2024.initial_state(), shi2024.DT, continuous
    if name == "duan2024":
        return duan2024.build(), duan2024.initial_state(), duan2024.DT, continuous
    if name == "flyaround":
        return flyaround.build(), flyaround.initial_state(), flyaround.DT, continuous
    raise ValueError(name)


def batch_of(x0, n: int, key):
    """`n` copies of `x0`, floating entries scaled by 1 + 1e-3 u, u ~ U[-1, 1] (unit
    quaternions normalized again)."""
    leaves, treedef = jax.tree.flatten(x0)
    keys = jr.split(key, len(leaves))
    out = []
    for leaf, k in zip(leaves, keys):
        leaf = jnp.asarray(leaf)
        tiled = jnp.broadcast_to(leaf, (n, *leaf.shape))
        if jnp.issubdtype(leaf.dtype, jnp.floating):
            tiled = tiled * (1 + 1e-3 * jr.uniform(k, tiled.shape, leaf.dtype, -1.0, 1.0))
            if leaf.shape[-1:] == (4,) and abs(float(jnp.linalg.norm(leaf)) - 1) < 1e-12:
                tiled = tiled / jnp.linalg.norm(tiled, axis=-1, keepdims=True)  # unit quaternions
        out.append(tiled)
    return jax.tree.unflatten(treedef, out)


def measure(name: str, batch: int, args) -> dict:
    loop, x0, dt, sampling = family(name, args.steps)
    x0s = batch_of(x0, batch, jr.key(args.seed))
    horizon = args.steps * dt

    kinds = {"scalarized": True, "plain": False}
    row = {"family": name, "batch": batch, "steps": args.steps, "dt": dt}
    compiled, metrics = {}, {}
    for kind, scalarize in kinds.items():

        def call(loop, x0s, scalarize=scalarize):
            out = monte_carlo(
                loop,
                x0s,
                0.0,
                horizon,
                dt=dt,
                sampling=sampling,
                performance=Performance(scalarize=scalarize),
            )
            return out.metrics

        program = _quick.UserProgram(call, Performance(scalarize=scalarize))
        compiled[kind], compile_s = common.compile_timed(program, (loop, x0s))
        metrics[kind] = jax.block_until_ready(compiled[kind](loop, x0s))  # warm-up
        row[kind] = {"compile_s": compile_s}
    calls = {kind: functools.partial(compiled[kind], loop, x0s) for kind in kinds}
    for kind, run_s in common.round_robin(calls, args.repeat).items():
        row[kind]["run_s"] = run_s
    for kind in kinds:
        row[kind]["state_steps_per_s"] = batch * args.steps / row[kind]["run_s"]
    row["scalarized_speedup"] = row["plain"]["run_s"] / row["scalarized"]["run_s"]
    # Steps after which the scalarized program's extra compile time is paid back.
    saved_per_step = (row["plain"]["run_s"] - row["scalarized"]["run_s"]) / args.steps
    extra_compile = row["scalarized"]["compile_s"] - row["plain"]["compile_s"]
    row["break_even_steps"] = extra_compile / saved_per_step if saved_per_step > 0 else None
    row["per_metric_relative_difference"] = {
        k: common.tree_relative_difference(metrics["scalarized"][k], metrics["plain"][k])
        for k in metrics["plain"]
    }
    row["metrics_relative_difference"] = max(row["per_metric_relative_difference"].values())
    return row


def main(args) -> int:
    common.enable_precision(args.dtype)
    meta = common.machine_meta()
    common.print_meta(
        meta,
        f"monte_carlo(loop, x0s, 0, {args.steps} dt, dt=dt) per family, {args.dtype}: "
        "Performance(scalarize=True) against scalarize=False",
    )
    rows = []
    for name in args.families:
        for batch in args.batches:
            row = measure(name, batch, args)
            rows.append(row)
            s, p = row["scalarized"], row["plain"]
            even = row["break_even_steps"]
            print(
                f"  {name:>20} batch {batch:>6}: scalarized {s['state_steps_per_s']:.3g} st-st/s "
                f"(compile {s['compile_s']:.2f} s), plain {p['state_steps_per_s']:.3g} st-st/s "
                f"(compile {p['compile_s']:.2f} s): {row['scalarized_speedup']:.2f}x, "
                f"break-even {'never' if even is None else f'{even:.0f} steps'}; metrics "
                f"differ by {row['metrics_relative_difference']:.2g} (relative)",
                flush=True,
            )
    ok = all(r["metrics_relative_difference"] <= args.rtol for r in rows)
    result = {
        "benchmark": "scalarized against plain time loop, per plant family",
        "settings": vars(args),
        "rows": rows,
    }
    return common.finish(result, meta, args.out, ok)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
