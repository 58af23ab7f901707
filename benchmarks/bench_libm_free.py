"""Vectorized transcendental functions against the C-library calls they replaced.

XLA:CPU compiles a float64 `sin`, `cos`, `log` (and so `arctanh`), `atan2` and `acos` into a
call of the C library's scalar function, once per element, between its vectorized kernels;
`exp` it inlines. `jaxatt.numerics` has `vectorized_sincos`, `vectorized_log`/`vectorized_atanh`
and `vectorized_arctan2`/`vectorized_arccos` (fdlibm's algorithms as jnp operations), and the
library's closed loops use them.

Part 1 (`--elements`): nanoseconds per element of one jitted function over 2^20 float64
values: each C-library function against its vectorized replacement, `exp` for scale (min over
interleaved repeats).

Part 2 (`--scenarios`): the call `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=dt,
metrics=...)` (every other option at its default: metrics reduced on the fly, scalarized on CPU
from 1000 samples) compiled twice in one process, once as the library is and once with the
C-library functions restored (`jaxatt.numerics._sincos._sincos_float64` returning
`(jnp.sin(x), jnp.cos(x))`, `jaxatt.numerics._log._log_float64` = `jnp.log`,
`jaxatt.numerics._atan`'s `_atan2_float64` = `jnp.arctan2` and `_acos_float64` = `jnp.arccos`
with its `_stored` mark the identity: every caller then traces the library call), each with
the XLA options the eager call would pass (`_quick.UserProgram`). The two compiled programs
are timed round robin (one warm-up each, then `--repeat` rounds, min per program). Their
metrics, statuses and failure times must agree to `--rtol` relative (NaN and inf in the same
places), or the script exits 1.

- `wu2018`: `jaxatt.scenarios.wu2018.build()` from `sample_corridor_starts(key(seed), B)`,
  RK4 dt = 0.05 s, the peak control and the control effort (`Peak("u")`, `Effort()`: the
  integral of |u|^2, which every step's rounding reaches): the Hill frame's rotation
  (`hill_rotation`) for the J2 acceleration and the chief's anomaly rates, sines of the true
  anomaly, at every stage.
- `flyaround`: `jaxatt.scenarios.flyaround.build()` from `dispersed_starts(key(seed), B)`,
  RK4 dt = 0.1 s, the settling time of |rho - rho_d| to 0.1 m, the peak control and the
  control effort (the loop declares no default metrics): the eccentric chief's true anomaly
  and the fly-around reference's phase.
- `chen2022`: Chen 2022 M1 (`chen2022_two_phase_power.build("M1")`,
  `chen2022_tuning.initial_states`), RK4 dt = 1e-3 s, default metrics: the reaching law's
  powers exp(a log|s|) (the logarithm restored).
- `zhang2021`: the "ppc" hover loop (`zhang2021_hover.build("ppc")`), RK4 dt = 0.02 s, default
  metrics: powers and the prescribed-performance transformation's atanh.
- `zhang2021-acos`: the `zhang2021` loop and metrics, the arccosine of Smith's eigenvalue
  formula in the robust gain (`largest_eigenvalue3`) at every stage (the arccosine restored).

Usage (from the repository root):

    python benchmarks/bench_libm_free.py                      # wu2018 and flyaround, B = 1000
    python benchmarks/bench_libm_free.py --scenarios chen2022 --horizon 2 --batches 10000
"""

import argparse
import sys
import time

import _common
import _quick
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--scenarios",
        nargs="*",
        choices=sorted(SCENARIOS),
        default=["wu2018", "flyaround"],
        help="closed loops to time (none: only the per-element table)",
    )
    p.add_argument("--batches", type=int, nargs="+", default=[1000], help="batch sizes")
    p.add_argument(
        "--horizon", type=float, default=None, help="simulated time [s]; default per scenario"
    )
    p.add_argument("--repeat", type=int, default=3, help="timed rounds after the warm-up")
    p.add_argument("--seed", type=int, default=1, help="key of the initial states")
    p.add_argument(
        "--rtol",
        type=float,
        default=1e-9,
        help="largest relative difference allowed between the two programs' outputs",
    )
    p.add_argument(
        "--no-elements", dest="elements", action="store_false", help="skip the per-element table"
    )
    p.add_argument("--out", default=str(_common.RESULTS_DIR / "libm_free.json"), help="JSON file")
    args = p.parse_args(argv)
    if min(args.batches) < 1 or args.repeat < 1 or (args.horizon or 1) <= 0:
        p.error("--batches, --repeat and --horizon must be positive")
    return args


