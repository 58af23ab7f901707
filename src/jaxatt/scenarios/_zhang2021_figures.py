"""Figures of the Zhang 2021 reproduction: the error groups with their envelopes, force, torque."""

import matplotlib.pyplot as plt
import numpy as np

from .. import plot


LABELS = {
    "linear_smc": "linear SMC (11)",
    "ppc": "PPC + SMC (33)",
    "finite_time_ppf": "finite-time PF + SMC",
}
PANELS = (
    ("position_error", 0, "relative position error $r_e$ [m]"),
    ("attitude_error", 3, r"relative attitude error $\sigma_e$"),
    ("velocity_error", 6, "relative velocity error $v_e$ [m/s]"),
    ("rate_error", 9, r"relative angular velocity error $\omega_e$ [rad/s]"),
)


def errors_with_envelopes(trajectories: dict, name: str) -> plt.Figure:
    """Figs. 3-6 / 9-12 / 15-18 equivalents: the four error groups of controller `name`, each
    component with $\\pm\\rho_i(t)$ when the controller has envelopes (a failed run is marked
    in every panel)."""
    traj = trajectories[name]
    ts = np.asarray(traj.ts)
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), layout="constrained", sharex=True)
    for ax, (signal, first, title) in zip(axes.flat, PANELS):
        values = np.asarray(traj.signals[signal])
        for i, axis in enumerate("xyz"):
            ax.plot(ts, values[:, i], label=axis)
        if "envelope" in traj.signals:
            rho = np.asarray(traj.signals["envelope"])[:, first]
            ax.plot(ts, rho, "k--", lw=0.8, label=r"$\pm\rho$")
            ax.plot(ts, -rho, "k--", lw=0.8)
        plot.mark_failure(ax, traj)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("t [s]")
        ax.legend(fontsize=7)
    fig.suptitle(LABELS[name])
    return fig


def comparison(trajectories: dict, signal: str, ylabel: str, component: int = 0) -> plt.Figure:
    """One component of `signal` for the three controllers (e.g. Fig. 15's x position); a run
    that did not end successfully says so in its legend entry."""
    fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
    for name, traj in trajectories.items():
        label = LABELS[name] + plot.status_label(traj.status, traj.failure_time)
        ax.plot(np.asarray(traj.ts), np.asarray(traj.signals[signal])[:, component], label=label)
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel)
    ax.legend()
    return fig


def controls(trajectories: dict, name: str) -> plt.Figure:
    """Figs. 7-8 equivalents: the commanded force and torque of controller `name`."""
    traj = trajectories[name]
    ts = np.asarray(traj.ts)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.5), layout="constrained")
    for ax, signal, unit in ((a, "force", "N"), (b, "torque", "N m")):
        values = np.asarray(traj.signals[signal])
        for i, axis in enumerate("xyz"):
            ax.plot(ts, values[:, i], label=axis)
        plot.mark_failure(ax, traj)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(f"{signal} [{unit}]")
        ax.legend(fontsize=7)
    fig.suptitle(LABELS[name])
    return fig


def figures(trajectories: dict) -> dict[str, plt.Figure]:
    """Every figure of the reproduction, by file stem."""
    with plot.style():
        out = {}
        for name in trajectories:
            out[f"errors_{name}"] = errors_with_envelopes(trajectories, name)
            out[f"controls_{name}"] = controls(trajectories, name)
        out["x_position_comparison"] = comparison(
            trajectories, "position_error", "x position error [m]"
        )
        out["attitude_x_comparison"] = comparison(trajectories, "attitude_error", r"$\sigma_{e,x}$")
    return out
