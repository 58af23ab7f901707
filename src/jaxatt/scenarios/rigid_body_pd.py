"""Built-in demo scenario: MRP PD regulation of the Xia et al. (2011) spacecraft.

The plant is the spacecraft Chen et al. (2022) use (SPEC 000.4): nominal inertia $J_0$, true
inertia $J_0 + \\Delta J(t)$, sinusoidal disturbance $d(t)$, 30 N m per-axis torque limit,
initial attitude D1 at rest. The controller is the PD law $\\tau = -k_1\\sigma - k_2\\omega$
(Yu et al. 2022's baseline form) with gains chosen here for a well-damped response
($k_1 = 60$ N m, $k_2 = 50$ N m s). `reproduce` writes an overview figure, a Monte Carlo
envelope over random initial attitudes, and `metrics.json`.

Simulation: classic RK4, dt = 1e-2 s (1e-3 in `reproduce(short=False)`), 40 s, continuous
control.
"""

import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import ArrayLike, Bool

from ..controllers import MRPPD
from ..metrics import control_effort, overshoot, peak, settling_time
from ..montecarlo import mrp_states, run_batch
from ..numerics import safe_norm
from ..plants import MRPState, RigidBodyMRP
from ..rotations import mrp_from_quat
from ..simulation import ClosedLoop, Saturation, Simulation, Trajectory, simulate
from . import _xia2011
from ._io import write_report
from ._protocol import Scenario


TITLE = "MRP PD regulation of the Xia 2011 spacecraft (built-in demo)"
TORQUE_LIMIT = 30.0
"""Per-axis torque limit [N m]."""
HORIZON = 40.0
"""Simulated time [s]."""
SETTLING_TOLERANCE = 1e-2
"""Settling tolerance on the error MRP norm ||sigma_e|| (a rotation of 4 atan(0.01) = 2.3 deg)."""


def build(k1: float = 60.0, k2: float = 50.0) -> ClosedLoop:
    """The closed loop (see [`initial_state`][] for the nominal start)."""
    plant = RigidBodyMRP(
        _xia2011.nominal_inertia(),
        _xia2011.inertia_perturbation(),
        _xia2011.disturbance(),
        shadow_switching=True,
    )
    return ClosedLoop(plant, MRPPD(k1, k2), actuator=Saturation(TORQUE_LIMIT))


def initial_state() -> MRPState:
    """Attitude D1 at rest."""
    return MRPState(mrp_from_quat(_xia2011.initial_attitude_d1()), jnp.zeros(3))


def trajectory_metrics(traj: Trajectory) -> dict[str, jax.Array]:
    """Settling time of ||sigma|| to `SETTLING_TOLERANCE`, overshoot, effort, peak torque."""
    error = safe_norm(traj.signals["attitude_error"])
    return {
        "settling_time": settling_time(traj.ts, error, SETTLING_TOLERANCE),
        "max_overshoot": jnp.max(overshoot(traj.signals["attitude_error"])),
        "effort": control_effort(traj.ts, traj.signals["u"]),
        "peak_torque": peak(traj.signals["u"]),
        "final_error": error[-1],
    }


def random_initial_states(key: jax.Array, n: int, max_rate: float = 0.05) -> MRPState:
    """`n` Haar-uniform attitudes with rates uniform in the box [-max_rate, max_rate]^3 [rad/s].

    [`jaxatt.montecarlo.mrp_states`][]: Haar-uniform attitudes (canonical, so
    ||sigma|| <= 1) and box rates, from the two halves of `jr.split(key)`.
    """
    return mrp_states(key, n, max_rate=max_rate)


@eqx.filter_jit
def _batch(loop: ClosedLoop, x0s: MRPState, sim: Simulation):
    result = run_batch(loop, x0s, sim, trajectory_metrics, keep_trajectories=True)
    return result.trajectories, result.metrics


