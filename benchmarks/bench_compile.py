"""Compile time of Chen 2022's M1 `simulate` and of one `jaxatt.tune` step, phase by phase, and
a count of recompilations when only gain values change.

**Compile time.** For each program, `jax.clear_caches()`, then
`traced = jax.jit(f).trace(*args)` (Python tracing to a jaxpr, including everything jaxatt
does at trace time), `lowered = traced.lower()` (jaxpr to StableHLO) and
`compiled = lowered.compile()` (XLA's optimization and code generation), each timed alone; no
run. The size of the StableHLO module and of XLA's optimized HLO (lines of text) is reported
too. `f` takes the arrays of its arguments (`eqx.partition(..., eqx.is_array)`) and closes over
the rest, so it is the same program the `eqx.filter_jit` functions below compile. Programs:

- `simulate, one trajectory`: `simulate(loop, x0, 0, T, dt=dt, save_every=steps/10,
  throw=False)` of `jaxatt.scenarios.chen2022_two_phase_power.build("M1")` (classic RK4,
  dt = 1e-3 s, 30 N m saturation) from one `chen2022_tuning.initial_states` sample;
- `vmap(simulate), batch B` for each B in `--batches`: the same under `jax.vmap`;
- `monte_carlo, batch B`: `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=dt,
  save_every=steps/10)` (default metrics, no trajectories kept);
- `tune step`: `jaxatt.tune._loop._loss_and_grad` (the `eqx.filter_jit` program behind
  `jaxatt.tune.loss_and_grad`, which every `jaxatt.tune.tune` step runs: `value_and_grad` of the
  objective; the optax update is a separate, small program) for `chen2022_tuning.parameters()`
  (five gains), `chen2022_tuning.objective(dt, horizon)` (differentiable settling time plus the
  chattering penalty; the scenario tunes with dt = 5e-3 s over 10 s) and `--tune-batch`
  initial states.

**Recompilations.** With `jax_log_compiles` on, a logging handler counts JAX's
"Finished tracing ..." and "Finished XLA compilation of jit(NAME) ..." records per function
name. Each user-facing entry point is called once (it compiles), then with `--variants` (5)
other gain values: new arrays of the same shape, dtype and weak type, written into the loop
with `eqx.tree_at` (rho, eta, lambda, p1/q1, q2/p2 scaled by 1 + 0.05 k). Any new trace or
compilation of the function is a recompilation, and the check fails. Entry points:

- `simulate(loop_k, x0, ...)` called directly (counted: `integrate`, its inner jit), over a
  `--check-horizon` trajectory;
- `bench_montecarlo.make_jaxatt("monte_carlo", ...)`: `eqx.filter_jit` of
  `monte_carlo(..., keep_trajectories=True)` with the loop as an argument (counted: `run`),
  batch `--check-batch`;
- `jaxatt.montecarlo.monte_carlo(loop_k, x0s, ...)` called directly (counted: `run_batch`, its
  inner jit);
- `jaxatt.tune.tune(..., steps=variants + 1)` after `jax.clear_caches()`: every step changes the
  unconstrained gains (counted: `_loss_and_grad`; exactly one compilation expected);
- `_loss_and_grad` called directly with `variants` templates whose gains differ (same
  parameters and objective objects as `tune` used: zero new compilations expected).

Reported, not checked: the same direct `simulate` calls with *strongly typed* gains
(`jnp.asarray(v, dtype=float64)`; weakly typed gains would make the first such call retrace,
as any change of weak type does; jaxatt's constructors now store strongly typed arrays, so
with the scenario's gains these calls are the variants above), and whether
`jaxatt.tune.apply` keeps the template's weak types.

**Recorded defaults** (estimated 3 to 5 minutes on 2 cores, most of it compiling and the six
tuning steps of the `tune` check):

    python benchmarks/bench_compile.py   # T 30 s, batch 1000, tune batch 256 at dt 5e-3 over 10 s

A small run (about 3 minutes on a loaded 2-core machine; compile times barely depend on sizes):

    python benchmarks/bench_compile.py --horizon 1 --batches 16 --tune-batch 4 \
        --tune-horizon 1 --check-horizon 0.1 --check-batch 4
"""

import argparse
import contextlib
import logging
import re
import sys
import time


