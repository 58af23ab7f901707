"""Throughput of a batched closed-loop simulation: jaxatt against NumPy, SciPy and a hand scan.

The scenario is `jaxatt.scenarios.rigid_body_pd`: the Xia et al. (2011) spacecraft (nominal
inertia J0 plus diag(sin .1t, 2 sin .2t, 3 sin .3t) [kg m^2], disturbance
[0.1 sin .1t, 0.2 sin .2t, 0.3 sin .3t] [N m]) with MRP kinematics, shadow switching after each
step, the PD law tau = -k1 sigma - k2 omega (k1 = 60 N m, k2 = 50 N m s) and a 30 N m per-axis
torque limit, started from random attitudes and rates.

Throughput is measured in *state-steps per second*: batch size x number of classic RK4 steps
(four vector-field evaluations each) divided by the wall time of one run. Compile time
(ahead-of-time trace, lower and XLA compile, no run) is reported separately from run time
(`min(timeit.repeat(..., number=1, repeat=R))` after a warm-up call; fewer repeats when they
would take over `--max-seconds`).

Implementations timed in the same run:

- jaxatt `vmap(simulate)`: `eqx.filter_jit(jax.vmap(simulate(..., throw=False,
  save_every=steps/10)))`, the closed loop passed as an argument (changing gains does not
  recompile): what a user who vmaps `simulate` gets (one sample's program, batched).
- jaxatt `monte_carlo`: the batch runner's default call, `monte_carlo(loop, x0s, 0, T,
  dt=dt)` (default metrics reduced on the fly, nothing saved, scalarized on CPU from 1000
  samples), compiled with the XLA options it passes when called eagerly (`_quick.UserProgram`).
  Its final states for the checks come from a separate, untimed call at the largest batch
  (`keep_trajectories=True`, one save at T).
- NumPy: classic RK4 over the whole batch written here from the equations, struct-of-arrays
  (one array of shape (batch,) per state component), explicit adjugate inverse of J(t), clip
  saturation, shadow switch after each step. At large batches it runs a shorter horizon
  (at most `--numpy-state-steps` state-steps) and its rate is scaled; the table says so.
- SciPy: `solve_ivp` (RK45, rtol 1e-8, atol 1e-10) on single trajectories, shadow switching by
  a terminal event and restart. Reported per dt-step equivalent: (horizon / dt) / wall time
  per trajectory, extrapolated linearly to the batch. RK45 takes far fewer, adaptive steps, so
  this is the rate at which SciPy delivers the same simulated time, not a like-for-like count.
- hand scan (optional, `--no-scan`): the NumPy code above run with `jax.numpy` inside one
  jitted `lax.scan`; the floor for what XLA can do with this vector field (DESIGN.md,
  performance notes).

Correctness is checked in the same run: final states of NumPy RK4 and jaxatt agree to ~1e-9
(float64), SciPy to ~1e-6 on the samples that never reach |sigma| = 1 (where SciPy switches
at the crossing and RK4 at the end of the step, an O(dt) difference by construction).

Usage (from the repository root):

    python benchmarks/bench_rigid_body.py
    python benchmarks/bench_rigid_body.py --dtype float32  # -> results/rigid_body_float32.json
"""

import argparse
import math
import sys

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from _common import finish  # load average, JSON, exit code
from _quick import UserProgram, run_time, time_jax  # the shared timing
from bench_montecarlo import machine_meta
from scipy.integrate import solve_ivp

from jaxatt.montecarlo import monte_carlo
from jaxatt.plants import MRPState
from jaxatt.scenarios import rigid_body_pd
from jaxatt.simulation import simulate