# ---------------------------------------------------------------------------------------------
# Part 1: per element.


def element_costs(repeat: int = 9) -> dict[str, float]:
    """ns per element of each function over 2^20 float64 values in [0.01, 10)."""
    from jaxatt.numerics import (
        vectorized_arccos,
        vectorized_arctan2,
        vectorized_atanh,
        vectorized_log,
        vectorized_sincos,
    )

    n = 1 << 20
    x = jnp.asarray(np.random.default_rng(0).uniform(0.01, 10.0, n))
    z = x / 10.01  # in (0, 1) for atanh
    functions = {
        "exp": (jnp.exp, x),
        "C library: sin": (jnp.sin, x),
        "C library: cos": (jnp.cos, x),
        "C library: sin + cos": (lambda x: jnp.sin(x) + jnp.cos(x), x),
        "vectorized_sincos: sin + cos": (lambda x: sum(vectorized_sincos(x)), x),
        "C library: log": (jnp.log, x),
        "vectorized_log": (vectorized_log, x),
        "C library: arctanh": (jnp.arctanh, z),
        "vectorized_atanh": (vectorized_atanh, z),
        "C library: arctan2": (lambda z: jnp.arctan2(z, 0.5), z),
        "vectorized_arctan2": (lambda z: vectorized_arctan2(z, 0.5), z),
        "C library: arccos": (jnp.arccos, z),
        "vectorized_arccos": (vectorized_arccos, z),
    }
    compiled = {name: jax.jit(f).lower(a).compile() for name, (f, a) in functions.items()}
    best = dict.fromkeys(functions, float("inf"))
    for name, (_, a) in functions.items():
        jax.block_until_ready(compiled[name](a))
    for _ in range(repeat):  # interleaved, so that a change of machine load hits all alike
        for name, (_, a) in functions.items():
            start = time.perf_counter()
            jax.block_until_ready(compiled[name](a))
            best[name] = min(best[name], time.perf_counter() - start)
    return {name: seconds / n * 1e9 for name, seconds in best.items()}


# ---------------------------------------------------------------------------------------------
# Part 2: closed loops.


def _library_sincos(x):
    return jnp.sin(x), jnp.cos(x)


def c_library_sincos():
    from jaxatt.numerics import _sincos

    return _common.restored([(_sincos, "_sincos_float64", _library_sincos)])


def c_library_log():
    from jaxatt.numerics import _log

    return _common.restored([(_log, "_log_float64", jnp.log)])


def c_library_atan():
    from jaxatt.numerics import _atan

    return _common.restored(
        [
            (_atan, "_atan2_float64", jnp.arctan2),
            (_atan, "_acos_float64", jnp.arccos),
            (_atan, "_stored", lambda angle: angle),
        ]
    )


def wu2018_setup(batch: int, seed: int):
    import jaxatt
    from jaxatt.scenarios import wu2018

    starts = jnp.asarray(wu2018.sample_corridor_starts(jr.key(seed), batch))
    x0s = jax.vmap(wu2018.initial_state)(starts)
    metrics = {"peak_control": jaxatt.metrics.Peak("u"), "control_effort": jaxatt.metrics.Effort()}
    return wu2018.build(), x0s, metrics


def flyaround_setup(batch: int, seed: int):
    import jaxatt
    from jaxatt.scenarios import flyaround

    metrics = {
        "position_settling_time": jaxatt.metrics.SettlingTime(
            "position_norm", flyaround.POSITION_TOLERANCE
        ),
        "peak_control": jaxatt.metrics.Peak("u"),
        "control_effort": jaxatt.metrics.Effort(),
    }
    return flyaround.build(), flyaround.dispersed_starts(jr.key(seed), batch), metrics


def chen2022_setup(batch: int, seed: int):
    from jaxatt.scenarios import chen2022_tuning, chen2022_two_phase_power as chen

    return chen.build("M1"), chen2022_tuning.initial_states(jr.key(seed), batch), None


def zhang2021_setup(batch: int, seed: int):
    from jaxatt.scenarios import zhang2021_hover as hover, zhang2021_tuning as zt

    return hover.build("ppc"), zt.initial_states(jr.key(seed), batch, "ppc"), None