try:  # imported as `benchmarks.bench_compile`
    from . import _common as common
except ImportError:  # run as a script: benchmarks/ is sys.path[0]
    import _common as common


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--horizon", type=float, default=30.0, help="simulate's horizon [s]")
    p.add_argument("--batches", type=int, nargs="*", default=[1000], help="vmapped batch sizes")
    p.add_argument("--tune-batch", type=int, default=256, help="training batch of the step")
    p.add_argument("--tune-dt", type=float, default=5e-3, help="RK4 step of the tuning [s]")
    p.add_argument("--tune-horizon", type=float, default=10.0, help="tuning horizon [s]")
    p.add_argument("--variants", type=int, default=5, help="gain values tried after the first call")
    p.add_argument(
        "--check-horizon", type=float, default=1.0, help="horizon of the recompile calls [s]"
    )
    p.add_argument("--check-batch", type=int, default=64, help="batch of the monte_carlo calls")
    p.add_argument("--no-tune", action="store_true", help="skip the tuning step")
    common.add_common_arguments(p)
    args = p.parse_args(argv)
    common.finish_arguments(p, args, [args.horizon, args.check_horizon], "compile.json")
    ratio = args.tune_horizon / args.tune_dt
    if args.tune_dt <= 0 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        p.error("--tune-horizon must be a positive whole multiple of --tune-dt")
    if min([*args.batches, args.tune_batch, args.check_batch, args.variants, 1]) < 1:
        p.error("batch sizes and --variants must be positive")
    return args


# ---------------------------------------------------------------------------------------------
# Counting traces and compilations.


class CompileLog(logging.Handler):
    """Collects JAX's `jax_log_compiles` records: ("trace" | "compile", function name, s)."""

    PATTERNS = {
        "trace": re.compile(r"Finished tracing (?:\+ transforming )?(\S+) for \S+ in (\S+) sec"),
        "compile": re.compile(r"Finished XLA compilation of jit\((\S+)\) in (\S+) sec"),
    }

    def __init__(self):
        super().__init__(level=logging.DEBUG)
        self.records: list[tuple[str, str, float]] = []

    def emit(self, record):
        message = record.getMessage()
        for kind, pattern in self.PATTERNS.items():
            match = pattern.search(message)
            if match:
                self.records.append((kind, match.group(1), float(match.group(2))))

    def count(self, kind: str, name: str, since: int = 0) -> int:
        return sum(1 for k, n, _ in self.records[since:] if k == kind and n == name)

    def others(self, name: str, since: int = 0) -> dict[str, int]:
        """Compilations of any other function since `since` (small eager ops, helpers)."""
        out: dict[str, int] = {}
        for kind, n, _ in self.records[since:]:
            if kind == "compile" and n != name:
                out[n] = out.get(n, 0) + 1
        return out


@contextlib.contextmanager
def logged_compiles():
    """`jax_log_compiles` on, its records to a `CompileLog` (and not to the console)."""
    import jax

    logger = logging.getLogger("jax")
    handler = CompileLog()
    old = (logger.level, logger.propagate, jax.config.jax_log_compiles)
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG)
    logger.propagate = False
    jax.config.update("jax_log_compiles", True)
    try:
        yield handler
    finally:
        jax.config.update("jax_log_compiles", old[2])
        logger.removeHandler(handler)
        logger.setLevel(old[0])
        logger.propagate = old[1]


def count_recompiles(log: CompileLog, name: str, calls) -> dict:
    """Call `calls[0]` (the first, compiling call), then the rest; count traces and compiles of
    `name` in each part. `calls` are thunks returning something to block on."""
    import jax

    start = len(log.records)
    begin = time.perf_counter()
    jax.block_until_ready(calls[0]())
    first_s = time.perf_counter() - begin
    mark = len(log.records)
    times = []
    for call in calls[1:]:
        begin = time.perf_counter()
        jax.block_until_ready(call())
        times.append(time.perf_counter() - begin)
    return {
        "function": name,
        "first_call_s": first_s,
        "first_call_traces": log.count("trace", name, start) - log.count("trace", name, mark),
        "first_call_compiles": log.count("compile", name, start) - log.count("compile", name, mark),
        "later_calls": len(calls) - 1,
        "later_call_s": times,
        "retraces": log.count("trace", name, mark),
        "recompiles": log.count("compile", name, mark),
        "other_compiles_in_later_calls": log.others(name, mark),
    }