def reproduce(
    out_dir: str | pathlib.Path, *, short: bool = False, batch: int = 100, progress: bool = False
) -> dict:
    """Simulate the nominal case and a batch of random attitudes; write figures and metrics.

    **Arguments:**
    - `out_dir`: folder for `overview.png`, `montecarlo.png` and `metrics.json`.
    - `short`: coarser step (1e-2 s instead of 1e-3 s) and a 16-sample batch, for CI.
    - `batch`: number of random initial attitudes.
    - `progress`: show a progress bar over the two simulation stages.

    **Returns:** the metrics written to `metrics.json`.
    """
    import matplotlib.pyplot as plt
    from tqdm import tqdm

    from .. import plot

    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dt = 1e-2 if short else 1e-3
    n = 16 if short else batch
    bar = tqdm(total=2, desc="rigid_body_pd", disable=not progress)
    loop, x0 = build(), initial_state()
    traj = simulate(loop, x0, 0.0, HORIZON, dt=dt, save_every=round(0.02 / dt))
    nominal = {k: float(v) for k, v in trajectory_metrics(traj).items()}
    bar.update()
    sim = Simulation(0.0, HORIZON, dt, save_every=round(0.1 / dt))
    trajs, batch_metrics = _batch(loop, random_initial_states(jr.key(0), n), sim)
    bar.update()
    bar.close()
    summary = monte_carlo_summary(batch_metrics, trajs.successful)
    metrics = {
        "scenario": "rigid_body_pd",
        "dt": dt,
        "horizon": HORIZON,
        "integrator": "RK4",
        "settling_tolerance": SETTLING_TOLERANCE,
        "nominal": nominal,
        "monte_carlo": summary,
    }
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    written = write_report(out / "metrics.json", metrics)
    with plot.style():
        fig = plot.plot_overview(traj, title=TITLE, limit=TORQUE_LIMIT)
        fig.savefig(out / "overview.png")
        plt.close(fig)
        fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
        errors = np.linalg.norm(np.asarray(trajs.signals["attitude_error"]), axis=-1)
        ts = np.asarray(trajs.ts[0])
        # The median is over one fixed set of samples at every time: failed samples and
        # samples non-finite at any time are left out (drawn in red) and counted in the legend.
        ok = np.asarray(trajs.successful, dtype=bool)
        keep = ok & np.isfinite(errors).all(axis=1)
        dropped, total = int((~keep).sum()), keep.size
        ax.semilogy(ts, errors[keep].T, color="C0", alpha=0.25, lw=0.8)
        median_label = "median"
        if dropped:
            ax.semilogy(ts, errors[~keep].T, color="C3", alpha=0.6, lw=0.8)
            ax.plot([], [], color="C3", lw=0.8, label=f"failed or non-finite ({dropped})")
            median_label += f" ({dropped} of {total} failed or non-finite, excluded)"
        median = np.median(errors[keep], axis=0) if keep.any() else np.full(ts.shape, np.nan)
        ax.semilogy(ts, median, color="k", lw=1.5, label=median_label)
        ax.axhline(SETTLING_TOLERANCE, color="C3", ls="--", lw=1, label="tolerance")
        ax.set_xlabel("t [s]")
        ax.set_ylabel(r"$\|\sigma_e\|$")
        ax.set_title(f"{n} random initial attitudes (vmap, one compiled call)")
        ax.legend()
        fig.savefig(out / "montecarlo.png")
        plt.close(fig)
    return written


def monte_carlo_summary(batch_metrics: dict, successful: Bool[ArrayLike, " n"]) -> dict:
    """The `monte_carlo` entry of `metrics.json` from the batch's metrics and success flags.

    A failed sample counts at its worst: never settled (an infinite settling time, also where
    its metric holds NaN) and an unbounded peak torque. `settling_time_max` and
    `peak_torque_max` are therefore infinite (JSON `null`) as soon as one sample is unsettled
    or failed; `settling_time_mean` averages the settled samples (None if there are none).
    """
    ok = np.asarray(successful, dtype=bool)
    times = np.asarray(batch_metrics["settling_time"], dtype=float)
    times = np.where(ok & ~np.isnan(times), times, np.inf)
    torques = np.asarray(batch_metrics["peak_torque"], dtype=float)
    torques = np.where(ok & ~np.isnan(torques), torques, np.inf)
    settled = np.isfinite(times)
    return {
        "samples": int(ok.size),
        "failed_samples": int((~ok).sum()),
        "settled_fraction": float(settled.mean()),
        "settling_time_mean": float(np.mean(times[settled])) if settled.any() else None,
        "settling_time_max": float(np.max(times)),
        "peak_torque_max": float(np.max(torques)),
    }


SCENARIO = Scenario(
    name="rigid_body_pd",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=trajectory_metrics,
)
