"""Time-history figures of a single simulated closed loop."""

import contextlib
from collections.abc import Iterator, Sequence

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from jaxtyping import ArrayLike, Int, Real
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..simulation import Status, Trajectory


_AXIS_LABELS = ("x", "y", "z")


@contextlib.contextmanager
def style() -> Iterator[None]:
    """A local matplotlib style for jaxatt figures (never changes global rcParams)."""
    interactive = matplotlib.is_interactive()
    try:
        with plt.rc_context(
            {
                "figure.dpi": 110,
                "axes.grid": True,
                "grid.alpha": 0.3,
                "axes.spines.top": False,
                "axes.spines.right": False,
                "legend.frameon": False,
                "font.size": 9,
            }
        ):
            yield
            interactive = matplotlib.is_interactive()
    finally:
        # rc_context restores *every* rcParam, also `interactive`, which Jupyter's inline
        # backend switches on when the first figure of a session is made; rolled back, every
        # later figure of the notebook was silently not displayed.
        matplotlib.interactive(interactive)


def _new_axes(ax: Axes | None) -> Axes:
    if ax is not None:
        return ax
    _, ax = plt.subplots(figsize=(6, 3))
    return ax


def _failure_text(status, failure_time) -> str:
    """`""` for a successful run, else `"<status> at t = <failure_time> s"`."""
    status = int(np.asarray(status))
    if status == Status.successful:
        return ""
    t = float(np.asarray(failure_time))
    return Status(status).name + (f" at t = {t:.4g} s" if np.isfinite(t) else "")


def status_label(status: Int[ArrayLike, ""], failure_time: Real[ArrayLike, ""]) -> str:
    """What a legend entry adds for one run: `""` for a successful run, else
    `" (<status> at t = <failure_time> s)"` (e.g. `" (constraint_violated at t = 1.2 s)"`), so
    a failed run is never drawn as an ordinary one. `status` and `failure_time` are one
    sample's `Trajectory.status` and `Trajectory.failure_time` (scalars)."""
    text = _failure_text(status, failure_time)
    return f" ({text})" if text else ""


def mark_failure(ax: Axes, traj: Trajectory) -> None:
    """Mark a run that did not end successfully on `ax`: a dotted red line at its failure time,
    with its status as the legend entry (e.g. `"nonfinite_state at t = 0.5 s"`); nothing for a
    successful run. For a figure drawn by hand from one trajectory (its samples after the
    failure time are not physical, except after a constraint violation); `plot_signal` and the
    figures built on it call it themselves. Where several runs share the axes, name each in its
    legend entry with [`status_label`][jaxatt.plot.status_label] instead.

    **Arguments:**
    - `ax`: the axes the trajectory is drawn on.
    - `traj`: a single (unbatched) trajectory; index a batch first
      (`jax.tree.map(lambda x: x[k], traj)`).
    """
    if np.ndim(traj.status) != 0:
        raise ValueError(
            "mark_failure: `traj` must be a single trajectory (its `status` a scalar), got a "
            f"status of shape {np.shape(traj.status)}; index a batch first."
        )
    label = _failure_text(traj.status, traj.failure_time)
    if not label:
        return
    t = float(np.asarray(traj.failure_time))
    if np.isfinite(t):
        ax.axvline(t, color="C3", lw=1.0, ls=":", label=label)
    else:
        ax.plot([], [], color="C3", lw=1.0, ls=":", label=label)


