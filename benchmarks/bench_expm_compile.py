"""Compile time of `jaxatt.networks.expm` against `jax.scipy.linalg.expm`.

`jaxatt.networks.expm` (Padé-13 scaling and squaring with one branch and a fixed-length,
masked squaring scan) exists to keep the compiled programs of the sampled-data consensus
loops small. This script measures what its docstring states: for an `n x n` float64 matrix,
the time to lower and compile `jax.jit(f)` and `jax.jit(jax.grad(sum of f))`, after
`jax.clear_caches()`, minimum of `--repeat` tries, for each implementation, in one process
with whatever `XLA_FLAGS` the environment sets. The two values must agree to 1e-12 relative
or the script exits 1.

Usage (from the repository root):

    python benchmarks/bench_expm_compile.py                  # n = 4, 3 tries; ~10 s
    python benchmarks/bench_expm_compile.py --size 8 --repeat 5
"""

import argparse
import sys
import time

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np


def compile_seconds(fn, a, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        jax.clear_caches()
        start = time.perf_counter()
        jax.jit(fn).lower(a).compile()
        times.append(time.perf_counter() - start)
    return min(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=4, help="matrix size n (default 4)")
    parser.add_argument("--repeat", type=int, default=3, help="tries per entry (default 3)")
    args = parser.parse_args(argv)
    jax.config.update("jax_enable_x64", True)
    from jaxatt.networks import expm

    n = args.size
    a = 0.3 * jnp.eye(n) + 0.1 * jnp.arange(n * n, dtype=float).reshape(n, n) / (n * n)
    ours, reference = np.asarray(expm(a)), np.asarray(jsl.expm(a))
    if not np.allclose(ours, reference, rtol=1e-12, atol=0.0):
        print(f"values differ: max |diff| {np.max(np.abs(ours - reference)):.3g}")
        return 1
    rows = []
    for label, f in (("jaxatt.networks.expm", expm), ("jax.scipy.linalg.expm", jsl.expm)):
        value = compile_seconds(f, a, args.repeat)
        grad = compile_seconds(jax.grad(lambda m, f=f: jnp.sum(f(m))), a, args.repeat)
        rows.append((label, value, grad))
    print(f"{n} x {n} float64, lower + compile [s], min of {args.repeat}, on {jax.devices()[0]}")
    print(f"{'implementation':24s} | {'value':>7s} | {'gradient':>8s}")
    for label, value, grad in rows:
        print(f"{label:24s} | {value:7.3f} | {grad:8.3f}")
    (_, v0, g0), (_, v1, g1) = rows
    print(f"ratio (jax.scipy / jaxatt): value {v1 / v0:.2f}x, gradient {g1 / g0:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