# Constants of the scenario, written out independently of jaxatt (checked against the jaxatt
# closed loop at start-up).
J0 = ((20.0, 1.2, 0.9), (1.2, 17.0, 1.4), (0.9, 1.4, 15.0))  # [kg m^2]
DJ_AMPLITUDE = (1.0, 2.0, 3.0)  # diag of Delta J(t) = diag(a_i sin(f_i t)) [kg m^2]
DJ_FREQUENCY = (0.1, 0.2, 0.3)  # [rad/s]
D_AMPLITUDE = (0.1, 0.2, 0.3)  # d_i(t) = a_i sin(f_i t) [N m]
D_FREQUENCY = (0.1, 0.2, 0.3)  # [rad/s]
K1 = 60.0  # [N m]
K2 = 50.0  # [N m s]
LIMIT = 30.0  # [N m]


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batches", type=int, nargs="+", default=[1, 100, 1000, 10000])
    p.add_argument("--horizon", type=float, default=10.0, help="simulated time [s]")
    p.add_argument("--dt", type=float, default=1e-3, help="RK4 step [s]")
    p.add_argument("--dtype", choices=["float64", "float32"], default="float64")
    p.add_argument("--repeat", type=int, default=3, help="timeit repeats for JAX runs")
    p.add_argument(
        "--max-seconds",
        type=float,
        default=20.0,
        help="time budget for the repeats of one JAX measurement (long runs repeat less)",
    )
    p.add_argument(
        "--baseline-repeat", type=int, default=1, help="timeit repeats for NumPy runs (slow)"
    )
    p.add_argument(
        "--scipy-samples", type=int, default=3, help="single trajectories SciPy integrates"
    )
    p.add_argument(
        "--numpy-state-steps",
        type=float,
        default=1e7,
        help="cap on batch x steps per NumPy run; larger batches run a shorter horizon, scaled",
    )
    p.add_argument("--check-samples", type=int, default=4, help="samples in the NumPy check")
    p.add_argument("--no-scan", action="store_true", help="skip the hand-written lax.scan")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--out",
        default=None,
        help="JSON file; default benchmarks/results/rigid_body.json (float64) or "
        "benchmarks/results/rigid_body_float32.json (float32)",
    )
    args = p.parse_args(argv)
    ratio = args.horizon / args.dt
    if args.dt <= 0 or args.horizon <= 0 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        p.error("--horizon must be a positive whole multiple of --dt")
    if min(args.batches) < 1 or args.repeat < 1 or args.baseline_repeat < 1:
        p.error("--batches and repeats must be positive")
    if args.out is None:
        suffix = "" if args.dtype == "float64" else "_float32"
        args.out = f"benchmarks/results/rigid_body{suffix}.json"
    return args


# ---------------------------------------------------------------------------------------------
# The closed loop written out in components (struct of arrays). `sin` acts on the time, `clip`
# on the batch arrays, so the same code runs on NumPy arrays, on JAX arrays and on floats.


def inverse_inertia(t, sin):
    """Entries of J(t)^{-1} = adj(J) / det(J), J(t) = J0 + diag(a_i sin(f_i t))."""
    (a, b, c), (d, e, f), (g, h, i) = J0
    a = a + DJ_AMPLITUDE[0] * sin(DJ_FREQUENCY[0] * t)
    e = e + DJ_AMPLITUDE[1] * sin(DJ_FREQUENCY[1] * t)
    i = i + DJ_AMPLITUDE[2] * sin(DJ_FREQUENCY[2] * t)
    adj = (
        (e * i - f * h, c * h - b * i, b * f - c * e),
        (f * g - d * i, a * i - c * g, c * d - a * f),
        (d * h - e * g, b * g - a * h, a * e - b * d),
    )
    det = a * adj[0][0] + b * adj[1][0] + c * adj[2][0]
    inertia = ((a, b, c), (d, e, f), (g, h, i))
    return inertia, tuple(tuple(x / det for x in row) for row in adj)


