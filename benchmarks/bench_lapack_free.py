"""Closed forms against the LAPACK calls they replaced, in two closed loops' Monte Carlo.

XLA:CPU runs `jnp.linalg.eigvalsh` and `jnp.linalg.solve` as a LAPACK call per matrix: once
per sample and RK4 stage of a batch, outside its fused elementwise code. Two closed loops
had one in their step until 2026-12-03:

- `--scenario zhang2021`: `jaxatt.controllers.PoseSlidingMode`'s robust gain
  ||beta2 C^-1||_2 (6x6; C^-1 = blkdiag(I/m, J^-1)), from `eigvalsh` of the 6x6 Gram matrix;
  now the larger of the two 3x3 blocks' norms in closed form
  (`jaxatt.numerics.largest_eigenvalue3`). Loop: `jaxatt.scenarios.zhang2021_hover.build("ppc")`
  from `zhang2021_tuning.initial_states(key(seed), B, "ppc")`, default metrics.
- `--scenario wu2018`: `jaxatt.controllers.SafeApproachSlidingMode`'s torque correction
  J^-1 (tau - tau_cmd) and the reference's omega_d = G(sigma_d)^-1 sigma_dot_d, from
  `jnp.linalg.solve`; now `jaxatt.numerics.solve3` and G^-1 = G^T / ((1 + |sigma|^2)/4)^2.
  Loop: `jaxatt.scenarios.wu2018.build()` from `wu2018.sample_corridor_starts(key(seed), B)`,
  metric: the peak control (`jaxatt.metrics.Peak("u")`; the loop declares no default metrics).

For each B in `--batches`, the call `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=dt)`
(every other option at its default: metrics reduced on the fly, scalarized on CPU from 1000
samples) is timed twice in one process: with the library as installed, and after
`jax.clear_caches()` with the previous implementation restored in-process (then put back).

Compile time (first call, minus the run) and run time (min of `--repeat` calls after the
first) per row; the two calls' metrics, statuses and failure times must agree to 1e-9
relative (NaN and inf in the same places), or the script exits 1.

Usage (from the repository root):

    python benchmarks/bench_lapack_free.py --scenario zhang2021      # B = 1, 16, 1000; 20 s
    python benchmarks/bench_lapack_free.py --scenario wu2018 --batches 16 1000 --repeat 3
"""

import argparse
import sys
import time

import _common
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", choices=sorted(SCENARIOS), default="zhang2021")
    p.add_argument("--batches", type=int, nargs="+", default=[1, 16, 1000], help="batch sizes")
    p.add_argument("--horizon", type=float, default=20.0, help="simulated time [s]")
    p.add_argument(
        "--dt",
        type=float,
        default=None,
        help="RK4 step [s]; default 0.02 (zhang2021), 0.05 (wu2018)",
    )
    p.add_argument("--repeat", type=int, default=2, help="timed calls after the first")
    p.add_argument("--seed", type=int, default=1, help="key of the initial states")
    p.add_argument(
        "--out",
        default=None,
        help="JSON file; default benchmarks/results/lapack_free_<scenario>.json",
    )
    args = p.parse_args(argv)
    if args.dt is None:
        args.dt = SCENARIOS[args.scenario][2]
    if args.out is None:
        args.out = str(_common.RESULTS_DIR / f"lapack_free_{args.scenario}.json")
    if min(args.batches) < 1 or args.repeat < 1 or args.horizon <= 0 or args.dt <= 0:
        p.error("--batches, --repeat, --horizon and --dt must be positive")
    return args


def _lapack_norm(gain):
    """Zhang 2021's previous robust gain: the 6x6 Gram matrix's largest eigenvalue (LAPACK)."""
    largest = jnp.linalg.eigvalsh(gain @ gain.T)[-1]
    return jnp.sqrt(jnp.maximum(largest, 0.0))


def _lapack_omega_d(self, t):
    """Wu 2018's previous reference rate: omega_d = solve(G(sigma_d), sigma_dot_d) (LAPACK)."""
    from jaxatt.rotations import mrp_kinematics_matrix

    sigma, sigma_dot = jax.jvp(self.sigma_d, (t,), (jnp.ones_like(t),))
    return jnp.linalg.solve(mrp_kinematics_matrix(sigma), sigma_dot)


