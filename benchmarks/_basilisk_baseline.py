"""Basilisk speed baseline: one spacecraft under MRP feedback (scenarioAttitudeFeedback-style).

Basilisk (PyPI package `bsk`) is optional. `basilisk_steps_per_second` returns None when it
cannot be imported. `bsk` 2.12.1 pins matplotlib<=3.10.9 and pillow/tqdm versions older than
the ones in the project venv, so it is meant to live in a separate venv, e.g.

    python3.11 -m venv /work/bskvenv && /work/bskvenv/bin/pip install bsk==2.12.1
    /work/bskvenv/bin/python benchmarks/_basilisk_baseline.py

This file imports only the standard library, NumPy and Basilisk (no jaxatt, no JAX), so that
venv can run it as it is.

The closed loop (one process, two tasks at the same rate dt, dynamics task first):

- dynamics task (priority 20), in this order:
  1. `extForceTorque.ExtForceTorque`: reads the commanded torque message (written by the FSW
     task at the previous step) into its buffer;
  2. `spacecraft.Spacecraft`: rigid hub (mass 750 kg, inertia J0 of Xia et al. 2011 about its
     centre of mass, no gravity, no state effectors), integrated from t - dt to t with
     Basilisk's default `svIntegratorRK4` (4 evaluations of the equations of motion, each
     calling extForceTorque.computeForceTorque, which returns the buffered torque: the torque
     is held constant over the step); MRP shadow switch after the step; writes the spacecraft
     state and mass-property messages;
  3. `simpleNav.SimpleNav`: copies the state into the navigation messages (attitude and
     translation) after its 18-state Gauss-Markov error model (zero noise here, still
     propagated every call);
- FSW task (priority 10), in this order:
  4. `inertial3D`: reference attitude sigma_R0N = 0 (inertial pointing at identity);
  5. `attTrackingError`: sigma_BR, omega_BR_B;
  6. `mrpFeedback`: K = 3.5, P = 30, Ki = -1 (integral off), so with omega_RN = 0 the command
     is L_r = -K sigma_BR - P omega_BR_B; writes the commanded torque message.

So at time t_k the torque u_k = u(x(t_k)) is computed and applied (zero-order hold) over
[t_k, t_k+1]: no extra step of delay. `reference_check` confirms it: the final state equals an
independent NumPy sample-and-hold RK4 of the same equations to ~1e-17, and differs by ~2e-7
from the same loop with the torque one step late. (scenarioAttitudeFeedback, in the version
read, adds extForceTorque to its single task ahead of the FSW modules, so there the torque lags
one step; the cost per step is the same.) ExecuteSimulation to n_steps * dt runs every module
n_steps + 1 times (at t = 0, dt, ..., n_steps dt), integrates n_steps RK4 steps, and is one
call into the C++ scheduler (no Python per step: no events, recorders, Vizard or progress
bar). The Basilisk log level is set to warnings.

Per step the spacecraft module does far more than the 6 attitude states need: it integrates
the full hub state (position, velocity, MRP, rate and two gravity-velocity states for the
delta-v accounting) through Basilisk's generic state manager, and each of the 4 RK4 evaluations
updates mass properties, evaluates the (empty) gravity field and the dynamic effectors, and
solves the coupled translation/rotation back-substitution system; after the step it
accumulates delta-v, computes energy and momentum, does the MRP switch and writes messages.
Measured on a shared 2-core machine (bsk 2.12.1): 15 to 28 us per closed-loop step depending
on load (about 13 us of it the dynamics task alone, `fsw=False`), flat in n_steps.
"""

from __future__ import annotations

import math
import time

import numpy as np


J0 = ((20.0, 1.2, 0.9), (1.2, 17.0, 1.4), (0.9, 1.4, 15.0))  # [kg m^2], Xia et al. (2011)
MASS = 750.0  # [kg]; the attitude loop does not depend on it
SIGMA0 = (0.1, 0.2, -0.3)  # initial MRP sigma_BN
OMEGA0 = (0.01, -0.01, 0.005)  # initial rate omega_BN_B [rad/s]
K_GAIN = 3.5  # [N m]
P_GAIN = 30.0  # [N m s]
KI_GAIN = -1.0  # negative: integral feedback off

