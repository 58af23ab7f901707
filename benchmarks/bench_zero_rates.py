"""Regulation loops with the reference's zero rates known when the program is traced.

`jaxatt.references.ConstantAttitude` returns its zero rates as NumPy constants, and the rate
errors of `jaxatt.rotations` (`rate_error`, `rate_error_mrp`) return the body rate when the
desired rate is a NumPy zero, instead of computing omega - C(e) 0 at every stage; the
finite-time MRP laws (`jaxatt.controllers._finite_time`) likewise drop their feed-forward's
rotated desired rate and acceleration. Before, the zeros were `jnp.zeros`, arrays of the
traced program, and the rotations of a zero vector were computed (XLA keeps x * 0, which is
NaN for an infinite x).

For each scenario and batch the script compiles the call `jaxatt.montecarlo.monte_carlo(loop,
x0s, 0, T, dt=dt)` (every other option at its default: default metrics reduced on the fly,
scalarized on CPU from 1000 samples, compiled with the XLA options the eager call passes,
`_quick.UserProgram`) for the loop as the scenario builds it and for the same loop with
`TracedZeroRates`, a reference that returns the same identity attitude with `jnp.zeros` rates
(the program before the change). It times them round robin (one warm-up each, then `--repeat`
rounds, min per program) and checks that their metrics and final states (an untimed call with
`keep_trajectories=True` and one save at T) agree to `--rtol` (1e-12, relative per entry):
the values are the same numbers, but a program that XLA fuses differently rounds its last
bits differently, and Yu 2022's finite-time law amplifies such differences while it
converges (2.6e-14 in its final states at 10 000 samples); it exits 1 otherwise.

- `rigid_body_pd`: `jaxatt.scenarios.rigid_body_pd.build()` (MRP PD law `MRPPD`, whose rate
  error is `rate_error_mrp`; saturation, shadow switching) from
  `random_initial_states(key(seed), B)`;
- `yu2022`: Yu et al. (2022)'s finite-time law with its disturbance observer
  (`jaxatt.scenarios.yu2022_ftac_mrp.build("FTAC")`) from the same states scaled by 0.3.

Usage (from the repository root):

    python benchmarks/bench_zero_rates.py   # -> results/zero_rates.json
"""

import argparse
import functools
import sys
from typing import ClassVar

import _common as common
import _quick
import jax
import jax.numpy as jnp
import jax.random as jr

from jaxatt.montecarlo import monte_carlo
from jaxatt.references import AbstractReference, AttitudeReference
from jaxatt.scenarios import rigid_body_pd, yu2022_ftac_mrp
from jaxatt.simulation import ClosedLoop


SCENARIOS = ("rigid_body_pd", "yu2022")


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[1, 100, 1000, 10000])
    p.add_argument("--rtol", type=float, default=1e-12, help="tolerance of the checks (relative)")
    p.add_argument("--horizon", type=float, default=1.0, help="simulated time [s]")
    p.add_argument("--scenarios", nargs="+", choices=SCENARIOS, default=list(SCENARIOS))
    common.add_common_arguments(p)
    args = p.parse_args(argv)
    if min(args.batches) < 1:
        p.error("--batches must be positive")
    return common.finish_arguments(p, args, [args.horizon], "zero_rates.json")


def build(name: str, key, n: int):
    """The loop as the scenario builds it, and its initial states."""
    x0s = rigid_body_pd.random_initial_states(key, n)
    if name == "rigid_body_pd":
        return rigid_body_pd.build(), x0s
    return yu2022_ftac_mrp.build("FTAC"), jax.tree.map(lambda a: 0.3 * a, x0s)


class TracedZeroRates(AbstractReference):
    """The identity at rest with `jnp.zeros` rates: arrays of the traced program, as
    `ConstantAttitude`'s were before its rates became NumPy constants."""

    q_d: jax.Array
    output_type: ClassVar[type] = AttitudeReference

    def init(self, t0):
        return None

    def __call__(self, t, state):
        zero = jnp.zeros(3, self.q_d.dtype)
        return AttitudeReference(self.q_d, zero, zero), None