def zhang2021_lapack():
    from jaxatt.controllers import _pose_sliding_mode

    return _common.restored([(_pose_sliding_mode, "_block_diagonal_norm", _lapack_norm)])


def wu2018_lapack():
    from jaxatt.controllers import _safe_approach
    from jaxatt.scenarios import wu2018

    return _common.restored(
        [
            (_safe_approach, "solve3", jnp.linalg.solve),
            (wu2018.SafeApproachReference, "omega_d", _lapack_omega_d),
        ]
    )


def zhang2021_setup(batch: int, seed: int):
    from jaxatt.scenarios import zhang2021_hover as hover, zhang2021_tuning as zt

    return hover.build("ppc"), zt.initial_states(jr.key(seed), batch, "ppc"), None


def wu2018_setup(batch: int, seed: int):
    import jaxatt
    from jaxatt.scenarios import wu2018

    starts = jnp.asarray(wu2018.sample_corridor_starts(jr.key(seed), batch))
    x0s = jax.vmap(wu2018.initial_state)(starts)
    return wu2018.build(), x0s, {"peak_control": jaxatt.metrics.Peak("u")}


SCENARIOS = {  # name: (setup, previous implementation, default dt)
    "zhang2021": (zhang2021_setup, zhang2021_lapack, 0.02),
    "wu2018": (wu2018_setup, wu2018_lapack, 0.05),
}


def run_row(batch: int, args) -> tuple[float, float, np.ndarray]:
    """(compile s, run s, outputs (batch, k)) of the call at this batch size: the metrics, the
    status and the failure time, one column each."""
    from jaxatt.montecarlo import monte_carlo

    loop, x0s, metrics = SCENARIOS[args.scenario][0](batch, args.seed)

    def call():
        result = monte_carlo(loop, x0s, 0.0, args.horizon, dt=args.dt, metrics=metrics)
        return [*result.metrics.values(), result.status, result.failure_time]

    start = time.perf_counter()
    first = jax.block_until_ready(call())
    first_s = time.perf_counter() - start
    run_s = _common.run_time(lambda: jax.block_until_ready(call()), args.repeat)
    columns = [np.asarray(a, dtype=float).reshape(batch, -1) for a in first]
    return first_s - run_s, run_s, np.concatenate(columns, axis=1)


def main(args) -> int:
    jax.config.update("jax_enable_x64", True)
    meta = _common.machine_meta()
    _common.print_meta(meta, __doc__.split("\n\n")[0])
    steps = round(args.horizon / args.dt)
    rows, ok = [], True
    print(
        f"{'B':>6} {'LAPACK compile s':>16} {'closed compile s':>16} {'LAPACK us/st-st':>15} "
        f"{'closed us/st-st':>15} {'speed-up':>8} {'max rel diff':>12}"
    )
    for batch in args.batches:
        with SCENARIOS[args.scenario][1]():
            lapack = run_row(batch, args)
        closed = run_row(batch, args)
        diff = _common.relative_difference(lapack[2], closed[2])
        ok &= bool(np.isfinite(diff) and diff <= 1e-9)
        per = [s / (batch * steps) * 1e6 for s in (lapack[1], closed[1])]
        row = {
            "batch": batch,
            "lapack": {"compile_s": lapack[0], "run_s": lapack[1], "us_per_state_step": per[0]},
            "closed_form": {
                "compile_s": closed[0],
                "run_s": closed[1],
                "us_per_state_step": per[1],
            },
            "speed_up": per[0] / per[1],
            "max_relative_difference": diff,
        }
        rows.append(row)
        print(
            f"{batch:>6} {lapack[0]:>16.1f} {closed[0]:>16.1f} {per[0]:>15.3g} {per[1]:>15.3g} "
            f"{row['speed_up']:>7.2f}x {diff:>12.2g}",
            flush=True,
        )
    result = {
        "scenario": args.scenario,
        "horizon_s": args.horizon,
        "dt": args.dt,
        "seed": args.seed,
        "rows": rows,
    }
    return _common.finish(result, meta, args.out, ok)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
