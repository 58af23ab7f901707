"""Zhang 2021's pose controller: the robust gain ||beta2 C^-1||_2 in closed form against LAPACK.

`jaxatt.controllers.PoseSlidingMode` multiplies the disturbance bound by the spectral norm of
beta2 C^-1 (6x6; C^-1 = blkdiag(I/m, J^-1)). It used to take it from a 6x6 symmetric
eigenvalue problem (`jnp.linalg.eigvalsh`), which XLA:CPU runs as a LAPACK call (`dsyevd`) per
matrix: once per sample and RK4 stage, outside the fused elementwise code of a batch. It now
takes the larger of the two 3x3 blocks' norms in closed form (`jaxatt.numerics.eigvalsh3`).
This script times both in one process, on the hover scenario's "ppc" closed loop
(`jaxatt.scenarios.zhang2021_hover.build("ppc")`, RK4 at `--dt`, `--horizon` seconds) from the
first B initial states of `jaxatt.scenarios.zhang2021_tuning.initial_states(key(seed), B,
"ppc")` for each B in `--batches`:

- closed form: `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=dt)` with every option at
  its default (default metrics reduced on the fly; scalarized on CPU from 1000 samples), the
  library as installed;
- LAPACK: the same call after `jax.clear_caches()`, with the controller's robust gain replaced
  in-process by the previous implementation (`sqrt(eigvalsh(G G^T)[-1])` of the whole 6x6
  `G = beta2 C^-1`), then restored.

Compile time (first call, minus the run) and run time (min of `--repeat` calls after the
first) per row; the two calls' default metrics, statuses and failure times must agree to
1e-9 relative (NaN and inf in the same places), or the script exits 1.

Usage (from the repository root):

    python benchmarks/bench_pose_robust_gain.py                     # B = 1, 16, 1000; 20 s
    python benchmarks/bench_pose_robust_gain.py --batches 100 1000 --horizon 50 --repeat 3
"""

import argparse
import contextlib
import sys
import time

import _common
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[1, 16, 1000], help="batch sizes")
    p.add_argument("--horizon", type=float, default=20.0, help="simulated time [s]")
    p.add_argument("--dt", type=float, default=0.02, help="RK4 step [s] (the scenario's short one)")
    p.add_argument("--repeat", type=int, default=2, help="timed calls after the first")
    p.add_argument("--seed", type=int, default=1, help="key of the initial states")
    p.add_argument(
        "--out", default=str(_common.RESULTS_DIR / "pose_robust_gain.json"), help="JSON file"
    )
    args = p.parse_args(argv)
    if min(args.batches) < 1 or args.repeat < 1 or args.horizon <= 0 or args.dt <= 0:
        p.error("--batches, --repeat, --horizon and --dt must be positive")
    return args


def _lapack_norm(gain):
    """The previous robust gain: the 6x6 Gram matrix's largest eigenvalue from LAPACK."""
    largest = jnp.linalg.eigvalsh(gain @ gain.T)[-1]
    return jnp.sqrt(jnp.maximum(largest, 0.0))


@contextlib.contextmanager
def lapack_robust_gain():
    from jaxatt.controllers import _pose_sliding_mode as module

    closed_form = module._block_diagonal_norm
    module._block_diagonal_norm = _lapack_norm
    jax.clear_caches()
    try:
        yield
    finally:
        module._block_diagonal_norm = closed_form
        jax.clear_caches()


def run_row(batch: int, args) -> tuple[float, float, np.ndarray]:
    """(compile s, run s, outputs (batch, k)) of the default call at this batch size: the
    default metrics, the status and the failure time, one column each."""
    from jaxatt.montecarlo import monte_carlo
    from jaxatt.scenarios import zhang2021_hover as hover, zhang2021_tuning as zt

    loop = hover.build("ppc")
    x0s = zt.initial_states(jr.key(args.seed), batch, "ppc")

    def call():
        result = monte_carlo(loop, x0s, 0.0, args.horizon, dt=args.dt)
        return [*result.metrics.values(), result.status, result.failure_time]

    start = time.perf_counter()
    first = jax.block_until_ready(call())
    first_s = time.perf_counter() - start
    run_s = _common.run_time(lambda: jax.block_until_ready(call()), args.repeat)
    columns = [np.asarray(a, dtype=float).reshape(batch, -1) for a in first]
    return first_s - run_s, run_s, np.concatenate(columns, axis=1)


def relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a - b| / max(|a|, 1e-12) over the finite entries; inf if the two disagree on
    which entries are finite or on their values there (NaN equals NaN: a failed sample's
    peak is NaN in both)."""
    finite = np.isfinite(a)
    if not np.array_equal(finite, np.isfinite(b)) or not np.array_equal(
        a[~finite], b[~finite], equal_nan=True
    ):
        return float("inf")
    scale = np.maximum(np.abs(a[finite]), 1e-12)
    return float(np.max(np.abs(a[finite] - b[finite]) / scale, initial=0.0))


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
        with lapack_robust_gain():
            lapack = run_row(batch, args)
        closed = run_row(batch, args)
        diff = relative_difference(lapack[2], closed[2])
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
    result = {"horizon_s": args.horizon, "dt": args.dt, "seed": args.seed, "rows": rows}
    return _common.finish(result, meta, args.out, ok)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
