"""Quick, self-checking Chen 2022 M1 Monte Carlo throughput: jaxatt against a hand scan and NumPy.

The short version of `bench_montecarlo.py` (no SciPy, Basilisk, JSON or recorded runs), and
the replacement of the former `jaxatt bench` command. It simulates Chen et al. (2022)'s closed
loop M1 (`jaxatt.scenarios.chen2022_two_phase_power.build("M1")`; classic RK4, dt = 1e-3 s,
`--horizon` seconds, 30 N m per-axis saturation) from the first B initial states of
`jaxatt.scenarios.chen2022_tuning.initial_states(jr.key(0), n)` for each batch size B in
`--batches`, three ways:

- jaxatt: `eqx.filter_jit` of `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=1e-3)`,
  every option at its default (default metrics reduced on the fly at every step, nothing
  saved, scalarized on CPU from 1000 samples), the closed loop an argument; its final states
  for the checks come from a separate untimed call with `keep_trajectories=True`;
- scan: the same equations written out in scalar components (`_reference.py`, not jaxatt code)
  under `jax.numpy` in one jitted `lax.scan`: the floor of what XLA does with this vector field;
- NumPy: the same component code on NumPy `(batch,)` arrays, RK4 over the batch (at most 2e5
  state-steps, at least 10 steps, its time scaled to the horizon: marked `*`).

Throughput is in state-steps per second (batch x RK4 steps / run wall time). jaxatt's compile
time (ahead-of-time trace, lower and XLA compile, no run) is reported apart from its run time
(one warm-up call, then the minimum over up to 3 timed calls). Every row is checked: the final
states of the hand scan (whole batch) and of NumPy (up to 4 samples, full horizon) must equal
jaxatt's to 1e-9 in float64 (1e-4 in float32); the script exits 1 when they do not.

Usage (from the repository root):

    python benchmarks/bench_quick.py                       # batches 1 100 1000, 1 s, float64
    python benchmarks/bench_quick.py --batches 1 100 1000 10000 --horizon 1 --float32
"""

import argparse
import sys

import _quick
import jax


DT = 1e-3
"""RK4 step [s] (that of `_quick.quick_table`)."""


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--batches", type=int, nargs="+", default=[1, 100, 1000], help="batch sizes, one row each"
    )
    p.add_argument("--horizon", type=float, default=1.0, help="simulated time [s]")
    p.add_argument("--float32", action="store_true", help="run in float32 (default float64)")
    args = p.parse_args(argv)
    ratio = args.horizon / DT
    if args.horizon <= 0 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        p.error(f"--horizon must be a positive whole multiple of dt = {DT:g} s")
    if min(args.batches) < 1:
        p.error("--batches must be positive")
    return args


def main(args) -> int:
    if not args.float32:  # before any array exists
        jax.config.update("jax_enable_x64", True)
    dtype = "float32" if args.float32 else "float64"
    print(
        f"Chen 2022 M1 Monte Carlo, {args.horizon:g} s of RK4 at dt {DT:g} s, {dtype}, on "
        f"{jax.devices()[0].device_kind} ({len(jax.devices())} device(s))",
        flush=True,
    )
    rows = _quick.quick_table(batches=tuple(args.batches), horizon=args.horizon, dt=DT)
    print(_quick.format_table(rows))
    print(
        "st-st/s = state-steps per second (batch x RK4 steps / run time); jaxatt = "
        "jaxatt.montecarlo.monte_carlo with its defaults; scan = a minimal hand-written "
        "lax.scan of the same equations; NumPy = vectorised RK4 (* scaled from fewer steps); "
        "max |diff| = largest final-state difference to jaxatt."
    )
    if not all(row["passed"] for row in rows):
        print(
            "bench_quick: the implementations disagree beyond tolerance "
            f"({rows[0]['tolerance']:g})",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(parse_args()))
