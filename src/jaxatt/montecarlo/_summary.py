r"""`MonteCarloResult`: per-sample metrics and outcomes of a batch, and their summaries.

Summaries are computed on the host with NumPy (they are reports, not part of a compiled
computation). Conventions, for every metric:

- a sample **failed** when its simulation did not succeed (`result != RESULTS.successful`:
  a non-finite state or a controller's constraint violation); its metric values are kept but
  never enter the statistics;
- statistics (mean, std, min, max, quantiles) are over the **successful samples whose metric
  is finite**; a settling time of `inf` (not settled within the horizon) is excluded from them
  and counted in `nonfinite`;
- the **worst case** counts failed and non-finite samples as $+\infty$ (larger is worse, as
  for settling times, torques and efforts);
- the **success rate** is the fraction of all samples that are successful, have a finite
  metric and, when `time_limit` is given, a metric $\le$ `time_limit`.
"""

import math
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool

from ..metrics import settling_time
from ..numerics import safe_norm
from ..simulation import RESULTS, Trajectory


def to_host(x) -> np.ndarray:
    """A NumPy copy of a (possibly sharded, possibly multi-host) array."""
    if isinstance(x, jax.Array) and not x.is_fully_addressable:
        from jax.experimental import multihost_utils

        x = multihost_utils.process_allgather(x, tiled=True)
    return np.asarray(x)