DESCRIPTION = (
    "Basilisk {version}: one spacecraft, scenarioAttitudeFeedback-style MRP feedback closed "
    "loop; dynamics task (extForceTorque, spacecraft rigid hub with J0, no gravity, default "
    "RK4, simpleNav) and FSW task (inertial3D, attTrackingError, mrpFeedback K=3.5 P=30 "
    "Ki=-1) both at dt = {dt:g} s; torque held over each step; no recorders; one run of the "
    "C++ scheduler per ExecuteSimulation"
)


def _import_basilisk():
    """The Basilisk modules used here, or None when Basilisk is not installed."""
    try:
        from Basilisk import __version__
        from Basilisk.architecture import bskLogging, messaging
        from Basilisk.fswAlgorithms import attTrackingError, inertial3D, mrpFeedback
        from Basilisk.simulation import extForceTorque, simpleNav, spacecraft
        from Basilisk.utilities import SimulationBaseClass, macros
    except ImportError:
        return None
    return {
        "version": __version__,
        "bskLogging": bskLogging,
        "messaging": messaging,
        "attTrackingError": attTrackingError,
        "inertial3D": inertial3D,
        "mrpFeedback": mrpFeedback,
        "extForceTorque": extForceTorque,
        "simpleNav": simpleNav,
        "spacecraft": spacecraft,
        "SimulationBaseClass": SimulationBaseClass,
        "macros": macros,
    }


def _dt_nanos(dt: float) -> int:
    ns = round(dt * 1e9)
    if ns <= 0 or abs(ns - dt * 1e9) > 1e-6 * dt * 1e9:
        raise ValueError(f"dt = {dt!r} s is not a whole number of nanoseconds")
    return ns


def build_simulation(bsk, dt: float, sigma0=SIGMA0, omega0=OMEGA0, fsw: bool = True):
    """Build and initialize the closed loop; returns (sim, handles) ready for ExecuteSimulation.

    `fsw=False` builds the dynamics task alone (extForceTorque with no command, spacecraft,
    no simpleNav): the cost of Basilisk's free rigid-body propagation by itself.
    """
    bsk["bskLogging"].setDefaultLogLevel(bsk["bskLogging"].BSK_WARNING)
    rate = _dt_nanos(dt)
    sim = bsk["SimulationBaseClass"].SimBaseClass()
    sim.SetProgressBar(False)
    proc = sim.CreateNewProcess("process")
    proc.addTask(sim.CreateNewTask("dynTask", rate), 20)

    ext = bsk["extForceTorque"].ExtForceTorque()
    ext.ModelTag = "controlTorque"
    sc = bsk["spacecraft"].Spacecraft()
    sc.ModelTag = "spacecraft"
    sc.hub.mHub = MASS
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = [list(row) for row in J0]
    sc.hub.sigma_BNInit = [[s] for s in sigma0]
    sc.hub.omega_BN_BInit = [[w] for w in omega0]
    sc.addDynamicEffector(ext)
    # Higher module priority runs first: extForceTorque latches the command, then the hub
    # integrates over the step just ended, then the navigation message is written.
    sim.AddModelToTask("dynTask", ext, None, 30)
    sim.AddModelToTask("dynTask", sc, None, 20)
    handles = {"spacecraft": sc, "extForceTorque": ext}
    if not fsw:
        sim.InitializeSimulation()
        return sim, handles

    nav = bsk["simpleNav"].SimpleNav()
    nav.ModelTag = "simpleNav"
    nav.scStateInMsg.subscribeTo(sc.scStateOutMsg)
    sim.AddModelToTask("dynTask", nav, None, 10)

    proc.addTask(sim.CreateNewTask("fswTask", rate), 10)
    guid = bsk["inertial3D"].inertial3D()
    guid.ModelTag = "inertial3D"
    guid.sigma_R0N = [0.0, 0.0, 0.0]
    err = bsk["attTrackingError"].attTrackingError()
    err.ModelTag = "attTrackingError"
    err.attNavInMsg.subscribeTo(nav.attOutMsg)
    err.attRefInMsg.subscribeTo(guid.attRefOutMsg)
    ctrl = bsk["mrpFeedback"].mrpFeedback()
    ctrl.ModelTag = "mrpFeedback"
    ctrl.K = K_GAIN
    ctrl.P = P_GAIN
    ctrl.Ki = KI_GAIN
    ctrl.integralLimit = 2.0 / ctrl.Ki * 0.1  # as in the Basilisk example (unused, Ki < 0)
    ctrl.guidInMsg.subscribeTo(err.attGuidOutMsg)
    payload = bsk["messaging"].VehicleConfigMsgPayload()
    payload.ISCPntB_B = [x for row in J0 for x in row]
    veh_msg = bsk["messaging"].VehicleConfigMsg().write(payload)
    ctrl.vehConfigInMsg.subscribeTo(veh_msg)
    ext.cmdTorqueInMsg.subscribeTo(ctrl.cmdTorqueOutMsg)
    sim.AddModelToTask("fswTask", guid, None, 30)
    sim.AddModelToTask("fswTask", err, None, 20)
    sim.AddModelToTask("fswTask", ctrl, None, 10)

    # Keep every SWIG object referenced as long as the sim lives.
    handles.update(
        simpleNav=nav, inertial3D=guid, attTrackingError=err, mrpFeedback=ctrl, vehMsg=veh_msg
    )
    sim.InitializeSimulation()
    return sim, handles


