"""Monte Carlo figures: envelopes of a batch of time series, distributions of a metric, and a
metric against the initial error."""

from collections.abc import Mapping

import matplotlib.transforms as mtransforms
import numpy as np
from jaxtyping import ArrayLike
from matplotlib.axes import Axes

from ._trajectory import _new_axes


def _host(values: ArrayLike) -> np.ndarray:
    from ..montecarlo._summary import to_host

    return to_host(values).astype(float)


def _successful_mask(successful: ArrayLike | None, n: int, name: str) -> np.ndarray:
    if successful is None:
        return np.ones(n, bool)
    mask = np.asarray(successful)
    if mask.dtype.kind != "b":
        # Integer status codes cast to bool would swap success (0) and failure.
        raise ValueError(
            f"{name}: `successful` must be a boolean mask (e.g. `result.successful` or "
            f"`result.status == 0`), got an array of dtype {mask.dtype}."
        )
    mask = mask.reshape(-1)
    if mask.shape != (n,):
        raise ValueError(
            f"{name}: `successful` must have one entry per sample, shape ({n},), got shape "
            f"{np.shape(successful)}."
        )
    return mask


def plot_envelope(
    ts: ArrayLike,
    values: ArrayLike,
    *,
    ax: Axes | None = None,
    quantiles: tuple[float, float] = (0.05, 0.95),
    label: str | None = None,
    log: bool = False,
    successful: ArrayLike | None = None,
) -> Axes:
    r"""Median and a quantile band of a batch of time series.

    The statistics are taken over one fixed set of kept samples at every time: sample $i$ is
    excluded (at all times, not only where it is non-finite) when it failed
    (`successful[i]` is false, e.g. a `constraint_violated` sample whose values stay finite)
    or when $v_i(t_k)$ is NaN or $\pm\infty$ at any saved time $t_k$ (diverged or failed).
    With $K$ the kept samples, the line is $\operatorname{median}_{i \in K} v_i(t_k)$ and the
    band, in the line's color, spans the `quantiles` of $\{v_i(t_k)\}_{i \in K}$, in the
    units of `values`. Excluded samples are not in the figure's statistics, so the legend says
    how many there are: "M1 (2 of 4 failed or non-finite, excluded)"; when every sample is
    excluded nothing is drawn but the legend entry.

    **Arguments:**
    - `ts`: times [s], shape `(T,)` (or the batched `traj.ts` of shape `(n, T)`, whose first
      row is used).
    - `values`: shape `(n, T)`, e.g. `safe_norm(trajs.signals["attitude_error"][..., 1:])`.
    - `ax`: axes to draw on; a new figure when `None`.
    - `quantiles`: lower and upper probabilities of the band, in [0, 1].
    - `label`: legend entry of the median line (the band is labelled with the quantiles).
    - `log`: logarithmic y axis.
    - `successful`: optional boolean mask of shape `(n,)`, e.g. `trajs.successful` or
      `result.status == 0` of a [`jaxatt.montecarlo.MonteCarloResult`][]; false samples are
      excluded and counted as failed. Without it only non-finite samples are excluded.

    **Returns:** the axes.
    """
    ts = _host(ts)
    if ts.ndim == 2:
        ts = ts[0]
    values = _host(values)
    if values.ndim != 2 or ts.ndim != 1 or values.shape[1] != ts.shape[0]:
        raise ValueError(
            f"plot_envelope: `values` must have shape (n, T) with T = len(ts) = {ts.shape[-1]}, "
            f"got shape {values.shape}."
        )
    if np.shape(quantiles) != (2,) or not 0.0 <= quantiles[0] <= quantiles[1] <= 1.0:
        raise ValueError(
            f"plot_envelope: `quantiles` must be (low, high) with 0 <= low <= high <= 1, got "
            f"{quantiles}."
        )
    low, high = (float(q) for q in quantiles)
    n = values.shape[0]
    keep = _successful_mask(successful, n, "plot_envelope") & np.isfinite(values).all(axis=1)
    if keep.any():
        q_low, median, q_high = np.quantile(values[keep], [low, 0.5, high], axis=0)
    else:
        q_low = median = q_high = np.full(ts.shape, np.nan)
    name = label if label is not None else "median"
    excluded = int(n - keep.sum())
    if excluded:
        name = f"{name} ({excluded} of {n} failed or non-finite, excluded)"
    ax = _new_axes(ax)
    (line,) = ax.plot(ts, median, lw=1.5, label=name)
    band = f"{100 * low:g}-{100 * high:g} %"
    ax.fill_between(
        ts,
        q_low,
        q_high,
        color=line.get_color(),
        alpha=0.25,
        lw=0,
        label=f"{label} {band}" if label is not None else band,
    )
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.legend(loc="best", fontsize=8)
    return ax


def _legend_label(
    name: str, values: np.ndarray, missing: str, failed: np.ndarray | None = None
) -> str:
    failed = np.zeros(values.shape, bool) if failed is None else failed
    parts = []
    if failed.any():
        parts.append(f"{int(failed.sum())} failed")
    unsettled = int(np.sum(~np.isfinite(values) & ~failed))
    if unsettled:
        parts.append(f"{unsettled} {missing}")
    return f"{name} ({', '.join(parts)})" if parts else name


