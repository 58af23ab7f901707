"""Monte Carlo throughput of Chen 2022's controller M1: jaxatt against a hand scan, NumPy, SciPy.

The closed loop is `jaxatt.scenarios.chen2022_two_phase_power.build("M1")`: the Xia et al.
(2011) spacecraft (quaternion attitude, inertia J0 + diag(sin .1t, 2 sin .2t, 3 sin .3t)
[kg m^2], disturbance [0.1 sin .1t, 0.2 sin .2t, 0.3 sin .3t] [N m]) tracking a reference q_d
integrated from omega_d(t) = 0.05 [sin .01 pi t, sin .02 pi t, sin .03 pi t] rad/s inside the
state; sliding surface s = e_omega + 5 e_v, two-phase power reaching law (rho = eta = 1.2,
p1/q1 = 31/11, q2/p2 = 5/9), norm robust term (sigma = 0.35, eps = 0.01), equivalent control
with J0, 30 N m per-axis saturation; classic RK4, dt = 1e-3 s, 30 s horizon (`--horizon`).
Initial states: `jaxatt.scenarios.chen2022_tuning.initial_states` (attitudes within 60 deg of
q_d(0), rates uniform in [-0.05, 0.05]^3 rad/s).

Throughput is measured in *state-steps per second*: batch size x number of RK4 steps (four
vector-field evaluations each) divided by the wall time of one run. Compile time (ahead-of-time
trace, lower and XLA compile, no run) is reported separately from run time (one warm-up call,
then `min(timeit.repeat(lambda: jax.block_until_ready(f(x)), number=1, repeat=R))`, fewer
repeats when they would take over `--max-seconds`).

Implementations timed in the same run (the baselines are written from the equations in
`benchmarks/_reference.py`, not with jaxatt code):

- jaxatt (`--jaxatt-call monte_carlo_default`, default): `eqx.filter_jit` of
  `jaxatt.montecarlo.monte_carlo(loop, x0s, 0, T, dt=dt)`, every option at its default (default
  metrics reduced on the fly at every step, nothing saved; the final states for the checks come
  from a separate untimed call), the closed loop an argument; `--jaxatt-call monte_carlo`: the
  earlier configuration, `monte_carlo(..., save_every=steps/10, keep_trajectories=True)`;
  `--jaxatt-call monte_carlo_plain`: that with
  `performance=jaxatt.simulation.Performance(scalarize=False)`.
- hand scan (`--no-scan` skips it): the reference component code under `jax.numpy` in one
  jitted `lax.scan`, batch axis innermost, everything elementwise: the floor of what XLA can do
  with this vector field (DESIGN.md, performance notes).
- NumPy: the same component code on NumPy arrays of shape (batch,), RK4 over the batch. Large
  batches (and long horizons) run fewer steps and their time is scaled (marked `*`).
- SciPy: `solve_ivp` (RK45, rtol 1e-8, atol 1e-10, float64) on single trajectories, the
  right-hand side the same component code on Python floats; per-trajectory time x batch
  (marked `+`), rate in dt-step equivalents (horizon / dt per trajectory).
- Basilisk (optional): `benchmarks/_basilisk_baseline.py`'s
  `basilisk_steps_per_second(n_steps, dt)`, when that file exists and `import Basilisk` works
  (or in a subprocess of `--basilisk-python`, a venv that has Basilisk); otherwise the column
  is skipped and the output says why. It times Basilisk's own single-spacecraft loop (not M1):
  a cost-per-step comparison, extrapolated to the batch (marked `+`), with no correctness check.

Correctness is checked in the same run and the script exits 1 if a check fails: the jaxatt
vector field against the reference one at random states, the hand scan on the whole largest
batch and NumPy on a few samples against jaxatt's final states (1e-9 in float64, 1e-4 in
float32), SciPy on its samples (1e-6; 1e-3 for float32 jaxatt).

Usage (from the repository root):

    python benchmarks/bench_montecarlo.py                   # -> results/montecarlo.json
    python benchmarks/bench_montecarlo.py --dtype float32   # -> results/montecarlo_float32.json

`_quick.quick_table()` runs a short version (jaxatt, hand scan, NumPy) and returns the rows;
`bench_quick.py` prints it.
"""