SCENARIOS = {  # name: (set-up, C-library functions restored, dt, default horizon)
    "wu2018": (wu2018_setup, c_library_sincos, 0.05, 20.0),
    "flyaround": (flyaround_setup, c_library_sincos, 0.1, 100.0),
    "chen2022": (chen2022_setup, c_library_log, 1e-3, 2.0),
    "zhang2021": (zhang2021_setup, c_library_log, 0.02, 20.0),
    "zhang2021-acos": (zhang2021_setup, c_library_atan, 0.02, 20.0),
}


def compiled_call(name: str, batch: int, args, horizon: float):
    """(compiled program, its arguments, compile s) of the default `monte_carlo` call."""
    from jaxatt.montecarlo import monte_carlo

    setup, _, dt, _ = SCENARIOS[name]
    loop, x0s, metrics = setup(batch, args.seed)

    def call(loop, x0s):
        result = monte_carlo(loop, x0s, 0.0, horizon, dt=dt, metrics=metrics)
        return [*result.metrics.values(), result.status, result.failure_time]

    program = _quick.UserProgram(call)
    start = time.perf_counter()
    compiled = program.lower(loop, x0s).compile()
    return compiled, (loop, x0s), time.perf_counter() - start


def outputs(values, batch: int) -> np.ndarray:
    return np.concatenate([np.asarray(a, dtype=float).reshape(batch, -1) for a in values], axis=1)


def run_row(name: str, batch: int, args) -> dict:
    horizon = args.horizon or SCENARIOS[name][3]
    steps = _common.steps_of(horizon, SCENARIOS[name][2])
    with SCENARIOS[name][1]():
        library = compiled_call(name, batch, args, horizon)
    vectorized = compiled_call(name, batch, args, horizon)
    programs = {"C library": library, "vectorized": vectorized}
    results = {key: jax.block_until_ready(c(*a)) for key, (c, a, _) in programs.items()}
    best = dict.fromkeys(programs, float("inf"))
    for _ in range(args.repeat):
        for key, (compiled, call_args, _) in programs.items():
            start = time.perf_counter()
            jax.block_until_ready(compiled(*call_args))
            best[key] = min(best[key], time.perf_counter() - start)
    diff = _common.relative_difference(
        outputs(results["C library"], batch), outputs(results["vectorized"], batch)
    )
    per = {key: best[key] / (batch * steps) * 1e6 for key in programs}
    return {
        "scenario": name,
        "batch": batch,
        "horizon_s": horizon,
        "dt": SCENARIOS[name][2],
        "compile_s": {key: program[2] for key, program in programs.items()},
        "run_s": best,
        "us_per_state_step": per,
        "speed_up": per["C library"] / per["vectorized"],
        "max_relative_difference": diff,
    }


def main(args) -> int:
    jax.config.update("jax_enable_x64", True)
    meta = _common.machine_meta()
    _common.print_meta(meta, __doc__.split("\n\n")[0])
    result, ok = {"seed": args.seed, "rtol": args.rtol, "repeat": args.repeat}, True
    if args.elements:
        costs = element_costs()
        result["ns_per_element"] = costs
        print("ns per element (2^20 float64 values, min over 9 interleaved calls):")
        for name, ns in costs.items():
            print(f"  {name:30s} {ns:6.2f}")
    rows = []
    print(
        f"{'scenario':>14} {'B':>6} {'compile s (C, vec)':>19} {'C us/st-st':>10} "
        f"{'vec us/st-st':>12} {'speed-up':>8} {'max rel diff':>12}"
    )
    for name in args.scenarios:
        for batch in args.batches:
            row = run_row(name, batch, args)
            ok &= bool(row["max_relative_difference"] <= args.rtol)
            rows.append(row)
            per, compile_s = row["us_per_state_step"], row["compile_s"]
            print(
                f"{name:>14} {batch:>6} {compile_s['C library']:>9.1f} "
                f"{compile_s['vectorized']:>9.1f} {per['C library']:>10.3g} "
                f"{per['vectorized']:>12.3g} {row['speed_up']:>7.2f}x "
                f"{row['max_relative_difference']:>12.2g}",
                flush=True,
            )
    result["rows"] = rows
    return _common.finish(result, meta, args.out, ok)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