def _values_and_failures(values, metric: str, label: str) -> tuple[np.ndarray, np.ndarray | None]:
    from ..montecarlo import MonteCarloResult

    where = "plot_settling_distribution"
    if isinstance(values, MonteCarloResult):
        if metric not in values.metrics:
            raise ValueError(
                f"{where}: `metric` {metric!r} is not a metric of {label!r}; it has "
                f"{sorted(values.metrics)}."
            )
        failed = ~_host(values.successful).astype(bool).reshape(-1)
        data = _host(values.metrics[metric])
        if data.shape != failed.shape:
            raise ValueError(
                f"{where}: the metric {metric!r} of {label!r} must have one value per sample, "
                f"shape {failed.shape}, got shape {data.shape} (draw one component at a time)."
            )
        return data, failed
    data = _host(values)
    if data.ndim != 1:
        raise ValueError(
            f"{where}: the values of {label!r} must have shape (n,), one per sample, got shape "
            f"{data.shape}."
        )
    return data, None


def plot_settling_distribution(
    results: Mapping[str, object],
    *,
    metric: str = "settling_time",
    kind: str = "cdf",
    ax: Axes | None = None,
    xlabel: str = "settling time [s]",
) -> Axes:
    """Empirical CDF (or histogram) of a metric per batch, e.g. settling time per controller.

    With `kind="cdf"` the curve of each batch rises by $1/n$ at every finite value, so it ends
    at the fraction of samples with a finite value; samples that never settled (`inf`) or
    failed are not drawn and are counted in the legend ("2 failed, 3 not settled"). With
    `kind="hist"` the finite values are binned on common edges (step histograms).

    **Arguments:**
    - `results`: label -> a [`jaxatt.montecarlo.MonteCarloResult`][] (its `metric` is drawn
      and its failed samples are counted as failed), or label -> values of shape `(n,)`
      (non-finite values are counted as not settled).
    - `metric`: the metric drawn from `MonteCarloResult`s.
    - `kind`: `"cdf"` or `"hist"`.
    - `ax`: axes to draw on; a new figure when `None`.
    - `xlabel`: the x-axis label.

    **Returns:** the axes.
    """
    if kind not in ("cdf", "hist"):
        raise ValueError(
            f"plot_settling_distribution: `kind` must be 'cdf' or 'hist', got {kind!r}."
        )
    data = {
        str(name): _values_and_failures(values, metric, str(name))
        for name, values in results.items()
    }
    if not data:
        raise ValueError("plot_settling_distribution: `results` must not be empty.")
    ax = _new_axes(ax)
    finite_all = np.concatenate(
        [v[np.isfinite(v) & (True if f is None else ~f)] for v, f in data.values()]
    )
    edges = np.histogram_bin_edges(finite_all, bins=30) if finite_all.size else None
    for name, (values, failed) in data.items():
        label = _legend_label(name, values, "not settled", failed)
        if failed is not None:
            values = np.where(failed, np.nan, values)
        finite = np.sort(values[np.isfinite(values)])
        if finite.size == 0:
            ax.plot([], [], label=label)
        elif kind == "cdf":
            fraction = np.arange(1, finite.size + 1) / values.size
            ax.step(
                np.concatenate([finite[:1], finite]),
                np.concatenate([[0.0], fraction]),
                where="post",
                label=label,
                lw=1.4,
            )
        else:
            ax.hist(finite, bins=edges, histtype="step", lw=1.4, label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("fraction of samples" if kind == "cdf" else "samples")
    if kind == "cdf":
        ax.set_ylim(0.0, 1.02)
    ax.legend(loc="best", fontsize=8)
    return ax


def plot_scatter_vs_initial_error(
    initial_angle: ArrayLike,
    values: ArrayLike,
    *,
    ax: Axes | None = None,
    label: str | None = None,
    ylabel: str = "settling time [s]",
    successful: ArrayLike | None = None,
) -> Axes:
    """Scatter of a per-sample metric against the initial attitude-error angle.

    Samples with a non-finite value (not settled, failed) and, when `successful` is given,
    failed samples whatever their value are drawn as crosses along the top edge of the axes
    and counted in the legend ("M1 (1 failed, 2 not settled)"; without `successful` every
    non-finite value is counted as not settled).

    **Arguments:**
    - `initial_angle`: initial error angle [rad], shape `(n,)` (plotted in degrees), e.g.
      `jax.vmap(jaxatt.rotations.quat_angle)(x0s.q)` for a reference starting at the
      identity.
    - `values`: the metric, shape `(n,)`.
    - `ax`: axes to draw on; a new figure when `None`.
    - `label`: legend entry.
    - `ylabel`: the y-axis label.
    - `successful`: optional boolean mask of shape `(n,)`, e.g. `result.status == 0` of a
      [`jaxatt.montecarlo.MonteCarloResult`][]; false samples are counted as failed.

    **Returns:** the axes.
    """
    angle = np.degrees(_host(initial_angle).reshape(-1))
    values = _host(values).reshape(-1)
    if angle.shape != values.shape:
        raise ValueError(
            "plot_scatter_vs_initial_error: `initial_angle` and `values` must have the same "
            f"length, got {angle.shape[0]} and {values.shape[0]}."
        )
    failed = ~_successful_mask(successful, values.shape[0], "plot_scatter_vs_initial_error")
    ax = _new_axes(ax)
    finite = np.isfinite(values) & ~failed
    name = label if label is not None else "samples"
    points = ax.scatter(
        angle[finite],
        values[finite],
        s=10,
        alpha=0.7,
        label=_legend_label(name, values, "not settled", failed),
    )
    if not finite.all():
        top = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
        ax.scatter(
            angle[~finite],
            np.full(int((~finite).sum()), 0.97),
            marker="x",
            s=18,
            color=points.get_facecolor()[0] if len(points.get_facecolor()) else None,
            transform=top,
            clip_on=False,
        )
    ax.set_xlabel("initial error angle [deg]")
    ax.set_ylabel(ylabel)
    ax.legend(loc="best", fontsize=8)
    return ax