def _json_float(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _json_safe(tree):
    if isinstance(tree, dict):
        return {k: _json_safe(v) for k, v in tree.items()}
    if isinstance(tree, (list, tuple)):
        return [_json_safe(v) for v in tree]
    if isinstance(tree, float):
        return _json_float(tree)
    return tree


def _check_quantiles(quantiles: Sequence[float]) -> tuple[float, ...]:
    quantiles = tuple(float(q) for q in quantiles)
    if not all(0.0 <= q <= 1.0 for q in quantiles):
        raise ValueError(
            f"MonteCarloResult.summary: `quantiles` must lie in [0, 1], got {quantiles}."
        )
    return quantiles


@jax.jit
def _settling_times(ts: Array, error: Array, tolerance: Array) -> Array:
    vector = error[..., 1:] if error.shape[-1] == 4 else error
    return jax.vmap(lambda t, e: settling_time(t, safe_norm(e), tolerance))(ts, vector)


class MonteCarloResult(eqx.Module):
    """The outcome of [`monte_carlo`][]: per-sample metrics, results and (optionally) trajectories.

    - `metrics`: metric name -> array of shape `(n,)`, one value per sample (see
      [`default_metrics`][]).
    - `result`: per-sample [`jaxatt.RESULTS`][] (`successful`, `nonfinite_state`,
      `constraint_violated`), shape `(n,)`.
    - `trajectories`: the batched [`jaxatt.Trajectory`][] when `keep_trajectories=True`,
      else `None`.

    See this module's docstring for how failures, non-finite values, the worst case and the
    success rate are counted.
    """

    metrics: dict[str, Array]
    result: RESULTS
    trajectories: Trajectory | None = None

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.result._value.shape[0])

    @property
    def successful(self) -> Bool[Array, " n"]:
        """Per-sample `result == RESULTS.successful`."""
        return self.result == RESULTS.successful

    def result_counts(self) -> dict[str, int]:
        """Number of samples per [`jaxatt.RESULTS`][] outcome, by name."""
        codes = to_host(self.result._value)
        return {
            name: int(np.sum(codes == item._value)) for name, item in RESULTS._name_to_item.items()
        }

    def _values(self, metric: str, tolerance: float | None) -> np.ndarray:
        if tolerance is None:
            if metric not in self.metrics:
                raise ValueError(
                    f"MonteCarloResult: `metric` must be one of {sorted(self.metrics)}, got "
                    f"{metric!r}."
                )
            values = to_host(self.metrics[metric])
            if values.shape != (self.n,):
                raise ValueError(
                    f"MonteCarloResult: metric {metric!r} has shape {values.shape}; summaries "
                    f"need one scalar per sample, shape ({self.n},)."
                )
            return values.astype(float)
        if metric != "settling_time":
            raise ValueError(
                "MonteCarloResult.summary: `tolerance` recomputes the settling time of the "
                f"attitude error, so `metric` must be 'settling_time', got {metric!r}."
            )
        if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance)) or tolerance <= 0:
            raise ValueError(
                f"MonteCarloResult.summary: `tolerance` must be positive, got {tolerance!r}."
            )
        if self.trajectories is None:
            raise ValueError(
                "MonteCarloResult.summary: `tolerance` needs the trajectories; run "
                "monte_carlo(..., keep_trajectories=True), or compute the settling time at "
                "that tolerance in `metrics=`."
            )
        traj = self.trajectories
        return to_host(
            _settling_times(traj.ts, traj.signals["attitude_error"], jnp.asarray(tolerance))
        ).astype(float)

    def summary(
        self,
        metric: str = "settling_time",
        *,
        tolerance: float | None = None,
        time_limit: float | None = None,
        quantiles: Sequence[float] = (0.05, 0.5, 0.95),
    ) -> dict:
        r"""Distribution of one metric over the batch.

        **Arguments:**
        - `metric`: a key of `metrics`.
        - `tolerance`: optional settling tolerance (unit of the attitude error: $\|e_v\|$ for
          quaternions, $\|\sigma_e\|$ for MRPs). When given, `metric` must be
          `"settling_time"` and the settling time is recomputed at this tolerance from the
          kept trajectories (`keep_trajectories=True`; their save interval sets the
          resolution).
        - `time_limit`: optional bound [unit of the metric, s for times]: a sample counts as a
          success only if its metric is $\le$ `time_limit`.
        - `quantiles`: probabilities in [0, 1] at which to report quantiles (NumPy's linear
          interpolation).

        **Returns:** a dict: `metric`, `count` (samples), `failed` (unsuccessful results),
        `results` (count per outcome), `nonfinite` (successful samples whose metric is
        inf/NaN, e.g. not settled), `finite`, `mean`, `std` (sample standard deviation,
        `ddof=1`), `min`, `max`, `quantiles` ({probability: value}), `worst` (failed and
        non-finite count as inf), `worst_index`, `success_rate`, `tolerance`, `time_limit`.
        Statistics of an empty selection are NaN.
        """
        quantiles = _check_quantiles(quantiles)
        if time_limit is not None:
            if not isinstance(time_limit, (int, float)) or math.isnan(time_limit):
                raise ValueError(
                    f"MonteCarloResult.summary: `time_limit` must be a number, got {time_limit!r}."
                )
        values = self._values(metric, tolerance)
        ok = to_host(self.successful).astype(bool)
        finite = ok & np.isfinite(values)
        selected = values[finite]
        worst_values = np.where(finite, values, np.inf)
        worst_index = int(np.argmax(worst_values))
        success = finite if time_limit is None else finite & (values <= time_limit)

        def stat(fn, minimum=1):
            return float(fn(selected)) if selected.size >= minimum else math.nan

        return {
            "metric": metric,
            "count": self.n,
            "failed": int(np.sum(~ok)),
            "results": self.result_counts(),
            "nonfinite": int(np.sum(ok & ~np.isfinite(values))),
            "finite": int(np.sum(finite)),
            "mean": stat(np.mean),
            "std": stat(lambda v: np.std(v, ddof=1), minimum=2),
            "min": stat(np.min),
            "max": stat(np.max),
            "quantiles": {
                q: (float(np.quantile(selected, q)) if selected.size else math.nan)
                for q in quantiles
            },
            "worst": float(worst_values[worst_index]),
            "worst_index": worst_index,
            "success_rate": float(np.mean(success)),
            "tolerance": tolerance,
            "time_limit": time_limit,
        }

    def to_dict(
        self, *, time_limit: float | None = None, quantiles: Sequence[float] = (0.05, 0.5, 0.95)
    ) -> dict:
        """A JSON-ready summary of every scalar metric (non-finite numbers become `None`).

        `{"count", "failed", "results", "metrics": {name: summary(name, ...)}}`; `time_limit`
        applies to `settling_time` only. Quantile keys become strings.
        """
        out: dict = {
            "count": self.n,
            "failed": int(np.sum(~to_host(self.successful))),
            "results": self.result_counts(),
            "metrics": {},
        }
        for name in self.metrics:
            limit = time_limit if name == "settling_time" else None
            summary = self.summary(name, time_limit=limit, quantiles=quantiles)
            summary["quantiles"] = {str(q): v for q, v in summary["quantiles"].items()}
            out["metrics"][name] = summary
        return _json_safe(out)

    def table(
        self,
        metrics: Sequence[str] | None = None,
        *,
        time_limit: float | None = None,
        quantiles: Sequence[float] = (0.05, 0.5, 0.95),
    ) -> str:
        """A Markdown table, one row per metric (default: all): count, failed, not finite,
        mean, std, quantiles, worst and success rate (`time_limit` applies to
        `settling_time`)."""
        names = list(self.metrics) if metrics is None else list(metrics)
        rows = {
            name: self.summary(
                name,
                time_limit=time_limit if name == "settling_time" else None,
                quantiles=quantiles,
            )
            for name in names
        }
        return _markdown(rows, "metric", quantiles)


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
        cells += [s["worst"], f"{100 * s['success_rate']:.1f} %"]
        lines.append("| " + " | ".join(_fmt(c) for c in cells) + " |")
    return "\n".join(lines)


def summary_table(
    results: Mapping[str, MonteCarloResult],
    metric: str = "settling_time",
    *,
    tolerance: float | None = None,
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
        name: r.summary(metric, tolerance=tolerance, time_limit=time_limit, quantiles=quantiles)
        for name, r in results.items()
    }
    return _markdown(rows, "batch", quantiles)
