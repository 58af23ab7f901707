"""A quick throughput check of the Chen 2022 M1 Monte Carlo: jaxatt, a hand scan, NumPy.

What `benchmarks/bench_quick.py` prints, and the measuring core of `bench_montecarlo.py`
(which adds SciPy, Basilisk, float32 and the recorded runs) and of the other Chen 2022 M1
benchmarks. A plain module: the scripts run with benchmarks/ first on `sys.path` (as
`python benchmarks/bench_x.py` does) and `import _quick`.

The closed loop is `jaxatt.scenarios.chen2022_two_phase_power.build("M1")`; the baselines are
written from the paper's equations in `_reference.py` (not with jaxatt code), and every row
is checked against jaxatt's final states. jaxatt runs through its own batch runner,
`jaxatt.montecarlo.monte_carlo` (the runner Monte Carlo studies, tuning and scenarios use), with
its default options (`JAXATT_CALLS["monte_carlo"]`) or with scalarization off
(`"monte_carlo_plain"`).

Throughput is in *state-steps per second*: batch size x classic RK4 steps (four vector-field
evaluations each) / wall time of one run. Compile time (ahead-of-time trace, lower and XLA
compile) is reported separately from run time (a warm-up call, then the minimum over repeats).
"""

import time
import timeit

import _reference as ref
import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from jaxatt.montecarlo import monte_carlo
from jaxatt.plants import QuaternionState
from jaxatt.scenarios import chen2022_tuning, chen2022_two_phase_power as chen
from jaxatt.simulation import ClosedLoopState, Performance


_MONTE_CARLO = (
    "eqx.filter_jit(lambda loop, x0s: jaxatt.montecarlo.monte_carlo(loop, x0s, 0.0, T, dt=dt, "
    "save_every=save_every, keep_trajectories=True{})) (default metrics computed; final states "
    "read from the kept trajectories)"
)
JAXATT_CALLS = {
    "monte_carlo_default": "eqx.filter_jit(lambda loop, x0s: jaxatt.montecarlo.monte_carlo(loop, "
    "x0s, 0.0, T, dt=dt)): every option at its default (default metrics reduced on the fly at "
    "every step, nothing saved, scalarized on CPU from 1000 samples per device); final states "
    "from a separate, untimed call with keep_trajectories=True and one save at T",
    "monte_carlo": _MONTE_CARLO.format("")
    + ", default performance options (scalarized on CPU from 1000 samples per device)",
    "monte_carlo_plain": _MONTE_CARLO.format(
        ", performance=jaxatt.simulation.Performance(scalarize=False)"
    )
    + ": the plain vmapped program at every batch",
}
JAXATT_CALLS = {
    name: call + "; the filter_jit gets the XLA compiler options monte_carlo passes when called "
    "eagerly on the batch (UserProgram)"
    for name, call in JAXATT_CALLS.items()
}
"""The jaxatt programs the benchmarks time, by name: all run `jaxatt.montecarlo.monte_carlo`
inside a `jit` of the benchmark's, compiled with the XLA options that `monte_carlo` passes to
its own `jit` when a user calls it eagerly on the same batch (see [`UserProgram`][]): the
programs a user gets."""


class UserProgram:
    """`eqx.filter_jit(fn)` for `fn(loop, x0s)` calling `monte_carlo`, compiled with the XLA
    compiler options `monte_carlo` would pass for the batch `x0s` with `performance`.

    A `jit` around `monte_carlo` makes it part of the benchmark's program, which compiles with
    the benchmark's options (JAX takes compiler options on the top-level `jit` only), so
    timing the eager call's program means passing them here. `lower` and calls pick the
    compiled function by the batch size, like `monte_carlo`.
    """

    def __init__(self, fn, performance: Performance | None = None, batch_size: int | None = None):
        self.fn = fn
        self.performance = Performance() if performance is None else performance
        self.batch_size = batch_size
        self._jits = {}

    def options(self, x0s) -> dict:
        if not hasattr(self.performance, "compiler_options"):
            return {}  # a jaxatt from before the option (bench_defaults' baseline worker)
        from jaxatt.simulation import samples_at_once  # after the guard: not in old jaxatts

        # monte_carlo resolves the options on the samples one device runs at once
        n = jax.tree.leaves(x0s)[0].shape[0]
        at_once = samples_at_once(n, batch_size=self.batch_size, devices=len(jax.devices()))
        return self.performance.resolve(at_once).compiler_options()

    def _jit(self, x0s):
        options = self.options(x0s)
        key = tuple(sorted(options.items()))
        if key not in self._jits:
            self._jits[key] = eqx.filter_jit(self.fn, compiler_options=options or None)
        return self._jits[key]

    def lower(self, loop, x0s):
        return self._jit(x0s).lower(loop, x0s)

    def __call__(self, loop, x0s):
        return self._jit(x0s)(loop, x0s)