def vector_field(t, s, w, sin, clip):
    """(sigma_dot, omega_dot) for MRP `s` and rate `w` (3-tuples of components)."""
    s1, s2, s3 = s
    w1, w2, w3 = w
    # Kinematics: sigma_dot = 1/4 [(1 - s.s) w + 2 s x w + 2 (s.w) s].
    ss = s1 * s1 + s2 * s2 + s3 * s3
    sw = s1 * w1 + s2 * w2 + s3 * w3
    c = 1 - ss
    ds1 = 0.25 * (c * w1 + 2 * (s2 * w3 - s3 * w2) + 2 * sw * s1)
    ds2 = 0.25 * (c * w2 + 2 * (s3 * w1 - s1 * w3) + 2 * sw * s2)
    ds3 = 0.25 * (c * w3 + 2 * (s1 * w2 - s2 * w1) + 2 * sw * s3)
    # PD law with saturation.
    u1 = clip(-K1 * s1 - K2 * w1, LIMIT)
    u2 = clip(-K1 * s2 - K2 * w2, LIMIT)
    u3 = clip(-K1 * s3 - K2 * w3, LIMIT)
    # Euler: J w_dot = -w x (J w) + u + d, J = J(t) (shared by the batch: it depends on t only,
    # exactly as under jax.vmap over initial states).
    (j, jinv) = inverse_inertia(t, sin)
    h1 = j[0][0] * w1 + j[0][1] * w2 + j[0][2] * w3
    h2 = j[1][0] * w1 + j[1][1] * w2 + j[1][2] * w3
    h3 = j[2][0] * w1 + j[2][1] * w2 + j[2][2] * w3
    r1 = -(w2 * h3 - w3 * h2) + u1 + D_AMPLITUDE[0] * sin(D_FREQUENCY[0] * t)
    r2 = -(w3 * h1 - w1 * h3) + u2 + D_AMPLITUDE[1] * sin(D_FREQUENCY[1] * t)
    r3 = -(w1 * h2 - w2 * h1) + u3 + D_AMPLITUDE[2] * sin(D_FREQUENCY[2] * t)
    dw1 = jinv[0][0] * r1 + jinv[0][1] * r2 + jinv[0][2] * r3
    dw2 = jinv[1][0] * r1 + jinv[1][1] * r2 + jinv[1][2] * r3
    dw3 = jinv[2][0] * r1 + jinv[2][1] * r2 + jinv[2][2] * r3
    return (ds1, ds2, ds3), (dw1, dw2, dw3)


def rk4_step(t, dt, s, w, sin, clip, where):
    """One classic RK4 step followed by the MRP shadow switch."""
    half = 0.5 * dt

    def axpy(y, h, k):
        return tuple(yi + h * ki for yi, ki in zip(y, k))

    ks1, kw1 = vector_field(t, s, w, sin, clip)
    ks2, kw2 = vector_field(t + half, axpy(s, half, ks1), axpy(w, half, kw1), sin, clip)
    ks3, kw3 = vector_field(t + half, axpy(s, half, ks2), axpy(w, half, kw2), sin, clip)
    ks4, kw4 = vector_field(t + dt, axpy(s, dt, ks3), axpy(w, dt, kw3), sin, clip)
    s = tuple(
        y + dt * ((a + 2 * b + 2 * c + d) / 6) for y, a, b, c, d in zip(s, ks1, ks2, ks3, ks4)
    )
    w = tuple(
        y + dt * ((a + 2 * b + 2 * c + d) / 6) for y, a, b, c, d in zip(w, kw1, kw2, kw3, kw4)
    )
    ss = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]
    switch = ss > 1
    safe = where(switch, ss, 1)
    return tuple(where(switch, -x / safe, x) for x in s), w, switch


def numpy_clip(x, limit):
    return np.clip(x, -limit, limit)


