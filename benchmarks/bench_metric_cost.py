"""What each streamed metric costs the default `monte_carlo` call (issue 18's "3x main" gap).

The default call reduces its four default metrics on the fly at every step. It runs at about
0.8x the same call saving nothing but the metrics of the last step (`benchmarks/README.md`);
this script splits that gap by metric. It times, on Chen et al. (2022)'s M1 closed loop
(classic RK4, dt = 1e-3 s, float64, the initial states of `bench_quick.py`), the programs a
user gets from `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=1e-3, ...)` (each compiled
with the XLA options `monte_carlo` passes itself: `_quick.UserProgram`):

- `floor`: the default metrics, read once per horizon (`save_every` = the number of steps): the
  closed loop alone, every metric read once;
- `default`: every argument at its default (the four default metrics at every step);
- each default metric alone, at every step: `settling_time`, `peak_torque`, `effort`,
  `max_rate_error`;
- three probes: `sum_e1` and `sum_u1`, running sums of |e_1| (the first attitude-error
  component, a function of the state) and of |u_1| (the first torque component, the
  controller's output), and `peak_u` (`Peak("u", Absolute())`, the three running maxima of
  |u_i|).

The programs are compiled first, then timed round robin (`--rounds` rounds, each program once
per round; its minimum is reported), so that a change of the machine's load during the run
moves every program alike. Checked: each metric alone equals the default call's value to
1e-12 relative on every sample, and no sample failed (a failed sample's `peak_u` is NaN);
exit 1 otherwise.

(A stream whose update ignores its state, such as `Final`, is no probe: its value after the
loop comes from the last sample alone, so the carried state is dead and is removed from the
loop before XLA sees it.)

Usage (from the repository root):

    python benchmarks/bench_metric_cost.py                       # batch 10 000, 1 s
    python benchmarks/bench_metric_cost.py --batch 1000 --horizon 2 --rounds 5
"""

import argparse
import sys
import time

import _common
import _quick
import jax
import numpy as np


DT = 1e-3
"""RK4 step [s]."""
DEFAULT_METRICS = ("settling_time", "peak_torque", "effort", "max_rate_error")


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batch", type=int, default=10_000, help="samples per program")
    p.add_argument("--horizon", type=float, default=1.0, help="simulated time [s]")
    p.add_argument("--rounds", type=int, default=4, help="round-robin timing rounds")
    p.add_argument("--seed", type=int, default=0, help="key of the initial states")
    p.add_argument(
        "--out",
        default=str(_common.RESULTS_DIR / "metric_cost.json"),
        help="JSON file (default benchmarks/results/metric_cost.json)",
    )
    args = p.parse_args(argv)
    if args.batch < 1 or args.rounds < 1:
        p.error("--batch and --rounds must be positive")
    ratio = args.horizon / DT
    if args.horizon <= 0 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        p.error(f"--horizon must be a positive whole multiple of dt = {DT:g} s")
    return args


def running_sum(signal: str, component: int):
    """A streamed metric: the sum over the samples of |signal[component]| (a probe)."""
    import jax.numpy as jnp

    from jaxatt.metrics import AbstractMetric

    class RunningSum(AbstractMetric):
        streams = True

        def __call__(self, traj):
            return jnp.sum(jnp.abs(traj.signals[signal][:, component]))

        def stream_init(self, t, signals, t_last):
            return jnp.abs(signals[signal][component])

        def stream_update(self, state, t, signals):
            return state + jnp.abs(signals[signal][component])

        def stream_value(self, state):
            return state

    return RunningSum()


def programs(loop, n_steps: int, horizon: float) -> dict:
    """The timed programs, by name: `fn(loop, x0s) -> metrics` for `UserProgram`."""
    from jaxatt.metrics import Absolute, Peak
    from jaxatt.montecarlo import default_metrics, monte_carlo

    defaults = default_metrics(loop)  # what monte_carlo records with metrics=None

    def call(**options):
        def fn(loop, x0s):
            return monte_carlo(loop, x0s, 0.0, horizon, dt=DT, **options).metrics

        return fn

    out = {"floor": call(save_every=n_steps), "default": call()}
    for name in DEFAULT_METRICS:
        out[name] = call(metrics={name: defaults[name]})
    out["sum_e1"] = call(metrics={"sum_e1": running_sum("attitude_error_vector", 0)})
    out["sum_u1"] = call(metrics={"sum_u1": running_sum("u", 0)})
    out["peak_u"] = call(metrics={"peak_u": Peak("u", Absolute())})
    return out


def main(args) -> int:
    jax.config.update("jax_enable_x64", True)
    meta = _common.machine_meta()
    _common.print_meta(
        meta,
        f"Chen 2022 M1, RK4 dt {DT:g} s, {args.horizon:g} s, batch {args.batch}, float64; "
        f"{args.rounds} round-robin rounds",
    )
    loop, x0s = _common.m1_setup(args.seed, args.batch, np.float64)
    n_steps = _common.steps_of(args.horizon, DT)
    compiled, outputs, compile_s = {}, {}, {}
    for name, fn in programs(loop, n_steps, args.horizon).items():
        program = _quick.UserProgram(fn)
        compiled[name], compile_s[name] = _common.compile_timed(program, (loop, x0s))
        outputs[name] = jax.block_until_ready(compiled[name](loop, x0s))  # warm-up
    best = {name: float("inf") for name in compiled}
    for _ in range(args.rounds):
        for name, program in compiled.items():
            start = time.perf_counter()
            jax.block_until_ready(program(loop, x0s))
            best[name] = min(best[name], time.perf_counter() - start)

    ok = True
    default = outputs["default"]
    for name in DEFAULT_METRICS:
        a, b = np.asarray(outputs[name][name]), np.asarray(default[name])
        same = bool(np.allclose(a, b, rtol=1e-12, atol=0))  # inf (unsettled) equals inf
        if not same:
            print(f"check FAILED: {name} alone differs from the default call's")
        ok &= same
    # A failed sample reports NaN for every metric but times (failure values).
    finite = bool(np.all(np.isfinite(np.asarray(outputs["peak_u"]["peak_u"]))))
    if not finite:
        print("check FAILED: a sample failed")
    ok &= finite

    floor = best["floor"]
    rows = []
    print(f"\n{'program':>15} | {'compile s':>9} | {'run s':>7} | {'st-st/s':>9} | {'/floor':>6}")
    for name, run in best.items():
        rate = args.batch * n_steps / run
        rows.append(
            {"program": name, "compile_s": compile_s[name], "run_s": run, "rate": rate,
             "ratio_to_floor": run / floor}
        )  # fmt: skip
        print(
            f"{name:>15} | {compile_s[name]:9.2f} | {run:7.3f} | {rate:9.3e} | {run / floor:6.3f}"
        )
    result = {"batch": args.batch, "horizon": args.horizon, "rounds": args.rounds, "rows": rows}
    return _common.finish(result, meta, args.out, ok)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