# ---------------------------------------------------------------------------------------------
# Gain variants.

GAINS = ("rho", "eta", "lambda", "p1/q1", "q2/p2")


def gain_variants(loop, parameters, n: int, *, strong: bool = False) -> list:
    """`n` copies of `loop` with every tuned gain scaled by 1 + 0.05 k (k = 1..n).

    The new values are arrays of the old shape and dtype; weakly typed like the old ones
    unless `strong` (then `jnp.asarray(v, dtype=old.dtype)`, strongly typed).
    """
    import equinox as eqx
    import jax.numpy as jnp
    import numpy as np

    loops = []
    for k in range(1, n + 1):
        new = loop
        for name in GAINS:
            where = parameters[name].where
            old = where(new)
            value = np.asarray(old) * (1 + 0.05 * k)
            if name == "q2/p2":  # stays inside (0, 1)
                value = np.asarray(old) * (1 - 0.05 * k)
            if strong or not old.weak_type:
                array = jnp.asarray(value, dtype=old.dtype)
            else:
                array = jnp.asarray(value.item()) if value.ndim == 0 else jnp.asarray(value)
            assert array.shape == old.shape and array.dtype == old.dtype
            assert array.weak_type == (old.weak_type and not strong)
            new = eqx.tree_at(where, new, array)
        loops.append(new)
    return loops


# ---------------------------------------------------------------------------------------------
# Phases.


def count_equations(jaxpr) -> int:
    """Equations of a jaxpr, those of its sub-jaxprs (calls, loop bodies, ...) included once."""
    jaxpr = getattr(jaxpr, "jaxpr", jaxpr)  # a ClosedJaxpr holds its Jaxpr in `.jaxpr`
    total = 0
    for eqn in jaxpr.eqns:
        total += 1
        for value in eqn.params.values():
            for sub in value if isinstance(value, (list, tuple)) else (value,):
                if hasattr(getattr(sub, "jaxpr", sub), "eqns"):
                    total += count_equations(sub)
    return total


def phases(function, args) -> dict:
    """Trace, lower and compile times of `jax.jit(function)` on `args` (caches cleared)."""
    import jax

    jax.clear_caches()
    jitted = jax.jit(function)
    start = time.perf_counter()
    traced = jitted.trace(*args)
    t_trace = time.perf_counter()
    lowered = traced.lower()
    t_lower = time.perf_counter()
    compiled = lowered.compile()
    t_compile = time.perf_counter()
    return {
        "trace_s": t_trace - start,
        "lower_s": t_lower - t_trace,
        "compile_s": t_compile - t_lower,
        "total_s": t_compile - start,
        "jaxpr_equations": count_equations(traced.jaxpr),
        "stablehlo_lines": len(lowered.as_text().splitlines()),
        "optimized_hlo_lines": len(compiled.as_text().splitlines()),
        "xla_cost": common.xla_cost(compiled),
    }


def closing_over_static(fn, tree):
    """`(g, arrays)` with `g(arrays) == fn(*tree)`: the non-array leaves are closed over."""
    import equinox as eqx

    arrays, static = eqx.partition(tree, eqx.is_array)

    def g(arrays):
        return fn(*eqx.combine(arrays, static))

    return g, (arrays,)


