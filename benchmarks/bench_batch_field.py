"""What `batch_field`'s per-sample checks cost a robustness study over inertias.

`jaxatt.montecarlo.batch_field(loop, "plant.body.inertia", inertias)` rebuilds the modules on
the path to the field once per sample, so that every sample meets the rules of the
constructors (a `RigidBody`'s inertia symmetric positive definite, its signals of the right
shape). The script times that call on Chen et al. (2022)'s M1 closed loop with `--batch`
inertias from `inertia_dispersion` (10 % principal scale, 0.05 rad misalignment, float64),
with the signals' shape check cached per signal object (the library's behaviour) and with
that cache switched off (every rebuild traces the signals again, as before the cache), in
turns (`--rounds` rounds, the fastest of each reported). Checked: both give the same batched
loop.

Usage (from the repository root):

    python benchmarks/bench_batch_field.py                 # 1000 inertias
    python benchmarks/bench_batch_field.py --batch 10000 --rounds 2
"""

import argparse
import sys
import time

import _common
import jax
import jax.random as jr
import numpy as np

from jaxatt.montecarlo import batch_field, inertia_dispersion
from jaxatt.scenarios import chen2022_two_phase_power as chen
from jaxatt.signals import _signals


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batch", type=int, default=1000, help="inertias in the batch")
    p.add_argument("--rounds", type=int, default=3, help="round-robin timing rounds")
    p.add_argument(
        "--out",
        default=str(_common.RESULTS_DIR / "batch_field.json"),
        help="JSON file (default benchmarks/results/batch_field.json)",
    )
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    jax.config.update("jax_enable_x64", True)
    meta = _common.machine_meta()
    _common.print_meta(meta, f"batch_field over {args.batch} inertias of Chen 2022 M1")
    loop = chen.build("M1")
    inertias = inertia_dispersion(
        jr.key(0), args.batch, loop.plant.body.inertia, principal_scale=0.1, max_misalignment=0.05
    )
    kept = _signals._OUTPUT_SHAPES_KEPT

    def timed(cache: bool) -> tuple[float, object]:
        _signals._OUTPUT_SHAPES_KEPT = kept if cache else 0
        _signals._OUTPUT_SHAPES.clear()
        start = time.perf_counter()
        batched, _ = batch_field(loop, "plant.body.inertia", inertias)
        return time.perf_counter() - start, batched

    timed(True)  # warm-up: imports, the first traces
    best = {"cached": float("inf"), "uncached": float("inf")}
    loops = {}
    for _ in range(args.rounds):
        for name in best:
            seconds, loops[name] = timed(name == "cached")
            best[name] = min(best[name], seconds)
    same = all(
        np.array_equal(a, b)
        for a, b in zip(jax.tree.leaves(loops["cached"]), jax.tree.leaves(loops["uncached"]))
    )
    _signals._OUTPUT_SHAPES_KEPT = kept
    ratio = best["uncached"] / best["cached"]
    for name, seconds in best.items():
        print(f"{name:>9}: {seconds:.3f} s ({1e3 * seconds / args.batch:.3f} ms per sample)")
    print(f"cached / uncached speed-up: {ratio:.2f}x; same batched loop: {same}")
    result = {"batch": args.batch, "rounds": args.rounds, "seconds": best, "speedup": ratio}
    return _common.finish(result, meta, args.out, bool(same))


if __name__ == "__main__":
    sys.exit(main())