def _run(sim, n_steps: int, dt: float) -> float:
    sim.ConfigureStopTime(n_steps * _dt_nanos(dt))
    t0 = time.perf_counter()
    sim.ExecuteSimulation()
    return time.perf_counter() - t0


def final_state(handles) -> tuple[np.ndarray, np.ndarray]:
    """(sigma_BN, omega_BN_B) from the spacecraft state message after a run."""
    state = handles["spacecraft"].scStateOutMsg.read()
    return np.array(state.sigma_BN, dtype=float), np.array(state.omega_BN_B, dtype=float)


def basilisk_steps_per_second(
    n_steps: int = 30000, dt: float = 1e-3, repeat: int = 3, fsw: bool = True
) -> dict | None:
    """Steps per second of Basilisk's MRP-feedback closed loop, or None without Basilisk.

    Each repeat builds and initializes a fresh simulation (timed as `setup_seconds`), then times
    one ExecuteSimulation to n_steps * dt. `steps_per_second` = n_steps / min(run times).
    """
    bsk = _import_basilisk()
    if bsk is None:
        return None
    if n_steps < 1 or repeat < 1:
        raise ValueError("n_steps and repeat must be positive")
    setups, runs = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        sim, handles = build_simulation(bsk, dt, fsw=fsw)
        setups.append(time.perf_counter() - t0)
        runs.append(_run(sim, n_steps, dt))
        sigma, _ = final_state(handles)
        del sim, handles
    best = min(runs)
    return {
        "steps_per_second": n_steps / best,
        "n_steps": n_steps,
        "dt": dt,
        "bsk_version": bsk["version"],
        "run_seconds": best,
        "run_seconds_all": runs,
        "setup_seconds": min(setups),
        "setup_seconds_all": setups,
        "repeat": repeat,
        "final_sigma_norm": float(np.linalg.norm(sigma)),
        "description": (
            DESCRIPTION.format(version=bsk["version"], dt=dt)
            if fsw
            else f"Basilisk {bsk['version']}: dynamics task only (extForceTorque with no "
            f"command, spacecraft rigid hub, default RK4) at dt = {dt:g} s; no FSW, no nav"
        ),
    }


# ---------------------------------------------------------------------------------------------
# Checks: convergence, and agreement with an independent NumPy sample-and-hold RK4 of the same
# loop (which would differ at O(dt) if the torque lagged one step or the law were different).


def _reference_final_state(
    horizon: float, dt: float, sigma0=SIGMA0, omega0=OMEGA0, delay: bool = False
):
    """NumPy RK4 of sigma_dot = B(sigma) omega / 4, J omega_dot = -omega x J omega + u, with
    u = -K sigma - P omega computed at the start of each step and held, shadow switch after.

    `delay=True` applies the torque of the previous step instead (zero at the first step)."""
    j = np.array(J0)
    j_inv = np.linalg.inv(j)
    s = np.array(sigma0, dtype=float)
    w = np.array(omega0, dtype=float)

    def f(s, w, u):
        ss = s @ s
        ds = 0.25 * ((1.0 - ss) * w + 2.0 * np.cross(s, w) + 2.0 * (s @ w) * s)
        dw = j_inv @ (-np.cross(w, j @ w) + u)
        return ds, dw

    u_prev = np.zeros(3)
    for _ in range(round(horizon / dt)):
        u = -K_GAIN * s - P_GAIN * w
        if delay:
            u, u_prev = u_prev, u
        k1s, k1w = f(s, w, u)
        k2s, k2w = f(s + 0.5 * dt * k1s, w + 0.5 * dt * k1w, u)
        k3s, k3w = f(s + 0.5 * dt * k2s, w + 0.5 * dt * k2w, u)
        k4s, k4w = f(s + dt * k3s, w + dt * k3w, u)
        s = s + dt / 6.0 * (k1s + 2 * k2s + 2 * k3s + k4s)
        w = w + dt / 6.0 * (k1w + 2 * k2w + 2 * k3w + k4w)
        if s @ s > 1.0:
            s = -s / (s @ s)
    return s, w