def main(args) -> int:
    common.enable_precision(args.dtype)
    import jax
    import optax

    from jaxatt import tune
    from jaxatt.montecarlo import monte_carlo
    from jaxatt.scenarios import chen2022_tuning
    from jaxatt.simulation import simulate
    from jaxatt.tune._loop import _loss_and_grad

    meta = common.machine_meta()
    common.print_meta(
        meta,
        f"Chen 2022 M1: compile phases of simulate (T {args.horizon:g} s, dt {args.dt:g} s), "
        f"vmap(simulate) at batches {args.batches}, and a tune step (batch {args.tune_batch}, "
        f"dt {args.tune_dt:g} s, T {args.tune_horizon:g} s); recompilations over "
        f"{args.variants} gain variants; {args.dtype}; persistent compilation cache: "
        f"{meta['jax_compilation_cache_dir']}",
    )
    big = max([*args.batches, args.tune_batch, args.check_batch, 1])
    loop, pool = common.m1_setup(args.seed, big, args.dtype)
    x0 = jax.tree_util.tree_map(lambda x: x[0], pool)
    parameters = chen2022_tuning.parameters()
    steps = common.steps_of(args.horizon, args.dt)
    save_every = common.default_save_every(steps)

    def one(loop, x0, horizon=args.horizon, save_every=save_every):
        return simulate(loop, x0, 0.0, horizon, dt=args.dt, save_every=save_every, throw=False)

    def batch(loop, x0s):
        return jax.vmap(lambda x0: one(loop, x0))(x0s)

    def batch_monte_carlo(loop, x0s):
        out = monte_carlo(loop, x0s, 0.0, args.horizon, dt=args.dt, save_every=save_every)
        return out.metrics, out.status

    # 1. Compile phases.
    rows = []

    def record(name, fn, tree):
        g, arrays = closing_over_static(fn, tree)
        row = {"program": name, **phases(g, arrays)}
        rows.append(row)
        print(
            f"  {name:<28}: trace {row['trace_s']:.2f} s, lower {row['lower_s']:.2f} s, "
            f"compile {row['compile_s']:.2f} s (total {row['total_s']:.2f} s), "
            f"{row['stablehlo_lines']} StableHLO lines",
            flush=True,
        )

    print("compile phases (jax.clear_caches() before each):")
    record("simulate, one trajectory", one, (loop, x0))
    for b in args.batches:
        record(f"vmap(simulate), batch {b}", batch, (loop, common.take(pool, b)))
        record(f"monte_carlo, batch {b}", batch_monte_carlo, (loop, common.take(pool, b)))
    optimizer = optax.adam(chen2022_tuning.LEARNING_RATE)
    objective = chen2022_tuning.objective(dt=args.tune_dt, horizon=args.tune_horizon)
    inputs = common.take(pool, args.tune_batch)
    u0 = tune.initial_unconstrained(loop, parameters)
    step_args = (u0, loop, parameters, objective, inputs)
    if not args.no_tune:
        record("tune step (loss_and_grad)", _loss_and_grad, step_args)

    # 2. Recompilations.
    checks = []
    horizon = args.check_horizon
    check_save = common.default_save_every(common.steps_of(horizon, args.dt))
    variants = gain_variants(loop, parameters, args.variants)
    strong = gain_variants(loop, parameters, args.variants, strong=True)
    x0s = common.take(pool, args.check_batch)
    run = common.montecarlo.make_jaxatt("monte_carlo", horizon, args.dt, check_save)

    def direct(m):
        return lambda: simulate(m, x0, 0.0, horizon, dt=args.dt, save_every=check_save)

    print(f"recompilations over {args.variants} gain variants (T {horizon:g} s):")
    with logged_compiles() as log:
        jax.clear_caches()
        checks.append(
            {
                "entry": "simulate(loop_k, x0, ...) directly",
                **count_recompiles(log, "integrate", [direct(m) for m in [loop, *variants]]),
            }
        )
        checks.append(
            {
                "entry": f"filter_jit(monte_carlo), loop an argument, batch {args.check_batch}",
                **count_recompiles(
                    log, "run", [lambda m=m: run(m, x0s) for m in [loop, *variants]]
                ),
            }
        )
        checks.append(
            {
                "entry": f"monte_carlo(loop_k, x0s, ...) directly, batch {args.check_batch}",
                **count_recompiles(
                    log,
                    "run_batch",
                    [
                        lambda m=m: (
                            monte_carlo(
                                m, x0s, 0.0, horizon, dt=args.dt, save_every=check_save
                            ).metrics
                        )
                        for m in [loop, *variants]
                    ],
                ),
            }
        )
        if not args.no_tune:
            jax.clear_caches()
            mark = len(log.records)
            start = time.perf_counter()
            result = tune.tune(
                loop,
                parameters,
                objective,
                inputs,
                steps=args.variants + 1,
                optimizer=optimizer,
                progress=False,
            )
            wall = time.perf_counter() - start
            compiles = log.count("compile", "_loss_and_grad", mark)
            checks.append(
                {
                    "entry": f"jaxatt.tune.tune(steps={args.variants + 1})",
                    "function": "_loss_and_grad",
                    "steps": args.variants + 1,
                    "wall_s": wall,
                    "first_call_compiles": min(compiles, 1),
                    "recompiles": max(compiles - 1, 0),
                    "retraces": max(log.count("trace", "_loss_and_grad", mark) - 1, 0),
                    "losses": [float(v) for v in result.losses],
                }
            )
            calls = [
                lambda m=m: _loss_and_grad(u0, m, parameters, objective, inputs) for m in variants
            ]
            calls.insert(0, lambda: _loss_and_grad(*step_args))
            entry = "_loss_and_grad(u0, template_k, ...) directly, after tune"
            checks.append({"entry": entry, **count_recompiles(log, "_loss_and_grad", calls)})
        informational = {
            "entry": "simulate(loop_k, x0, ...) with strongly typed gains",
            **count_recompiles(log, "integrate", [direct(m) for m in [loop, *strong]]),
        }
    applied = tune.apply(loop, parameters, u0)
    weak = {
        name: {
            "template": bool(parameters[name].where(loop).weak_type),
            "after_apply": bool(parameters[name].where(applied).weak_type),
        }
        for name in GAINS
    }
    informational["tune_apply_weak_types"] = weak

    for c in checks:
        print(
            f"  {c['entry']}: first call {c['first_call_compiles']} compilation(s); later calls "
            f"{c['recompiles']} recompilation(s), {c['retraces']} retrace(s)",
            flush=True,
        )
    print(
        f"  (not checked) {informational['entry']}: {informational['recompiles']} "
        f"recompilation(s), {informational['retraces']} retrace(s) over {args.variants} calls"
    )
    lost = [name for name, w in weak.items() if w["template"] and not w["after_apply"]]
    if lost:
        print(
            f"  (not checked) jaxatt.tune.apply returns strongly typed {', '.join(lost)} where the "
            "template's are weakly typed: a module it returns (e.g. TuneResult.module) compiles "
            "anew in a jitted function compiled for the template"
        )

    print_table(rows, args, meta)
    ok = all(c["recompiles"] == 0 and c["retraces"] == 0 for c in checks)
    print()
    for c in checks:
        verdict = "ok" if c["recompiles"] == 0 and c["retraces"] == 0 else "FAILED"
        print(
            f"check: {c['entry']}: {c['recompiles']} recompilations, {c['retraces']} retraces "
            f"after the first call: {verdict}"
        )
    result = {
        "benchmark": "chen2022 M1 compile time (trace, lower, XLA compile) and recompilations",
        "units": {"time": "s"},
        "settings": {
            **vars(args),
            "save_every": save_every,
            "gain_variants": "rho, eta, lambda, p1/q1 x (1 + 0.05 k), q2/p2 x (1 - 0.05 k)",
            "optimizer": f"adam({chen2022_tuning.LEARNING_RATE})",
        },
        "phases": rows,
        "recompilation_checks": checks,
        "informational": informational,
    }
    return common.finish(result, meta, args.out, ok)