def numpy_rk4(sigma, omega, n_steps, dt, t0=0.0):
    """NumPy RK4 over a batch. `sigma`, `omega`: (batch, 3). Returns final states, switches."""
    s = tuple(np.ascontiguousarray(sigma[:, i]) for i in range(3))
    w = tuple(np.ascontiguousarray(omega[:, i]) for i in range(3))
    switches = np.zeros(sigma.shape[0], dtype=np.int64)
    for i in range(n_steps):
        # Time-only quantities (J(t), d(t)) in Python floats: exact for float64.
        s, w, switch = rk4_step(t0 + i * dt, dt, s, w, math.sin, numpy_clip, np.where)
        switches += switch
    return np.stack(s, axis=-1), np.stack(w, axis=-1), switches


def make_scan(n_steps, dt, dtype):
    """The same component code under `jax.numpy`, in one `lax.scan` over steps."""

    def clip(x, limit):
        return jnp.clip(x, -limit, limit)

    @jax.jit
    def run(sigma, omega):
        y = tuple(sigma[:, i] for i in range(3)) + tuple(omega[:, i] for i in range(3))

        def body(y, i):
            t = (i * dt).astype(dtype)
            s, w, _ = rk4_step(t, dt, y[:3], y[3:], jnp.sin, clip, jnp.where)
            return s + w, None

        y, _ = jax.lax.scan(body, y, jnp.arange(n_steps))
        return jnp.stack(y[:3], axis=-1), jnp.stack(y[3:], axis=-1)

    return run


def scipy_trajectory(sigma0, omega0, t1):
    """One trajectory with `solve_ivp` RK45; shadow switch by a terminal event and restart."""

    def clip(x, limit):
        return min(limit, max(-limit, x))

    def rhs(t, y):
        ds, dw = vector_field(t, y[:3], y[3:], math.sin, clip)
        return np.array(ds + dw)

    def crossing(t, y):
        return y[0] * y[0] + y[1] * y[1] + y[2] * y[2] - 1.0

    crossing.terminal = True
    crossing.direction = 1.0
    y = np.concatenate([sigma0, omega0]).astype(np.float64)
    t, nfev, nsteps, events = 0.0, 0, 0, 0
    while True:
        sol = solve_ivp(rhs, (t, t1), y, method="RK45", rtol=1e-8, atol=1e-10, events=crossing)
        if sol.status < 0:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        nfev += sol.nfev
        nsteps += len(sol.t) - 1
        y = sol.y[:, -1].copy()
        if sol.status == 1:  # crossed |sigma| = 1: continue from the shadow set
            events += 1
            t = float(sol.t_events[0][-1])
            y = np.concatenate([sol.y_events[0][-1][:3], sol.y_events[0][-1][3:]])
            y[:3] = -y[:3] / np.dot(y[:3], y[:3])
            if t1 - t < 1e-12:
                break
            continue
        break
    return y[:3], y[3:], {"nfev": nfev, "steps": nsteps, "events": events}


# ---------------------------------------------------------------------------------------------
# The scenario check.


def check_scenario(loop):
    """The constants written out above are the ones of the jaxatt scenario."""
    body = loop.plant.body
    checks = [
        (np.asarray(body.inertia), np.asarray(J0)),
        (np.diag(np.asarray(body.inertia_perturbation.amplitude)), DJ_AMPLITUDE),
        (np.diag(np.asarray(body.inertia_perturbation.frequency)), DJ_FREQUENCY),
        (np.asarray(body.disturbance.amplitude), D_AMPLITUDE),
        (np.asarray(body.disturbance.frequency), D_FREQUENCY),
        (np.asarray(loop.controller.k1), K1),
        (np.asarray(loop.controller.k2), K2),
        (np.asarray(loop.actuator.limit), LIMIT),
    ]
    for got, expected in checks:
        if not np.allclose(got, expected, rtol=1e-6, atol=0):
            raise SystemExit(f"scenario constants changed: {got} != {expected}")
    if not loop.plant.shadow_switching:
        raise SystemExit("scenario no longer uses shadow switching")


def fmt_rate(x):
    return "-" if x is None else f"{x:.3g}"


