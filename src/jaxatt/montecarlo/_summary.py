r"""`MonteCarloResult`: per-sample metrics and outcomes of a batch, and their summaries.

Summaries are computed on the host with NumPy (they are reports, not part of a compiled
computation). Conventions, for every metric:

- a sample **failed** when its simulation did not succeed (`status != Status.successful`: a
  non-finite state, an invalid plant, or a controller's constraint violation); its metric
  values are the metrics' failure values (`inf` for times, NaN otherwise), it is counted in
  `failed` and never enters the statistics;
- statistics (mean, std, min, max) are over the **successful samples whose metric is
  finite**; a settling time of `inf` (not settled within the horizon) is excluded from them
  and counted in `nonfinite`;
- **quantiles** are over every sample, a failed or non-finite one counting as the worst
  possible value (as in the worst case): the median settling time of a batch where most
  samples did not settle is `inf`, never the median of the few that did;
- the **worst case** is the largest value (settling times, torques, efforts) or, for a metric
  whose smallest value is its worst (a margin: [`jaxatt.performance.MinimumMargin`][], whose
  `worst` is `"smallest"`), the smallest; failed and non-finite samples count as the worst
  possible value ($+\infty$, or $-\infty$ for a margin);
- the **success rate** is the fraction of all samples that are successful, have a finite
  metric and, when `time_limit` is given, a metric $\le$ `time_limit`.

A metric with one value per component (e.g. per agent, or per axis with an
[`jaxatt.metrics.Absolute`][] norm) is summarised per component: pass `component=k`, or let
[`MonteCarloResult.table`][] and [`MonteCarloResult.to_dict`][] expand it.
"""

import math
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from .._json import json_safe
from .._text import percent
from ..simulation import Status, Trajectory


def to_host(x) -> np.ndarray:
    """A NumPy copy of a (possibly sharded, possibly multi-host) array."""
    if isinstance(x, jax.Array) and not x.is_fully_addressable:
        from jax.experimental import multihost_utils

        x = multihost_utils.process_allgather(x, tiled=True)
    return np.asarray(x)


def _check_quantiles(quantiles: Sequence[float]) -> tuple[float, ...]:
    quantiles = tuple(float(q) for q in quantiles)
    if not all(0.0 <= q <= 1.0 for q in quantiles):
        raise ValueError(
            f"MonteCarloResult.summary: `quantiles` must lie in [0, 1], got {quantiles}."
        )
    return quantiles