def print_table(rows, args, meta) -> None:
    header = [
        ("program", 28),
        ("trace s", 7),
        ("lower s", 7),
        ("compile s", 9),
        ("total s", 7),
        ("jaxpr eqns", 10),
        ("StableHLO lines", 15),
        ("opt. HLO lines", 14),
    ]
    line = " | ".join(f"{name:>{width}}" for name, width in header)
    print()
    print(
        f"Measured on {meta['device_kind']} ({meta['cpu']['model']}, {meta['cpu_count']} CPUs), "
        f"{args.dtype}, {meta['date']}"
    )
    print(line)
    print("-" * len(line))
    for row in rows:
        print(
            f"{row['program']:>28} | {row['trace_s']:>7.2f} | {row['lower_s']:>7.2f} | "
            f"{row['compile_s']:>9.2f} | {row['total_s']:>7.2f} | {row['jaxpr_equations']:>10} | "
            f"{row['stablehlo_lines']:>15} | {row['optimized_hlo_lines']:>14}"
        )
    print(
        "  trace = jax.jit(f).trace(...) (Python to jaxpr), lower = .lower() (to StableHLO), "
        "compile = .compile() (XLA); jaxpr eqns = equations of the traced jaxpr, "
        "sub-jaxprs (calls, loop bodies) included once"
    )


if __name__ == "__main__":
    sys.exit(main(parse_args()))