import argparse
import datetime
import importlib
import json
import os
import pathlib
import platform
import subprocess
import sys
import time
import timeit

import _reference as ref
import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from _quick import (  # the measuring core, shared with `bench_quick.py`
    JAXATT_CALLS,
    _tolerances,
    check_scenario,
    check_vector_field,
    default_save_every,
    initial_states,
    make_jaxatt,
    max_abs_diff,
    measure_batch,
)

import jaxatt
from jaxatt.scenarios import chen2022_two_phase_power as chen


# Arrays are created only inside functions, after `main` (or the caller of `quick_table`) has
# chosen the precision.


HERE = pathlib.Path(__file__).resolve().parent


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[1, 100, 1000, 10000])
    p.add_argument("--horizon", type=float, default=30.0, help="simulated time [s]")
    p.add_argument("--dt", type=float, default=1e-3, help="RK4 step [s]")
    p.add_argument("--dtype", choices=["float64", "float32"], default="float64")
    p.add_argument("--jaxatt-call", choices=sorted(JAXATT_CALLS), default="monte_carlo_default")
    p.add_argument(
        "--save-every",
        type=int,
        default=None,
        help="jaxatt saves every this many steps; default: the largest divisor of the step "
        "count not above steps/10 (11 saves)",
    )
    p.add_argument("--repeat", type=int, default=3, help="timeit repeats for JAX runs")
    p.add_argument(
        "--max-seconds",
        type=float,
        default=20.0,
        help="time budget for the repeats of one measurement (long runs repeat less)",
    )
    p.add_argument(
        "--baseline-repeat", type=int, default=1, help="timeit repeats for NumPy runs (slow)"
    )
    p.add_argument(
        "--numpy-state-steps",
        type=float,
        default=1e7,
        help="cap on batch x steps per NumPy run; beyond it a shorter horizon runs, scaled",
    )
    p.add_argument(
        "--numpy-max-steps",
        type=int,
        default=5000,
        help="cap on the RK4 steps of one NumPy run (small batches are interpreter-bound)",
    )
    p.add_argument(
        "--scipy-samples", type=int, default=3, help="single trajectories SciPy integrates"
    )
    p.add_argument("--check-samples", type=int, default=4, help="samples in the NumPy check")
    p.add_argument("--no-scan", action="store_true", help="skip the hand-written lax.scan")
    p.add_argument("--no-basilisk", action="store_true", help="skip the Basilisk hook")
    p.add_argument(
        "--basilisk-python",
        default=None,
        help="interpreter of a venv with Basilisk (bsk); the hook runs there in a subprocess. "
        "Default: import it here, if `import Basilisk` works",
    )
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--out",
        default=None,
        help="JSON file; default benchmarks/results/montecarlo.json (float64) or "
        "benchmarks/results/montecarlo_float32.json (float32)",
    )
    args = p.parse_args(argv)
    ratio = args.horizon / args.dt
    if args.dt <= 0 or args.horizon <= 0 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        p.error("--horizon must be a positive whole multiple of --dt")
    if min(args.batches) < 1 or max(args.batches) > 1_000_000:
        p.error("--batches must lie in [1, 1000000]")
    if args.repeat < 1 or args.baseline_repeat < 1 or args.numpy_max_steps < 1:
        p.error("repeats and step caps must be positive")
    if args.save_every is not None and (args.save_every < 1 or round(ratio) % args.save_every != 0):
        p.error("--save-every must be a positive divisor of horizon / dt")
    if args.out is None:
        suffix = "" if args.dtype == "float64" else "_float32"
        args.out = str(HERE / "results" / f"montecarlo{suffix}.json")
    return args


# ---------------------------------------------------------------------------------------------
# The implementations.