def _tolerances(dtype) -> dict[str, float]:
    """Final-state tolerances: same-precision RK4 codes, RK45 (float64), vector field (rel)."""
    if np.dtype(dtype) == np.float64:
        return {"rk4": 1e-9, "scipy": 1e-6, "vector_field": 1e-12}
    return {"rk4": 1e-4, "scipy": 1e-3, "vector_field": 1e-4}


def default_save_every(n_steps: int) -> int:
    """The largest divisor of `n_steps` not above `n_steps // 10` (at least 1)."""
    save_every = max(1, n_steps // 10)
    while n_steps % save_every:
        save_every -= 1
    return save_every


def check_scenario(loop) -> None:
    """Raise if the constants of `_reference.py` are no longer those of the jaxatt loop."""
    from jaxatt.controllers import NormRobustTerm, SlidingModeTracking
    from jaxatt.reaching import Sign, TwoPhasePower
    from jaxatt.references import IntegratedReference
    from jaxatt.simulation import Saturation

    law = loop.controller
    structure = [
        isinstance(law, SlidingModeTracking) and law.surface_feedforward,
        isinstance(law.reaching_law, TwoPhasePower)
        and isinstance(law.reaching_law.switching, Sign),
        isinstance(law.robust, NormRobustTerm),
        isinstance(loop.reference, IntegratedReference),
        isinstance(loop.actuator, Saturation),
        not loop.plant.renormalize,
    ]
    if not all(structure):
        raise RuntimeError(f"scenario structure changed: {structure}")
    body = loop.plant.body
    wd = loop.reference.omega_d
    checks = [
        ("J0", body.inertia, ref.J0),
        (
            "dJ amplitude",
            np.diag(np.asarray(body.inertia_perturbation.amplitude)),
            ref.DJ_AMPLITUDE,
        ),
        (
            "dJ frequency",
            np.diag(np.asarray(body.inertia_perturbation.frequency)),
            ref.DJ_FREQUENCY,
        ),
        ("d amplitude", body.disturbance.amplitude, ref.D_AMPLITUDE),
        ("d frequency", body.disturbance.frequency, ref.D_FREQUENCY),
        ("omega_d amplitude", wd.amplitude, ref.WD_AMPLITUDE),
        ("omega_d frequency", wd.frequency, ref.WD_FREQUENCY),
        ("omega_d phase, offset", (wd.phase, wd.offset), (0.0, 0.0)),
        ("q_d(0)", loop.reference.q_d0, ref.QD0),
        ("lambda", law.surface.slope, ref.SLOPE),
        ("rho", law.reaching_law.rho, ref.RHO),
        ("eta", law.reaching_law.eta, ref.ETA),
        ("p1/q1", law.reaching_law.beta, ref.BETA),
        ("q2/p2", law.reaching_law.alpha, ref.ALPHA),
        ("controller J0", law.inertia, ref.J0),
        ("sigma", law.robust.sigma, ref.SIGMA),
        ("eps", law.robust.eps, ref.EPS),
        ("torque limit", loop.actuator.limit, ref.LIMIT),
    ]
    for name, got, expected in checks:
        got = np.asarray(got, dtype=np.float64)
        if not np.allclose(got, np.broadcast_to(expected, got.shape), rtol=1e-6, atol=1e-12):
            raise RuntimeError(f"scenario constant {name} changed: {got} != {expected}")


def check_vector_field(loop, q, omega, key, dtype) -> dict:
    """Max relative difference of the jaxatt closed-loop vector field and the reference one.

    At `len(q)` states built from the given attitudes and rates, at random t in [0, 30] s: in
    the first half q_d is a random unit quaternion and the rates are scaled by 1x to 40x
    (large errors: saturated torque, |s_i| >= 1); in the second half q_d is q plus a 2%
    perturbation, renormalized (small errors: unsaturated, |s_i| < 1). The reference runs in
    float64 on the same (rounded) inputs; the difference is divided by the largest
    |component| of each derivative.
    """
    n = q.shape[0]
    k_scale, k_qd, k_near, k_t = jr.split(key, 4)
    far = (jnp.arange(n) < n // 2)[:, None]
    scale = jr.uniform(k_scale, (n, 1), minval=1.0, maxval=40.0, dtype=dtype)
    omega = jnp.where(far, omega * scale, omega)
    qd = jnp.where(
        far, jr.normal(k_qd, (n, 4), dtype=dtype), q + 0.02 * jr.normal(k_near, (n, 4), dtype)
    )
    qd = qd / jnp.linalg.norm(qd, axis=1, keepdims=True)
    t = jr.uniform(k_t, (n,), maxval=30.0, dtype=dtype)

    @jax.jit
    def jaxatt_field(t, q, omega, qd):
        def one(t, q, omega, qd):
            dy = loop(t, ClosedLoopState(QuaternionState(q, omega), qd, None), None)
            return jnp.concatenate([dy.plant.q, dy.plant.omega, dy.reference])

        return jax.vmap(one)(t, q, omega, qd)

    got = np.asarray(jaxatt_field(t, q, omega, qd), dtype=np.float64)
    t64 = np.asarray(t, np.float64)
    inputs = np.concatenate([np.asarray(x, np.float64) for x in (q, omega, qd)], axis=1)
    expected = np.stack(
        [ref.vector_field(ref.SCALAR, tk, tuple(yk.tolist())) for tk, yk in zip(t64, inputs)]
    )
    scale = np.max(np.abs(expected), axis=1, keepdims=True)
    # How much of the law these states exercise: saturation, and both exponents of the law.
    xp = ref.array_namespace(np, np.float64)
    y = tuple(inputs.T)
    _, _, _, wd, wd_dot = ref.time_terms(xp, t64)
    u_cmd, s = ref.tracking_control(xp, t64, y, wd, wd_dot)
    return {
        "states": n,
        "max_rel_diff": float(np.max(np.abs(got - expected) / scale)),
        "states_with_saturated_axis": int(np.sum(np.max(np.abs(u_cmd), axis=0) > ref.LIMIT)),
        "axes_with_abs_s_at_least_1": int(np.sum(np.abs(s) >= 1)),
        "axes_with_abs_s_below_1": int(np.sum(np.abs(s) < 1)),
    }


def initial_states(seed: int, n: int, dtype) -> tuple[np.ndarray, np.ndarray]:
    """`chen2022_tuning.initial_states(jr.key(seed), n)` as NumPy arrays of `dtype`."""
    x0 = chen2022_tuning.initial_states(jr.key(seed), n)
    return np.asarray(x0.q, dtype=dtype), np.asarray(x0.omega, dtype=dtype)


def make_jaxatt(
    call: str, horizon: float, dt: float, save_every: int, batch_size: int | None = None
):
    """A jitted `run(loop, x0s) -> (final, successful, result)` through jaxatt (JAXATT_CALLS).

    `final`: the closed-loop states at `horizon`, shape (n, 11) (columns
    `_reference.STATE_NAMES`); `successful`: (n,) booleans; `result`: the
    `MonteCarloResult` (default metrics, status, kept trajectories). `batch_size`: passed to
    `monte_carlo` (`lax.map` over chunks of that many samples; None, the default, runs the
    whole batch at once).
    """
    if call not in JAXATT_CALLS:
        raise ValueError(f"unknown jaxatt call {call!r}; one of {sorted(JAXATT_CALLS)}")
    if call == "monte_carlo_default":

        def run_default(loop, x0s):
            out = monte_carlo(loop, x0s, 0.0, horizon, dt=dt, batch_size=batch_size)
            return None, out.successful, out

        return UserProgram(run_default, batch_size=batch_size)
    performance = Performance(scalarize=False) if call == "monte_carlo_plain" else None

    def final_state(states: ClosedLoopState) -> jax.Array:
        return jnp.concatenate(
            [states.plant.q[:, -1], states.plant.omega[:, -1], states.reference[:, -1]], axis=-1
        )

    def run(loop, x0s):
        out = monte_carlo(
            loop,
            x0s,
            0.0,
            horizon,
            dt=dt,
            save_every=save_every,
            keep_trajectories=True,
            batch_size=batch_size,
            performance=performance,
        )
        return final_state(out.trajectories.states), out.successful, out

    return UserProgram(run, performance, batch_size)


def run_time(f, repeat: int) -> float:
    return min(timeit.repeat(f, number=1, repeat=repeat))


def time_jax(f, args, repeat: int, max_seconds: float):
    """Compile time, run time, output and number of timed repeats of a jitted `f`.

    Compile time is ahead-of-time `f.lower(*args).compile()` (trace, lower, XLA compile), no
    run. Then one warm-up call, then `min(timeit.repeat(..., number=1, repeat=n))` with
    n = `repeat`, reduced so that the repeats take about `max_seconds`; when the warm-up alone
    takes longer than `max_seconds`, n = 0 and the warm-up call is the measurement.
    """
    start = time.perf_counter()
    compiled = f.lower(*args).compile()
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    out = jax.block_until_ready(compiled(*args))
    warm = time.perf_counter() - start
    n = min(repeat, int(max_seconds // warm))
    run = run_time(lambda: jax.block_until_ready(compiled(*args)), n) if n else warm
    return compile_s, run, out, n


def numpy_steps(batch: int, n_steps: int, state_steps_cap: float, max_steps: int) -> int:
    """RK4 steps the NumPy run takes at `batch` (at least 10; its time is scaled to n_steps)."""
    return int(min(n_steps, max_steps, max(10, state_steps_cap // batch)))


def time_numpy(q, omega, n_steps, dt, dtype, *, measured_steps, repeat) -> dict:
    ref.numpy_rk4(q[:1], omega[:1], 2, dt, dtype=dtype)  # warm-up (first-call overheads)
    measured = run_time(lambda: ref.numpy_rk4(q, omega, measured_steps, dt, dtype=dtype), repeat)
    batch = q.shape[0]
    return {
        "compile_s": 0.0,
        "run_s": measured * n_steps / measured_steps,
        "measured_steps": measured_steps,
        "measured_run_s": measured,
        "scaled": measured_steps < n_steps,
        "state_steps_per_s": batch * measured_steps / measured,
    }


def max_abs_diff(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a, np.float64) - np.asarray(b, np.float64))))


def measure_batch(
    loop,
    jaxatt_run,
    q,
    omega,
    *,
    n_steps,
    dt,
    dtype,
    scan,
    numpy_cap,
    numpy_max_steps,
    repeat,
    baseline_repeat,
    max_seconds,
) -> tuple[dict, dict]:
    """One table row (jaxatt, hand scan, NumPy) and the final states for the checks."""
    batch = q.shape[0]
    row = {"batch": batch, "rk4_steps": n_steps, "state_steps": batch * n_steps}
    x0s = QuaternionState(jnp.asarray(q), jnp.asarray(omega))
    compile_s, run_s, out, n = time_jax(jaxatt_run, (loop, x0s), repeat, max_seconds)
    if out[0] is None:  # the default call keeps no trajectory: final states from another call
        check = make_jaxatt("monte_carlo", n_steps * dt, dt, n_steps)
        out = (check(loop, x0s)[0], out[1], out[2])
    final = {"jaxatt": np.asarray(out[0])}
    if final["jaxatt"].dtype != dtype:
        raise RuntimeError(f"jaxatt ran in {final['jaxatt'].dtype}, expected {dtype}")
    row["jaxatt"] = {
        "compile_s": compile_s,
        "run_s": run_s,
        "state_steps_per_s": batch * n_steps / run_s,
        "failed_samples": int(np.sum(~np.asarray(out[1]))),
        "timed_repeats": n,
    }
    if out[2] is not None:  # a few of monte_carlo's default metrics, as a sanity check
        settle = np.asarray(out[2].metrics["settling_time"])
        row["jaxatt"]["settled_fraction_1e-2"] = float(np.mean(np.isfinite(settle)))
        row["jaxatt"]["max_peak_torque"] = float(np.max(out[2].metrics["peak_torque"]))

    if scan:
        scan_run = ref.make_hand_scan(n_steps, dt, dtype)
        compile_s, run_s, out, n = time_jax(scan_run, (x0s.q, x0s.omega), repeat, max_seconds)
        final["scan"] = np.asarray(out)
        row["scan"] = {
            "compile_s": compile_s,
            "run_s": run_s,
            "state_steps_per_s": batch * n_steps / run_s,
            "timed_repeats": n,
        }

    steps = numpy_steps(batch, n_steps, numpy_cap, numpy_max_steps)
    row["numpy"] = time_numpy(
        q, omega, n_steps, dt, dtype, measured_steps=steps, repeat=baseline_repeat
    )
    rate = row["jaxatt"]["state_steps_per_s"]
    row["ratio_jaxatt_numpy"] = rate / row["numpy"]["state_steps_per_s"]
    if scan:
        row["ratio_jaxatt_scan"] = rate / row["scan"]["state_steps_per_s"]
    return row, final


def quick_table(
    batches=(1, 100, 1000),
    horizon: float = 1.0,
    *,
    dt: float = 1e-3,
    repeat: int = 3,
    max_seconds: float = 5.0,
    numpy_state_steps: float = 2e5,
    jaxatt_call: str = "monte_carlo_default",
    seed: int = 0,
) -> list[dict]:
    """A short version of the benchmark: jaxatt, hand scan and NumPy, no SciPy or Basilisk.

    Runs in the precision the caller has chosen (float64 when `jax_enable_x64` is on, else
    float32). Each returned row is a dict with `batch`, `dtype`, `rk4_steps`, `state_steps`,
    per implementation (`jaxatt`, `scan`, `numpy`) `compile_s`, `run_s`, `state_steps_per_s`,
    the ratios `ratio_jaxatt_scan` and `ratio_jaxatt_numpy`, and the checks
    `max_abs_diff_scan` (whole batch), `max_abs_diff_numpy` (on the samples NumPy ran the full
    horizon for, at most 4), `tolerance` and `passed`. NumPy runs at most `numpy_state_steps`
    state-steps (at least 10 steps) and is scaled (`numpy.scaled`).
    """
    dtype = np.dtype(jnp.result_type(float))
    n_steps = round(horizon / dt)
    tol = _tolerances(dtype)["rk4"]
    loop = chen.build("M1")
    check_scenario(loop)
    q, omega = initial_states(seed, max(batches), dtype)
    jaxatt_run = make_jaxatt(jaxatt_call, horizon, dt, default_save_every(n_steps))
    rows = []
    for batch in batches:
        row, final = measure_batch(
            loop,
            jaxatt_run,
            q[:batch],
            omega[:batch],
            n_steps=n_steps,
            dt=dt,
            dtype=dtype,
            scan=True,
            numpy_cap=numpy_state_steps,
            numpy_max_steps=n_steps,
            repeat=repeat,
            baseline_repeat=1,
            max_seconds=max_seconds,
        )
        k = min(4, batch)
        numpy_final = ref.numpy_rk4(q[:k], omega[:k], n_steps, dt, dtype=dtype)
        row["dtype"] = dtype.name
        row["jaxatt_call"] = jaxatt_call
        row["max_abs_diff_scan"] = max_abs_diff(final["scan"], final["jaxatt"])
        row["max_abs_diff_numpy"] = max_abs_diff(numpy_final, final["jaxatt"][:k])
        row["tolerance"] = tol
        row["passed"] = max(row["max_abs_diff_scan"], row["max_abs_diff_numpy"]) <= tol
        rows.append(row)
    return rows


def format_table(rows: list[dict]) -> str:
    """The rows of `quick_table` as a plain-text table (rates in state-steps per second)."""
    header = (
        f"{'batch':>6} | {'jaxatt compile s':>16} | {'jaxatt st-st/s':>14} | "
        f"{'scan st-st/s':>12} | {'jaxatt/scan':>11} | {'NumPy st-st/s':>13} | "
        f"{'jaxatt/NumPy':>12} | {'max |diff|':>10}"
    )
    lines = [header, "-" * len(header)]
    for row in rows:
        lines.append(
            f"{row['batch']:>6} | {row['jaxatt']['compile_s']:>16.2f} | "
            f"{row['jaxatt']['state_steps_per_s']:>14.3g} | "
            f"{row['scan']['state_steps_per_s']:>12.3g} | {row['ratio_jaxatt_scan']:>11.2f} | "
            f"{row['numpy']['state_steps_per_s']:>12.3g}{'*' if row['numpy']['scaled'] else ' '}"
            f" | {row['ratio_jaxatt_numpy']:>12.2f} | "
            f"{max(row['max_abs_diff_scan'], row['max_abs_diff_numpy']):>10.2g}"
        )
    return "\n".join(lines)