class MonteCarloResult(eqx.Module):
    """The outcome of [`monte_carlo`][] (and of [`run_batch`][]).

    - `metrics`: metric name -> array of shape `(n,)` (or `(n, k...)` for a metric with one
      value per component); failed samples hold the metric's failure value.
    - `status`: per-sample [`jaxatt.simulation.Status`][] codes, shape `(n,)`.
    - `failure_time`: per-sample time [s] of the first failure (`inf` when successful).
    - `trajectories`: the batched [`jaxatt.Trajectory`][] when `keep_trajectories=True`,
      else `None`.
    - `smallest_is_worst`: the names of the metrics whose worst case is their smallest value
      (the metric objects' `worst`; [`run_batch`][] fills it).
    - `time_metrics`: the names of the metrics that are times [s] (the metric objects'
      `is_time`: settling times, times outside a band, convergence times), to which the
      summaries' `time_limit` applies; [`run_batch`][] fills it.

    See this module's docstring for how failures, non-finite values, the worst case and the
    success rate are counted.
    """

    metrics: dict[str, Array]
    status: Int[Array, " n"]
    failure_time: Float[Array, " n"]
    trajectories: Trajectory | None = None
    smallest_is_worst: tuple[str, ...] = eqx.field(default=(), static=True)
    time_metrics: tuple[str, ...] = eqx.field(default=(), static=True)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(np.shape(self.status)[0])

    @property
    def successful(self) -> Bool[Array, " n"]:
        """Per-sample `status == Status.successful`."""
        return self.status == int(Status.successful)

    def status_counts(self) -> dict[str, int]:
        """Number of samples per [`jaxatt.simulation.Status`][], by name."""
        codes = to_host(self.status)
        return {status.name: int(np.sum(codes == int(status))) for status in Status}

    def _values(self, metric: str, component) -> np.ndarray:
        if metric not in self.metrics:
            raise ValueError(
                f"MonteCarloResult: `metric` must be one of {sorted(self.metrics)}, got {metric!r}."
            )
        values = to_host(self.metrics[metric])
        if values.shape[:1] != (self.n,):
            raise ValueError(
                f"MonteCarloResult: metric {metric!r} has shape {values.shape}; its leading "
                f"axis must be the batch ({self.n},)."
            )
        if values.ndim > 1:
            if component is None:
                raise ValueError(
                    f"MonteCarloResult: metric {metric!r} has one value per component (shape "
                    f"{values.shape[1:]} per sample); pass `component=` (an index) to "
                    "summarise one of them."
                )
            index = component if isinstance(component, tuple) else (component,)
            values = values[(slice(None), *index)]
        elif component is not None:
            raise ValueError(
                f"MonteCarloResult: metric {metric!r} is a scalar per sample; "
                f"`component` must be None, got {component!r}."
            )
        return values.astype(float)

    def summary(
        self,
        metric: str = "settling_time",
        *,
        component: int | tuple[int, ...] | None = None,
        time_limit: float | None = None,
        quantiles: Sequence[float] = (0.05, 0.5, 0.95),
        worst: str | None = None,
    ) -> dict:
        r"""Distribution of one metric over the batch.

        **Arguments:**
        - `metric`: a key of `metrics`.
        - `component`: for a metric with one value per component, which one.
        - `time_limit`: optional bound [unit of the metric, s for times]: a sample counts as a
          success only if its metric is $\le$ `time_limit`.
        - `quantiles`: probabilities in [0, 1] at which to report quantiles (NumPy's linear
          interpolation).
        - `worst`: `"largest"` or `"smallest"`, which end is the worst case; default the
          metric's own (`"smallest"` for the names in `smallest_is_worst`, else `"largest"`).

        **Returns:** a dict: `metric`, `count` (samples), `failed` (unsuccessful samples),
        `status` (count per outcome), `nonfinite` (successful samples whose metric is
        inf/NaN, e.g. not settled), `finite`, `mean`, `std` (sample standard deviation,
        `ddof=1`), `min`, `max` (these four over the finite values), `quantiles`
        ({probability: value}, over every sample), `worst` (in both, failed and non-finite
        samples count as the worst possible value, inf or -inf), `worst_index`,
        `worst_is` (`"largest"` or `"smallest"`), `success_rate`, `time_limit`. Statistics of
        an empty selection are NaN.

        To summarise a settling time at another tolerance, record it as another metric
        (`SettlingTime(signal, tol)`), or compute it from the kept trajectories.
        """
        quantiles = _check_quantiles(quantiles)
        if time_limit is not None:
            if (
                isinstance(time_limit, bool)  # True would be a limit of 1 s
                or not isinstance(time_limit, (int, float))
                or math.isnan(time_limit)
            ):
                raise ValueError(
                    f"MonteCarloResult.summary: `time_limit` must be a number, got {time_limit!r}."
                )
        if worst is None:
            worst = "smallest" if metric in self.smallest_is_worst else "largest"
        if worst not in ("largest", "smallest"):
            raise ValueError(
                "MonteCarloResult.summary: `worst` must be 'largest', 'smallest' or None, "
                f"got {worst!r}."
            )
        if self.n == 0:
            # No worst sample, no success rate: NumPy's argmax raised "empty sequence".
            raise ValueError(
                "MonteCarloResult.summary: the result has no samples (`status` has shape "
                "(0,)); there is nothing to summarise."
            )
        values = self._values(metric, component)
        ok = to_host(self.successful).astype(bool)
        finite = ok & np.isfinite(values)
        selected = values[finite]
        if worst == "largest":
            worst_values = np.where(finite, values, np.inf)
            worst_index = int(np.argmax(worst_values))
        else:
            worst_values = np.where(finite, values, -np.inf)
            worst_index = int(np.argmin(worst_values))
        success = finite if time_limit is None else finite & (values <= time_limit)

        def stat(fn, minimum=1):
            return float(fn(selected)) if selected.size >= minimum else math.nan

        return {
            "metric": metric if component is None else f"{metric}{list(np.atleast_1d(component))}",
            "count": self.n,
            "failed": int(np.sum(~ok)),
            "status": self.status_counts(),
            "nonfinite": int(np.sum(ok & ~np.isfinite(values))),
            "finite": int(np.sum(finite)),
            "mean": stat(np.mean),
            "std": stat(lambda v: np.std(v, ddof=1), minimum=2),
            "min": stat(np.min),
            "max": stat(np.max),
            "quantiles": {q: _quantile(values, finite, q, worst) for q in quantiles},
            "worst": float(worst_values[worst_index]),
            "worst_index": worst_index,
            "worst_is": worst,
            "success_rate": float(np.mean(success)),
            "time_limit": time_limit,
        }

    def _is_time(self, metric: str) -> bool:
        return metric == "settling_time" or metric in self.time_metrics

    def _rows(self, metrics: Sequence[str] | None) -> list[tuple[str, str, tuple | None]]:
        """(label, metric, component) for every metric, components expanded."""
        names = list(self.metrics) if metrics is None else list(metrics)
        rows = []
        for name in names:
            shape = np.shape(self.metrics[name])[1:] if name in self.metrics else ()
            if not shape:
                rows.append((name, name, None))
                continue
            for index in np.ndindex(shape):
                label = f"{name}[{', '.join(map(str, index))}]"
                rows.append((label, name, index))
        return rows

    def to_dict(
        self, *, time_limit: float | None = None, quantiles: Sequence[float] = (0.05, 0.5, 0.95)
    ) -> dict:
        """A JSON-ready summary of every metric (non-finite numbers become `None`).

        `{"count", "failed", "status", "metrics": {label: summary(...)}}`, one entry per
        component for metrics with several; `time_limit` [s] applies to the time metrics
        (`time_metrics`, and a metric named `settling_time`). Quantile keys become strings.
        """
        out: dict = {
            "count": self.n,
            "failed": int(np.sum(~to_host(self.successful))),
            "status": self.status_counts(),
            "metrics": {},
        }
        for label, name, index in self._rows(None):
            limit = time_limit if self._is_time(name) else None
            summary = self.summary(name, component=index, time_limit=limit, quantiles=quantiles)
            summary["quantiles"] = {str(q): v for q, v in summary["quantiles"].items()}
            out["metrics"][label] = summary
        return json_safe(out)

    def table(
        self,
        metrics: Sequence[str] | None = None,
        *,
        time_limit: float | None = None,
        quantiles: Sequence[float] = (0.05, 0.5, 0.95),
    ) -> str:
        """A Markdown table, one row per metric (and component; default: all): count, failed,
        not finite, mean, std, quantiles, worst and success rate (`time_limit` [s] applies to
        the time metrics, as in [`to_dict`][jaxatt.montecarlo.MonteCarloResult.to_dict])."""
        rows = {
            label: self.summary(
                name,
                component=index,
                time_limit=time_limit if self._is_time(name) else None,
                quantiles=quantiles,
            )
            for label, name, index in self._rows(metrics)
        }
        return _markdown(rows, "metric", quantiles)