def plot_signal(
    traj: Trajectory,
    name: str,
    *,
    ax: Axes | None = None,
    labels: Sequence[str] | None = None,
    components: slice | Sequence[int] | None = None,
    ylabel: str | None = None,
    log: bool = False,
) -> Axes:
    """Plot a recorded signal `traj.signals[name]` against time, one line per component.

    **Arguments:**
    - `traj`: a single (unbatched) trajectory.
    - `name`: a key of `traj.signals` (e.g. `"u"`, `"attitude_error"`, `"s"`).
    - `ax`: axes to draw on; a new figure when `None`.
    - `labels`: legend entries per component.
    - `components`: which components to draw (e.g. `slice(1, 4)` for a quaternion's vector part).
    - `ylabel`: the y-axis label; `log`: plot `|value|` on a log axis.

    A trajectory whose status is not successful (`simulate(..., throw=False)`) gets a dotted
    red line at its failure time, labelled with the status, so a failed run never looks like
    an ordinary one.

    **Returns:** the axes.
    """
    if name not in traj.signals:
        raise ValueError(
            f"plot_signal: `name` must be one of {sorted(traj.signals)}, got {name!r}."
        )
    ts = np.asarray(traj.ts)
    if ts.ndim != 1:
        raise ValueError("plot_signal: `traj` must be a single trajectory (index a batch first).")
    values = np.asarray(traj.signals[name])
    if values.ndim == 1:
        values = values[:, None]
    if components is not None:
        values = values[:, components]
    if labels is None:
        labels = [f"{name}[{i}]" for i in range(values.shape[1])]
    elif len(labels) != values.shape[1]:
        raise ValueError(
            f"plot_signal: `labels` must have {values.shape[1]} entries, one per drawn component "
            f"of {name!r}, got {len(labels)}: {list(labels)!r}."
        )
    ax = _new_axes(ax)
    for column, label in zip(values.T, labels):
        ax.plot(ts, np.abs(column) if log else column, label=label, lw=1.2)
    mark_failure(ax, traj)
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(ylabel if ylabel is not None else name)
    ax.legend(loc="best", fontsize=8)
    return ax


def plot_attitude_error(traj: Trajectory, *, ax: Axes | None = None) -> Axes:
    """The attitude-error vector: the signal `attitude_error_vector` that attitude plants
    publish ($e_v$, the vector part of the error quaternion, for quaternion plants;
    $\\sigma_e$, the error MRP, for MRP plants)."""
    return plot_signal(
        traj,
        "attitude_error_vector",
        ax=ax,
        labels=[f"$e_{{{a}}}$" for a in _AXIS_LABELS],
        ylabel="attitude-error vector",
    )


def plot_rate_error(traj: Trajectory, *, ax: Axes | None = None) -> Axes:
    """Angular-rate error $\\omega - C\\omega_d$ [rad/s]."""
    return plot_signal(
        traj,
        "rate_error",
        ax=ax,
        labels=[f"$e_{{\\omega,{a}}}$" for a in _AXIS_LABELS],
        ylabel="rate error [rad/s]",
    )


def plot_control(traj: Trajectory, *, ax: Axes | None = None, limit: float | None = None) -> Axes:
    """Applied control torque [N m], with the saturation limit drawn when given.

    The control must be a 3-axis torque; a control with other components (e.g. a 6-DOF force
    and torque) is refused: draw it with [`plot_signal`][] (`components=slice(3, 6)` for the
    torque of a 6-DOF plant).
    """
    shape = np.shape(traj.signals.get("u", np.zeros(3)))
    if shape[-1:] != (3,):
        raise ValueError(
            "plot_control: the applied control `u` must be a 3-axis torque, got "
            f"{shape[-1] if shape else 0} components (shape {shape}); "
            "draw it with plot_signal(traj, 'u', ...) (components=slice(3, 6) for a 6-DOF "
            "plant's torque)."
        )
    ax = plot_signal(
        traj, "u", ax=ax, labels=[f"$u_{a}$" for a in _AXIS_LABELS], ylabel="torque [N m]"
    )
    if limit is not None:
        for sign in (-1, 1):
            ax.axhline(sign * limit, color="k", lw=0.8, ls="--")
    return ax


def plot_overview(
    traj: Trajectory, *, title: str | None = None, limit: float | None = None
) -> Figure:
    """A 3-panel figure: attitude error, rate error and applied torque against time."""
    fig, axes = plt.subplots(3, 1, figsize=(7, 7.5), sharex=True, layout="constrained")
    plot_attitude_error(traj, ax=axes[0])
    plot_rate_error(traj, ax=axes[1])
    plot_control(traj, ax=axes[2], limit=limit)
    if title:
        fig.suptitle(title)
    return fig