def time_scipy(q, omega, horizon, samples, repeat, max_seconds) -> dict:
    """SciPy per-trajectory times (min over repeats that fit `max_seconds`), final states."""
    ref.scipy_trajectory(q[0], omega[0], min(0.1, horizon))  # warm-up, not timed
    trajectories, finals = [], []
    for k in range(samples):
        start = time.perf_counter()
        y1, stats = ref.scipy_trajectory(q[k], omega[k], horizon)
        first = time.perf_counter() - start
        extra = min(repeat - 1, int(max_seconds // first))
        times = [first]
        if extra:
            times += timeit.repeat(
                lambda k=k: ref.scipy_trajectory(q[k], omega[k], horizon), number=1, repeat=extra
            )
        trajectories.append({"wall_s": min(times), "timed_runs": len(times), **stats})
        finals.append(y1)
    return {"trajectories": trajectories, "final": np.stack(finals)}


BASILISK_SUBPROCESS = """
import json, sys
sys.path.insert(0, sys.argv[1])
from _basilisk_baseline import basilisk_steps_per_second
print(json.dumps(basilisk_steps_per_second(int(sys.argv[2]), float(sys.argv[3]))))
"""


def load_basilisk_hook(python: str | None = None):
    """`(hook, None)`, or `(None, reason)` when the Basilisk column is skipped.

    The hook is `basilisk_steps_per_second(n_steps, dt) -> dict | None` from
    `benchmarks/_basilisk_baseline.py` (written separately), which simulates one spacecraft
    for `n_steps` steps of `dt` [s] and returns a dict with `steps_per_second` (integrator
    steps of that one spacecraft per wall-clock second; `steps_per_s` is accepted too) and
    whatever else it measured (stored in the JSON), or None without Basilisk.

    With `python=None` the file is imported here, if `import Basilisk` works in this
    interpreter. Basilisk's package (`bsk`) pins versions that conflict with the project venv,
    so `python` may name the interpreter of another venv that has it: the hook then runs in a
    subprocess of that interpreter (the file imports only the standard library, NumPy and
    Basilisk) and its dict comes back as JSON.
    """
    path = HERE / "_basilisk_baseline.py"
    if not path.exists():
        return None, "benchmarks/_basilisk_baseline.py not found"
    if python is not None:

        def hook(n_steps, dt):
            done = subprocess.run(
                [python, "-c", BASILISK_SUBPROCESS, str(HERE), str(n_steps), repr(dt)],
                capture_output=True,
                text=True,
                check=True,
            )
            return json.loads(done.stdout.strip().splitlines()[-1])

        return hook, None
    try:
        importlib.import_module("Basilisk")
    except ImportError as error:
        return None, f"import Basilisk failed in this interpreter ({error}; see --basilisk-python)"
    name = f"{__package__}._basilisk_baseline" if __package__ else "_basilisk_baseline"
    try:
        return importlib.import_module(name).basilisk_steps_per_second, None
    except Exception as error:  # a broken optional file must not stop the benchmark
        return None, f"benchmarks/_basilisk_baseline.py failed to load ({error!r})"


def run_basilisk(hook, n_steps, dt) -> tuple[dict | None, str | None]:
    """Call the hook; `(dict with steps_per_s, None)` or `(None, why the column is skipped)`."""
    try:
        out = hook(n_steps, dt)
    except subprocess.CalledProcessError as error:
        return None, f"the Basilisk subprocess failed: {error.stderr.strip()[-500:]}"
    except Exception as error:
        return None, f"basilisk_steps_per_second raised {error!r}"
    if out is None:
        return None, "basilisk_steps_per_second returned None (Basilisk not importable there)"
    rate = out.get("steps_per_second", out.get("steps_per_s")) if isinstance(out, dict) else None
    if not rate:
        return None, f"basilisk_steps_per_second returned {out!r} (no steps_per_second)"
    return {**out, "steps_per_s": float(rate)}, None


# ---------------------------------------------------------------------------------------------
# Measurements.


# ---------------------------------------------------------------------------------------------
# The script.


def fmt(x, spec=".3g") -> str:
    return "-" if x is None else format(x, spec)


def machine_meta() -> dict:
    import jaxlib
    import scipy

    cpu_model = "unknown"
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu_model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "devices": [str(d) for d in jax.devices()],
        "device_kind": jax.devices()[0].device_kind,
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "cpu_count": os.cpu_count(),
        "cpu_model": cpu_model,
        "versions": {
            "jax": jax.__version__,
            "jaxlib": jaxlib.__version__,
            "equinox": eqx.__version__,
            "jaxatt": jaxatt.__version__,
            "numpy": np.__version__,
            "scipy": scipy.__version__,
        },
        "EQX_ON_ERROR": os.environ.get("EQX_ON_ERROR"),
        "load_average_start": os.getloadavg(),
    }


def print_table(rows, args, meta, columns) -> None:
    header = [("batch", 6)]
    header += [("jaxatt compile s", 16), ("jaxatt run s", 12), ("jaxatt st-st/s", 14)]
    if "scan" in columns:
        header += [("scan compile s", 14), ("scan st-st/s", 12), ("jaxatt/scan", 11)]
    header += [("NumPy run s", 11), ("NumPy st-st/s", 13), ("jaxatt/NumPy", 12)]
    if "scipy" in columns:
        header += [("SciPy run s", 11), ("SciPy st-st/s", 13), ("jaxatt/SciPy", 12)]
    if "basilisk" in columns:
        header += [("Basilisk st-st/s", 16), ("jaxatt/Basilisk", 15)]
    line = " | ".join(f"{name:>{width}}" for name, width in header)
    print()
    print(
        f"Measured on {meta['device_kind']} ({meta['cpu_model']}, {meta['cpu_count']} CPUs), "
        f"{args.dtype}, {meta['date']}"
    )
    print(line)
    print("-" * len(line))
    for row in rows:
        ja, nu = row["jaxatt"], row["numpy"]
        cells = [
            f"{row['batch']:>6}",
            f"{ja['compile_s']:>16.2f}",
            f"{ja['run_s']:>12.4g}",
            f"{fmt(ja['state_steps_per_s']):>14}",
        ]
        if "scan" in columns:
            cells += [
                f"{row['scan']['compile_s']:>14.2f}",
                f"{fmt(row['scan']['state_steps_per_s']):>12}",
                f"{fmt(row['ratio_jaxatt_scan']):>11}",
            ]
        cells += [
            f"{nu['run_s']:>10.4g}{'*' if nu['scaled'] else ' '}",
            f"{fmt(nu['state_steps_per_s']):>13}",
            f"{fmt(row['ratio_jaxatt_numpy']):>12}",
        ]
        if "scipy" in columns:
            sp = row["scipy"]
            cells += [
                f"{sp['run_s']:>10.4g}+",
                f"{fmt(sp['state_steps_per_s']):>13}",
                f"{fmt(row['ratio_jaxatt_scipy']):>12}",
            ]
        if "basilisk" in columns:
            cells += [
                f"{fmt(row['basilisk']['state_steps_per_s']):>15}+",
                f"{fmt(row['ratio_jaxatt_basilisk']):>15}",
            ]
        print(" | ".join(cells))


def main(args) -> int:
    if args.dtype == "float64":
        jax.config.update("jax_enable_x64", True)
    dtype = np.dtype(args.dtype)
    n_steps = round(args.horizon / args.dt)
    save_every = args.save_every or default_save_every(n_steps)
    tol = _tolerances(dtype)
    meta = machine_meta()
    print("devices:", meta["devices"], "| kind:", meta["device_kind"])
    print(f"CPU: {meta['cpu_model']}, os.cpu_count() = {meta['cpu_count']}")
    print("versions:", ", ".join(f"{k} {v}" for k, v in meta["versions"].items()))
    print(
        f"scenario chen2022_two_phase_power M1: horizon {args.horizon} s, dt {args.dt} s, "
        f"{n_steps} RK4 steps, dtype {args.dtype}; state-steps = batch x RK4 steps"
    )
    print(
        f"jaxatt call ({args.jaxatt_call}): {JAXATT_CALLS[args.jaxatt_call]}, "
        f"save_every = {save_every}"
    )

    loop = chen.build("M1")
    check_scenario(loop)
    big = max(args.batches)
    pool_q, pool_w = initial_states(args.seed, max(big, args.scipy_samples, 64), dtype)
    correctness: dict = {"tolerances": tol}
    vf = check_vector_field(
        loop, jnp.asarray(pool_q[:64]), jnp.asarray(pool_w[:64]), jr.key(args.seed + 1), dtype
    )
    correctness["vector_field"] = vf
    print(
        f"check: jaxatt vs reference vector field at {vf['states']} random states "
        f"({vf['states_with_saturated_axis']} with a saturated axis, "
        f"{vf['axes_with_abs_s_at_least_1']} axes with |s_i| >= 1, "
        f"{vf['axes_with_abs_s_below_1']} below): max relative difference "
        f"{vf['max_rel_diff']:.3g} (tolerance {tol['vector_field']:g})",
        flush=True,
    )

    # Baselines that do not depend on the batch: SciPy and Basilisk per trajectory.
    n_sp = min(args.scipy_samples, len(pool_q))
    scipy_out = None
    if n_sp:
        scipy_out = time_scipy(pool_q, pool_w, args.horizon, n_sp, args.repeat, args.max_seconds)
        sp_traj = scipy_out["trajectories"]
        scipy_per_traj = float(np.mean([t["wall_s"] for t in sp_traj]))
        print(
            f"SciPy RK45: {scipy_per_traj:.3g} s per trajectory (mean of {n_sp}), "
            f"{np.mean([t['steps'] for t in sp_traj]):.0f} adaptive steps and "
            f"{np.mean([t['nfev'] for t in sp_traj]):.0f} evaluations per trajectory "
            f"(RK4: {n_steps} steps, {4 * n_steps} evaluations)",
            flush=True,
        )
    basilisk, basilisk_note = None, "skipped (--no-basilisk)"
    if not args.no_basilisk:
        hook, basilisk_note = load_basilisk_hook(args.basilisk_python)
        if hook is not None:
            basilisk, basilisk_note = run_basilisk(hook, n_steps, args.dt)
    if basilisk is None:
        print(f"Basilisk: column skipped, {basilisk_note}")
    else:
        print(
            f"Basilisk: {basilisk['steps_per_s']:.3g} steps/s for one spacecraft; "
            f"{basilisk.get('description', '(no description)')}"
        )

    jaxatt_run = make_jaxatt(args.jaxatt_call, args.horizon, args.dt, save_every)
    rows, finals = [], {}
    for batch in args.batches:
        row, final = measure_batch(
            loop,
            jaxatt_run,
            pool_q[:batch],
            pool_w[:batch],
            n_steps=n_steps,
            dt=args.dt,
            dtype=dtype,
            scan=not args.no_scan,
            numpy_cap=args.numpy_state_steps,
            numpy_max_steps=args.numpy_max_steps,
            repeat=args.repeat,
            baseline_repeat=args.baseline_repeat,
            max_seconds=args.max_seconds,
        )
        finals[batch] = final
        rate = row["jaxatt"]["state_steps_per_s"]
        if scipy_out is not None:
            row["scipy"] = {
                "compile_s": 0.0,
                "run_s": batch * scipy_per_traj,
                "extrapolated_from_trajectories": n_sp,
                "state_steps_per_s": n_steps / scipy_per_traj,
            }
            row["ratio_jaxatt_scipy"] = rate / row["scipy"]["state_steps_per_s"]
        if basilisk is not None:
            row["basilisk"] = {
                "run_s": batch * n_steps / basilisk["steps_per_s"],
                "extrapolated_from_trajectories": 1,
                "state_steps_per_s": basilisk["steps_per_s"],
            }
            row["ratio_jaxatt_basilisk"] = rate / basilisk["steps_per_s"]
        rows.append(row)
        print(
            f"  batch {batch:>6}: jaxatt {fmt(rate)} state-steps/s"
            + (f", scan {fmt(row['scan']['state_steps_per_s'])}" if "scan" in row else "")
            + f", NumPy {fmt(row['numpy']['state_steps_per_s'])}"
            + (
                f" ({row['numpy']['measured_steps']} steps, scaled)"
                if row["numpy"]["scaled"]
                else ""
            ),
            flush=True,
        )

    # Correctness against jaxatt's final states of the largest batch.
    js = finals[big]["jaxatt"]
    k = min(args.check_samples, big)
    numpy_final = ref.numpy_rk4(pool_q[:k], pool_w[:k], n_steps, args.dt, dtype=dtype)
    correctness["numpy"] = {
        "samples": k,
        "max_abs_diff": max_abs_diff(numpy_final, js[:k]),
        "tolerance": tol["rk4"],
    }
    if not args.no_scan:
        correctness["scan"] = {
            "samples": big,
            "max_abs_diff": max_abs_diff(finals[big]["scan"], js),
            "tolerance": tol["rk4"],
        }
    if scipy_out is not None:
        compared = min(n_sp, big)
        correctness["scipy"] = {
            "samples": compared,
            "max_abs_diff": max_abs_diff(scipy_out["final"][:compared], js[:compared]),
            "tolerance": tol["scipy"],
        }
    failed_samples = sum(row["jaxatt"]["failed_samples"] for row in rows)
    checks = [c for c in ("numpy", "scan", "scipy") if c in correctness]
    ok = (
        vf["max_rel_diff"] <= tol["vector_field"]
        and all(correctness[c]["max_abs_diff"] <= correctness[c]["tolerance"] for c in checks)
        and failed_samples == 0
    )
    correctness["jaxatt_failed_samples"] = failed_samples
    correctness["passed"] = ok

    columns = {"scan"} if not args.no_scan else set()
    columns |= {"scipy"} if scipy_out is not None else set()
    columns |= {"basilisk"} if basilisk is not None else set()
    print_table(rows, args, meta, columns)
    notes = [
        "state-steps = batch x number of classic RK4 steps (4 vector-field evaluations each)",
        f"jaxatt: {JAXATT_CALLS[args.jaxatt_call]}, save_every = {save_every}",
        "compile s = ahead-of-time trace + lower + XLA compile (no run); run s = min over up "
        f"to {args.repeat} timeit repeats after a warm-up call, fewer when they would take "
        f"over {args.max_seconds:g} s ('timed_repeats' in the JSON; 0 = the warm-up call is "
        "the measurement)",
        "scan: the reference component code (benchmarks/_reference.py, not jaxatt code) "
        "under jax.numpy in one jitted lax.scan",
        f"NumPy: the same component code on (batch,) arrays, min over {args.baseline_repeat} "
        f"repeat(s); * = ran fewer steps (at most {args.numpy_state_steps:.0e} state-steps and "
        f"{args.numpy_max_steps} steps) and run s is scaled linearly to the full horizon",
    ]
    if scipy_out is not None:
        notes.append(
            f"SciPy: + = per-trajectory wall time (mean over {n_sp} trajectories of the min of "
            f"up to {args.repeat} runs; RK45, rtol 1e-8, atol 1e-10, float64, the component "
            "code on Python floats) x batch; its rate counts dt-step equivalents (horizon/dt "
            "per trajectory), while RK45 takes other, adaptive steps"
        )
    if basilisk is not None:
        notes.append(
            "Basilisk: + = its own single-spacecraft loop (see 'basilisk.description' in the "
            "JSON; not M1, so no correctness check), batch x n_steps / steps_per_second "
            "(extrapolated, one process per spacecraft)"
        )
    else:
        notes.append(f"Basilisk column skipped: {basilisk_note}")
    for note in notes:
        print("  " + note)
    print()
    for name in checks:
        c = correctness[name]
        print(
            f"check: max |{name} - jaxatt| over the final states of {c['samples']} samples at "
            f"t = {args.horizon} s: {c['max_abs_diff']:.3g} (tolerance {c['tolerance']:g})"
        )
    print(f"check: jaxatt samples not successful: {failed_samples}")
    print("check:", "PASSED" if ok else "FAILED")

    meta["load_average_end"] = os.getloadavg()
    print(
        "load average (1, 5, 15 min) at start "
        + ", ".join(f"{x:.2f}" for x in meta["load_average_start"])
        + ", at end "
        + ", ".join(f"{x:.2f}" for x in meta["load_average_end"])
        + f" ({meta['cpu_count']} CPUs; above that, other processes shared the cores)"
    )
    result = {
        "benchmark": "chen2022 M1 Monte Carlo closed-loop throughput",
        "units": {"rate": "state-steps per second (batch x RK4 steps / run wall time)"},
        "settings": {
            **vars(args),
            "rk4_steps": n_steps,
            "save_every": save_every,
            "jaxatt_call_code": JAXATT_CALLS[args.jaxatt_call],
            "initial_states": "jaxatt.scenarios.chen2022_tuning.initial_states(jr.key(seed), n)",
            "scipy": ref.SCIPY_OPTIONS,
        },
        "meta": meta,
        "scipy_trajectories": scipy_out["trajectories"] if scipy_out else [],
        "basilisk": basilisk if basilisk is not None else {"skipped": basilisk_note},
        "rows": rows,
        "correctness": correctness,
        "notes": notes,
    }
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {out}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(parse_args()))