def _quantile(values: np.ndarray, finite: np.ndarray, q: float, worst: str) -> float:
    """The `q`-quantile (NumPy's linear interpolation) of `values` with every entry that is not
    `finite` (failed or non-finite) at the worst end: `inf` (`-inf` for `worst="smallest"`)
    wherever the interpolation reaches one. (`np.quantile` itself gives NaN next to an
    infinite value, even with a weight of 0.)"""
    n, count = values.size, int(np.sum(finite))
    position = (n - 1) * q
    below, above = math.floor(position), math.ceil(position)
    if worst == "largest" and above >= count:
        return math.inf
    if worst == "smallest" and below < n - count:
        return -math.inf
    # Both neighbours are finite values: the worst entries, replaced by the finite extreme on
    # their side, keep their places in the sorted order without entering the interpolation.
    fill = np.max(values[finite]) if worst == "largest" else np.min(values[finite])
    return float(np.quantile(np.where(finite, values, fill), q))


def _fmt(value) -> str:
    if isinstance(value, float):
        if math.isnan(value):
            return "-"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return f"{value:.4g}"
    return str(value)


def _markdown(rows: Mapping[str, dict], first: str, quantiles: Sequence[float]) -> str:
    header = [first, "n", "failed", "not finite", "mean", "std"]
    header += [f"q{100 * q:g}" for q in quantiles]
    header += ["worst", "success"]
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    for name, s in rows.items():
        cells = [name, s["count"], s["failed"], s["nonfinite"], s["mean"], s["std"]]
        cells += [s["quantiles"][q] for q in quantiles]
        cells += [s["worst"], percent(s["success_rate"])]
        lines.append("| " + " | ".join(_fmt(c) for c in cells) + " |")
    return "\n".join(lines)


def summary_table(
    results: Mapping[str, MonteCarloResult],
    metric: str = "settling_time",
    *,
    component: int | tuple[int, ...] | None = None,
    time_limit: float | None = None,
    quantiles: Sequence[float] = (0.05, 0.5, 0.95),
) -> str:
    """A Markdown table comparing one metric across several batches (e.g. controllers).

    **Arguments:** `results` maps a row label to a [`MonteCarloResult`][]; the rest as
    [`MonteCarloResult.summary`][].

    **Returns:** the table as a string (display it with `IPython.display.Markdown`).
    """
    quantiles = _check_quantiles(quantiles)
    rows = {
        name: r.summary(metric, component=component, time_limit=time_limit, quantiles=quantiles)
        for name, r in results.items()
    }
    return _markdown(rows, "batch", quantiles)