def main(args):
    if args.dtype == "float64":  # before any array exists (DESIGN.md, Numerics)
        jax.config.update("jax_enable_x64", True)
    dtype = np.dtype(args.dtype)
    n_steps = round(args.horizon / args.dt)
    save_every = max(1, n_steps // 10)
    while n_steps % save_every:
        save_every -= 1
    tol_numpy, tol_scipy = (1e-9, 1e-6) if dtype == np.float64 else (1e-4, 1e-3)

    loop = rigid_body_pd.build()
    check_scenario(loop)
    pool = rigid_body_pd.random_initial_states(jr.key(args.seed), max(args.batches))
    pool_sigma = np.asarray(pool.sigma)
    pool_omega = np.asarray(pool.omega)
    assert pool_sigma.dtype == dtype, pool_sigma.dtype

    @eqx.filter_jit
    def jaxatt_batch(loop, x0s):
        def one(x0):
            traj = simulate(
                loop, x0, 0.0, args.horizon, dt=args.dt, save_every=save_every, throw=False
            )
            return traj.states.plant.sigma[-1], traj.states.plant.omega[-1], traj.successful

        return jax.vmap(one)(x0s)

    def default_call(loop, x0s):
        out = monte_carlo(loop, x0s, 0.0, args.horizon, dt=args.dt)
        return out.successful, out.metrics

    def final_states(loop, x0s):  # untimed, for the checks
        out = monte_carlo(
            loop, x0s, 0.0, args.horizon, dt=args.dt, save_every=n_steps, keep_trajectories=True
        )
        plant = out.trajectories.states.plant
        return plant.sigma[:, -1], plant.omega[:, -1]

    monte_carlo_batch, monte_carlo_final = UserProgram(default_call), UserProgram(final_states)

    meta = machine_meta()
    cpu_model = meta["cpu_model"]
    print("devices:", meta["devices"], "| kind:", meta["device_kind"])
    print(f"CPU: {cpu_model}, os.cpu_count() = {meta['cpu_count']}")
    print("versions:", ", ".join(f"{k} {v}" for k, v in meta["versions"].items()))
    print(
        f"scenario rigid_body_pd: horizon {args.horizon} s, dt {args.dt} s, {n_steps} RK4 "
        f"steps, dtype {args.dtype}; state-steps = batch x RK4 steps"
    )

    # SciPy: single trajectories, full horizon, float64 always.
    n_sp = min(args.scipy_samples, len(pool_sigma))
    scipy_times, scipy_final, scipy_stats = [], [], []
    if n_sp:  # warm-up (first-call overheads in SciPy/NumPy), not timed
        scipy_trajectory(pool_sigma[0].astype(np.float64), pool_omega[0].astype(np.float64), 0.1)
    for k in range(n_sp):
        s0 = pool_sigma[k].astype(np.float64)
        w0 = pool_omega[k].astype(np.float64)
        s1, w1, stats = scipy_trajectory(s0, w0, args.horizon)
        # Each trajectory is timed `--repeat` times (it is cheap); the minimum is kept.
        scipy_times.append(
            run_time(lambda s0=s0, w0=w0: scipy_trajectory(s0, w0, args.horizon), args.repeat)
        )
        scipy_final.append((s1, w1))
        scipy_stats.append(stats)
    scipy_per_traj = float(np.mean(scipy_times)) if n_sp else None
    scipy_rate = n_steps / scipy_per_traj if n_sp else None
    if n_sp:
        print(
            f"SciPy RK45: {scipy_per_traj:.3f} s per trajectory (mean of {n_sp}), "
            f"{np.mean([s['steps'] for s in scipy_stats]):.0f} adaptive steps and "
            f"{np.mean([s['nfev'] for s in scipy_stats]):.0f} evaluations per trajectory "
            f"(RK4: {n_steps} steps, {4 * n_steps} evaluations)"
        )

    rows, jaxatt_out = [], {}
    scan_out = {}
    for batch in args.batches:
        x0s = MRPState(jnp.asarray(pool_sigma[:batch]), jnp.asarray(pool_omega[:batch]))
        row = {"batch": batch, "rk4_steps": n_steps, "state_steps": batch * n_steps}

        compile_s, run_s, out, n = time_jax(
            jaxatt_batch, (loop, x0s), args.repeat, args.max_seconds
        )
        failed = int(np.sum(~np.asarray(out[2])))
        jaxatt_out[batch] = (np.asarray(out[0]), np.asarray(out[1]))
        row["jaxatt"] = {
            "compile_s": compile_s,
            "run_s": run_s,
            "state_steps_per_s": batch * n_steps / run_s,
            "failed_samples": failed,
            "timed_repeats": n,
        }
        compile_s, run_s, out, n = time_jax(
            monte_carlo_batch, (loop, x0s), args.repeat, args.max_seconds
        )
        row["monte_carlo"] = {
            "compile_s": compile_s,
            "run_s": run_s,
            "state_steps_per_s": batch * n_steps / run_s,
            "failed_samples": int(np.sum(~np.asarray(out[0]))),
            "timed_repeats": n,
        }
        if batch == max(args.batches):
            monte_carlo_out = tuple(np.asarray(a) for a in monte_carlo_final(loop, x0s))

        if not args.no_scan:
            scan = make_scan(n_steps, args.dt, dtype)
            compile_s, run_s, out, n = time_jax(
                scan, (x0s.sigma, x0s.omega), args.repeat, args.max_seconds
            )
            scan_out[batch] = (np.asarray(out[0]), np.asarray(out[1]))
            row["scan"] = {
                "compile_s": compile_s,
                "run_s": run_s,
                "state_steps_per_s": batch * n_steps / run_s,
                "timed_repeats": n,
            }

        np_steps = int(min(n_steps, max(10, args.numpy_state_steps // batch)))
        s0, w0 = pool_sigma[:batch], pool_omega[:batch]
        np_run = run_time(lambda: numpy_rk4(s0, w0, np_steps, args.dt), args.baseline_repeat)
        row["numpy"] = {
            "compile_s": 0.0,
            "run_s": np_run * n_steps / np_steps,
            "measured_steps": np_steps,
            "measured_run_s": np_run,
            "scaled": np_steps < n_steps,
            "state_steps_per_s": batch * np_steps / np_run,
        }
        if n_sp:
            row["scipy"] = {
                "compile_s": 0.0,
                "run_s": batch * scipy_per_traj,
                "extrapolated_from_trajectories": n_sp,
                "state_steps_per_s": scipy_rate,
            }
        rate = row["jaxatt"]["state_steps_per_s"]
        row["ratio_jaxatt_numpy"] = rate / row["numpy"]["state_steps_per_s"]
        row["ratio_jaxatt_scipy"] = rate / scipy_rate if n_sp else None
        mc_rate = row["monte_carlo"]["state_steps_per_s"]
        row["ratio_monte_carlo_numpy"] = mc_rate / row["numpy"]["state_steps_per_s"]
        row["ratio_monte_carlo_scipy"] = mc_rate / scipy_rate if n_sp else None
        if "scan" in row:
            row["ratio_jaxatt_scan"] = rate / row["scan"]["state_steps_per_s"]
            row["ratio_monte_carlo_scan"] = mc_rate / row["scan"]["state_steps_per_s"]
        rows.append(row)
        print(
            f"  batch {batch:>6}: vmap(simulate) {fmt_rate(rate)}, monte_carlo "
            f"{fmt_rate(mc_rate)} state-steps/s, NumPy "
            f"{fmt_rate(row['numpy']['state_steps_per_s'])}"
            + (f" ({np_steps} steps, scaled)" if np_steps < n_steps else "")
            + (f", scan {fmt_rate(row['scan']['state_steps_per_s'])}" if "scan" in row else ""),
            flush=True,
        )

    # Correctness: NumPy RK4 over the full horizon on a few samples vs jaxatt's rows.
    big = max(args.batches)
    js, jw = jaxatt_out[big]
    k = min(args.check_samples, big)
    ns, nw, switches = numpy_rk4(pool_sigma[:k], pool_omega[:k], n_steps, args.dt)
    err_numpy = float(max(np.max(np.abs(ns - js[:k])), np.max(np.abs(nw - jw[:k]))))
    ms, mw = monte_carlo_out
    err_monte_carlo = float(max(np.max(np.abs(ms - js)), np.max(np.abs(mw - jw))))
    correctness = {
        "reference_batch": big,
        "numpy_samples": k,
        "numpy_shadow_switches": switches.tolist(),
        "max_abs_diff_numpy": err_numpy,
        "tolerance_numpy": tol_numpy,
        "max_abs_diff_monte_carlo_vs_vmap": err_monte_carlo,
    }
    if scan_out:
        ss, sw = scan_out[big]
        correctness["max_abs_diff_scan"] = float(
            max(np.max(np.abs(ss - js)), np.max(np.abs(sw - jw)))
        )
    compared = [i for i in range(n_sp) if scipy_stats[i]["events"] == 0]
    if compared:
        err_scipy = float(
            max(
                max(np.max(np.abs(scipy_final[i][0] - js[i])) for i in compared),
                max(np.max(np.abs(scipy_final[i][1] - jw[i])) for i in compared),
            )
        )
    else:
        err_scipy = None
    correctness.update(
        {
            "scipy_samples_compared": compared,
            "scipy_samples_with_switch_event": [i for i in range(n_sp) if i not in compared],
            "max_abs_diff_scipy": err_scipy,
            "tolerance_scipy": tol_scipy,
        }
    )
    ok = (
        err_numpy <= tol_numpy
        and err_monte_carlo <= tol_numpy
        and (err_scipy is None or err_scipy <= tol_scipy)
        and all(row["monte_carlo"]["failed_samples"] == 0 for row in rows)
    )
    correctness["passed"] = ok

    header = (
        f"{'batch':>6} | {'jaxatt compile s':>16} | {'jaxatt run s':>12} | {'jaxatt st-st/s':>14}"
        f" | {'mc compile s':>12} | {'mc st-st/s':>10}"
        f" | {'NumPy run s':>11} | {'NumPy st-st/s':>13} | {'SciPy run s':>11}"
        f" | {'SciPy st-st/s':>13} | {'jaxatt/NumPy':>12} | {'jaxatt/SciPy':>12}"
        f" | {'mc/NumPy':>8} | {'mc/SciPy':>8}"
    )
    if scan_out:
        header += (
            f" | {'scan compile s':>14} | {'scan st-st/s':>12} | {'jaxatt/scan':>11}"
            f" | {'mc/scan':>7}"
        )
    print()
    print(
        f"Measured on {meta['device_kind']} ({cpu_model}, {meta['cpu_count']} CPUs), "
        f"{args.dtype}, {meta['date']}"
    )
    print(header)
    print("-" * len(header))
    for row in rows:
        ja, nu = row["jaxatt"], row["numpy"]
        sp = row.get("scipy")
        sp_run = f"{sp['run_s']:.4g}" if sp else "-"
        line = (
            f"{row['batch']:>6} | {ja['compile_s']:>16.2f} | {ja['run_s']:>12.4g} | "
            f"{fmt_rate(ja['state_steps_per_s']):>14} | "
            f"{row['monte_carlo']['compile_s']:>12.2f} | "
            f"{fmt_rate(row['monte_carlo']['state_steps_per_s']):>10} | "
            f"{nu['run_s']:>10.4g}{'*' if nu['scaled'] else ' '} | "
            f"{fmt_rate(nu['state_steps_per_s']):>13} | "
            f"{sp_run:>10}+ | "
            f"{fmt_rate(sp['state_steps_per_s'] if sp else None):>13} | "
            f"{row['ratio_jaxatt_numpy']:>12.3g} | {fmt_rate(row['ratio_jaxatt_scipy']):>12} | "
            f"{row['ratio_monte_carlo_numpy']:>8.3g} | "
            f"{fmt_rate(row['ratio_monte_carlo_scipy']):>8}"
        )
        if "scan" in row:
            line += (
                f" | {row['scan']['compile_s']:>14.2f} | "
                f"{fmt_rate(row['scan']['state_steps_per_s']):>12} | "
                f"{row['ratio_jaxatt_scan']:>11.3g} | {row['ratio_monte_carlo_scan']:>7.3g}"
            )
        print(line)
    notes = [
        "state-steps = batch x number of classic RK4 steps (4 vector-field evaluations each)",
        "jaxatt = jax.vmap(simulate) in one filter_jit; mc = monte_carlo's default call "
        "(default metrics streamed, nothing saved, scalarized from 1000 samples)",
        "compile s = ahead-of-time trace + lower + XLA compile (no run); run s = min over up "
        f"to {args.repeat} timeit repeats after a warm-up call, fewer when they would take "
        f"over {args.max_seconds:g} s ('timed_repeats' in the JSON; 0 = the warm-up call is "
        "the measurement)",
        f"NumPy: min over {args.baseline_repeat} repeat(s); * = ran at most "
        f"{args.numpy_state_steps:.0e} state-steps (a shorter horizon) and run s is scaled "
        "linearly to the full horizon",
        f"SciPy: + = per-trajectory wall time (mean over {n_sp} trajectories of the min of "
        f"{args.repeat} timed runs each; RK45, rtol 1e-8, atol 1e-10, "
        "always float64) x batch; its rate counts dt-step equivalents (horizon/dt per "
        "trajectory), while RK45 takes far fewer, adaptive steps",
        "scan: the NumPy component code under jax.numpy in one jitted lax.scan (not jaxatt)",
    ]
    for note in notes:
        print("  " + note)
    print()
    print(
        f"check: max |NumPy - jaxatt| on {k} samples at t = {args.horizon} s: {err_numpy:.3g} "
        f"(tolerance {tol_numpy:g}); shadow switches per sample {switches.tolist()}"
    )
    print(
        f"check: max |monte_carlo - vmap(simulate)| final states on {big} samples: "
        f"{err_monte_carlo:.3g} (tolerance {tol_numpy:g}); monte_carlo's failed samples: "
        f"{sum(row['monte_carlo']['failed_samples'] for row in rows)}"
    )
    if scan_out:
        print(
            f"check: max |scan - jaxatt| on {big} samples: {correctness['max_abs_diff_scan']:.3g}"
        )
    if err_scipy is not None:
        print(
            f"check: max |SciPy - jaxatt| on samples {compared}: {err_scipy:.3g} "
            f"(tolerance {tol_scipy:g})"
        )
    if correctness["scipy_samples_with_switch_event"]:
        print(
            "check: SciPy samples not compared (they cross |sigma| = 1, switched at the "
            f"crossing by SciPy, at the step end by RK4): "
            f"{correctness['scipy_samples_with_switch_event']}"
        )
    result = {
        "benchmark": "rigid_body_pd closed-loop throughput",
        "units": {"rate": "state-steps per second (batch x RK4 steps / run wall time)"},
        "settings": {
            **vars(args),
            "rk4_steps": n_steps,
            "save_every": save_every,
            "scipy": {"method": "RK45", "rtol": 1e-8, "atol": 1e-10},
        },
        "scipy_trajectories": [
            {"wall_s": t, **stats} for t, stats in zip(scipy_times, scipy_stats)
        ],
        "rows": rows,
        "correctness": correctness,
        "notes": notes,
    }
    return finish(result, meta, args.out, ok)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