def with_traced_zero_rates(loop: ClosedLoop) -> ClosedLoop:
    reference = TracedZeroRates(jnp.array([1.0, 0.0, 0.0, 0.0]))
    return ClosedLoop(
        loop.plant, loop.controller, reference, observer=loop.observer, actuator=loop.actuator
    )


def measure(name: str, batch: int, args) -> dict:
    loop, x0s = build(name, jr.key(args.seed), batch)
    loops = {"numpy": loop, "traced": with_traced_zero_rates(loop)}
    horizon, dt = args.horizon, args.dt
    steps = common.steps_of(horizon, dt)

    def default_call(loop, x0s):
        return monte_carlo(loop, x0s, 0.0, horizon, dt=dt).metrics

    def final_states(loop, x0s):
        out = monte_carlo(loop, x0s, 0.0, horizon, dt=dt, save_every=steps, keep_trajectories=True)
        return out.trajectories.states

    row = {"scenario": name, "batch": batch, "steps": steps}
    compiled, metrics = {}, {}
    for kind, closed_loop in loops.items():
        program = _quick.UserProgram(default_call)
        compiled[kind], compile_s = common.compile_timed(program, (closed_loop, x0s))
        metrics[kind] = jax.block_until_ready(compiled[kind](closed_loop, x0s))  # warm-up
        row[kind] = {"compile_s": compile_s}
    calls = {kind: functools.partial(compiled[kind], loop, x0s) for kind, loop in loops.items()}
    for kind, run_s in common.round_robin(calls, args.repeat).items():
        row[kind]["run_s"] = run_s
    for kind in loops:
        row[kind]["state_steps_per_s"] = batch * steps / row[kind]["run_s"]
    final = _quick.UserProgram(final_states)
    states = {kind: final(closed_loop, x0s) for kind, closed_loop in loops.items()}
    row["speedup"] = row["traced"]["run_s"] / row["numpy"]["run_s"]
    row["metrics_relative_difference"] = common.tree_relative_difference(
        metrics["numpy"], metrics["traced"]
    )
    row["final_states_relative_difference"] = common.tree_relative_difference(
        states["numpy"], states["traced"]
    )
    return row


def main(args) -> int:
    common.enable_precision(args.dtype)
    meta = common.machine_meta()
    common.print_meta(
        meta,
        f"monte_carlo(loop, x0s, 0, {args.horizon:g}, dt={args.dt:g}), {args.dtype}: the "
        "reference's zero rates as NumPy constants (ConstantAttitude) against jnp.zeros "
        "(TracedZeroRates)",
    )
    rows = []
    for name in args.scenarios:
        for batch in args.batches:
            row = measure(name, batch, args)
            rows.append(row)
            print(
                f"  {name:>13} batch {batch:>6}: NumPy zeros {row['numpy']['run_s']:.4g} s "
                f"({row['numpy']['state_steps_per_s']:.3g} st-st/s, compile "
                f"{row['numpy']['compile_s']:.2f} s), traced zeros {row['traced']['run_s']:.4g} s "
                f"({row['traced']['state_steps_per_s']:.3g} st-st/s, compile "
                f"{row['traced']['compile_s']:.2f} s): {row['speedup']:.2f}x; metrics differ by "
                f"{row['metrics_relative_difference']:.2g}, final states by "
                f"{row['final_states_relative_difference']:.2g} (relative)",
                flush=True,
            )
    ok = all(
        max(r["metrics_relative_difference"], r["final_states_relative_difference"]) <= args.rtol
        for r in rows
    )
    result = {
        "benchmark": "zero reference rates: NumPy constants against traced zeros",
        "settings": vars(args),
        "rows": rows,
    }
    return common.finish(result, meta, args.out, ok)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