def convergence_check(horizon: float = 300.0, dt: float = 1e-3, tol: float = 1e-3) -> dict | None:
    """Run the loop for `horizon` s; |sigma| must fall from |sigma0| (0.374) to below `tol`.

    The slow closed-loop pole is about -K / (4 P) = -0.029 1/s (time constant ~34 s; |sigma|
    is still ~0.02 at 100 s), hence the 300 s default.
    """
    bsk = _import_basilisk()
    if bsk is None:
        return None
    sim, handles = build_simulation(bsk, dt)
    _run(sim, round(horizon / dt), dt)
    sigma, omega = final_state(handles)
    norm = float(np.linalg.norm(sigma))
    return {
        "horizon": horizon,
        "sigma0_norm": float(np.linalg.norm(SIGMA0)),
        "final_sigma": sigma.tolist(),
        "final_sigma_norm": norm,
        "final_omega_norm": float(np.linalg.norm(omega)),
        "tol": tol,
        "converged": norm < tol,
    }


def reference_check(horizon: float = 5.0, dt: float = 1e-3, tol: float = 1e-9) -> dict | None:
    """Final state after `horizon` s against the NumPy sample-and-hold RK4 of the same loop."""
    bsk = _import_basilisk()
    if bsk is None:
        return None
    sim, handles = build_simulation(bsk, dt)
    _run(sim, round(horizon / dt), dt)
    sigma, omega = final_state(handles)
    ref_s, ref_w = _reference_final_state(horizon, dt)
    diff = float(max(np.max(np.abs(sigma - ref_s)), np.max(np.abs(omega - ref_w))))
    # The same loop with the torque one step late, to show that the check can tell the two apart.
    late_s, late_w = _reference_final_state(horizon, dt, delay=True)
    late = max(np.max(np.abs(sigma - late_s)), np.max(np.abs(omega - late_w)))
    return {
        "horizon": horizon,
        "max_abs_diff": float(diff),
        "max_abs_diff_vs_one_step_delay": float(late),
        "tol": tol,
        "ok": bool(diff < tol),
    }


def main() -> int:
    import json
    import os

    if _import_basilisk() is None:
        print("Basilisk (bsk) is not installed: no baseline")
        return 0
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
    print(f"1-min load average {load:.2f} on {os.cpu_count()} CPUs")
    result = basilisk_steps_per_second()
    print(json.dumps(result, indent=2))
    conv = convergence_check()
    print("convergence:", json.dumps(conv))
    ref = reference_check()
    print("reference (NumPy sample-and-hold RK4):", json.dumps(ref))
    print("cost per step vs n_steps (setup excluded; min and median of 5 runs each):")
    print(f"{'n_steps':>8} {'min run s':>10} {'us/step':>8} {'median us/step':>15} {'setup s':>8}")
    for n in (1000, 3000, 10000, 30000, 100000):
        r = basilisk_steps_per_second(n_steps=n, repeat=5)
        median = sorted(r["run_seconds_all"])[2]
        print(
            f"{n:>8} {r['run_seconds']:>10.4f} {1e6 / r['steps_per_second']:>8.2f} "
            f"{1e6 * median / n:>15.2f} {r['setup_seconds']:>8.4f}"
        )
    dyn = basilisk_steps_per_second(fsw=False)
    print(
        f"dynamics task only (no nav, no FSW): {dyn['steps_per_second']:.3g} steps/s "
        f"({1e6 / dyn['steps_per_second']:.2f} us/step)"
    )
    return 0 if conv["converged"] and ref["ok"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
