r"""Tuning objectives over a Monte Carlo batch: a convergence time a tuner can trust, aggregated
over the batch (mean, quantile, CVaR, worst case), plus penalties on torque, effort, chattering.

**Convergence time** ([`jaxatt.metrics.convergence_time`][]). For each sample,

$$T_c = t_0 + T_{\mathrm{out}} + \mathbb 1[x(t_1) > \mathrm{tol}]\;
\frac{\ln(x(t_1)/\mathrm{tol})}{\hat\lambda},$$

$T_{\mathrm{out}}$ the time the error magnitude $x$ spends outside the band (linear
interpolation between saved samples) and $\hat\lambda$ the decay rate measured over the last
tenth of the horizon (floored at one e-fold per horizon). It is continuous in the gains (a
late bump adds its duration; it does not jump the result to its end, as the last-exit time
does), continuous across the settled/unsettled boundary, finite for every sample that does
not diverge, and differentiable almost everywhere; for a sample that decays through the band
once it equals the exact last-exit time ([`jaxatt.metrics.settling_time`][], reported as
`settling_time`). Its bias against the sample spacing $\Delta t$ is the linear
interpolation's, at most about $\lambda\Delta t^2/8$ per crossing.

**Trust.** The batch is simulated by the batch runner Monte Carlo uses
([`jaxatt.montecarlo.run_batch`][], same solver, sampling and performance options). A
sample that fails (non-finite state, invalid plant, constraint violation) has `inf`
convergence time, so the loss is `inf` and [`tune`][] stops with an error naming the step; a
diverged sample can never lower the loss.
"""

import abc

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
from jaxtyping import Array, Float, PyTree

from .._validation import (
    check_in_open_interval,
    check_nonnegative,
    check_positive,
    check_shape,
    is_real_scalar,
)
from ..metrics import (
    AbstractMetric,
    AbstractNorm,
    Chattering,
    ConvergenceTime,
    Effort,
    Euclidean,
    Peak,
    SettlingTime,
)
from ..metrics._chattering import holds_save_interval
from ..montecarlo._batch import check_metric_records, run_batch, streamable
from ..numerics import amax
from ..simulation import (
    RK4,
    AbstractClosedLoop,
    AbstractFixedStepSolver,
    AbstractSampling,
    Continuous,
    Performance,
    Simulation,
)


class AbstractAggregate(eqx.Module):
    """Reduces per-sample values (n,) to one number."""

    @abc.abstractmethod
    def __call__(self, values: Float[Array, " n"]) -> Float[Array, ""]:
        """The aggregate."""


class Mean(AbstractAggregate):
    """The batch mean."""

    def __call__(self, values):
        return jnp.mean(values)


class Quantile(AbstractAggregate):
    """The `q`-quantile (linear interpolation), e.g. `Quantile(0.95)`."""

    q: Float[Array, ""]

    def __init__(self, q: float | int):
        self.q = check_in_open_interval(
            "Quantile", "q", check_shape("Quantile", "q", q, ()), 0.0, 1.0
        )

    def __call__(self, values):
        return jnp.quantile(values, self.q)


class CVaR(AbstractAggregate):
    r"""Conditional value at risk: the mean of the worst $(1 - \alpha)$ fraction of the values
    (of the samples; of every sample's every component for a per-component penalty, as
    [`Mean`][] and [`Quantile`][] take them), at least one."""

    alpha: float = eqx.field(static=True)

    def __init__(self, alpha: float | int):
        if not is_real_scalar(alpha) or not 0.0 < float(alpha) < 1.0:
            raise ValueError(f"CVaR: `alpha` must be a number in (0, 1), got {alpha!r}.")
        self.alpha = float(alpha)

    def __call__(self, values):
        values = jnp.ravel(values)
        k = max(1, int(round((1 - self.alpha) * values.size)))
        return jnp.mean(jax.lax.top_k(values, k)[0])


class WorstCase(AbstractAggregate):
    """The batch maximum."""

    def __call__(self, values):
        return amax(values)


def _aggregate(where: str, aggregate: AbstractAggregate | None) -> AbstractAggregate:
    """`aggregate`, `Mean()` if None; anything else is refused with a message."""
    if aggregate is None:
        return Mean()
    if not isinstance(aggregate, AbstractAggregate):
        raise ValueError(
            f"{where}: `aggregate` must be a jaxatt.tune aggregate (Mean(), Quantile(q), "
            f"CVaR(alpha), WorstCase()) or None, got {aggregate!r}."
        )
    return aggregate


SAMPLE_METRICS = (
    "settling_time",
    "objective_time",
    "peak_torque",
    "peak_command",
    "effort",
    "chattering",
    "settled",
    "successful",
    "status",
)

PENALIZED_METRICS = tuple(m for m in SAMPLE_METRICS if m not in ("settled", "successful", "status"))
"""The metrics of `SAMPLE_METRICS` a [`Penalty`][] of a [`SettlingObjective`][] may bound: the
quantities. `settled` and `successful` are flags (a penalty above a bound below 1 would
penalise the samples that settle or succeed) and `status` a code."""


class Penalty(eqx.Module):
    r"""`weight * aggregate(max(0, metric - bound)^2)` over the batch for a per-sample metric.

    `metric` is a key of the objective's per-sample metrics: for a [`SettlingObjective`][]
    `"peak_torque"`, `"peak_command"`, `"effort"` or `"chattering"`; for a
    [`MetricObjective`][] a name of its `limits`. `aggregate` is `Mean()` by default (a soft
    limit: a few samples may exceed the bound if the rest gain from it); `WorstCase()`
    penalises the worst sample, for a bound every sample must respect.
    """

    metric: str = eqx.field(static=True)
    bound: Float[Array, ""]
    weight: Float[Array, ""]
    aggregate: AbstractAggregate

    def __init__(
        self,
        metric: str,
        bound: float | int,
        weight: float | int = 1.0,
        aggregate: AbstractAggregate | None = None,
    ):
        self.metric = metric
        self.bound = check_nonnegative(
            "Penalty", "bound", check_shape("Penalty", "bound", bound, ())
        )
        self.weight = check_positive(
            "Penalty", "weight", check_shape("Penalty", "weight", weight, ())
        )
        self.aggregate = _aggregate("Penalty", aggregate)

    def __call__(self, metrics: dict[str, Array]) -> Float[Array, ""]:
        excess = jax.nn.relu(metrics[self.metric] - self.bound) ** 2
        return self.weight * self.aggregate(excess)


class AbstractObjective(eqx.Module):
    """`objective(module, inputs) -> (loss, aux)`, with a host-side `check(module, inputs)`
    that [`tune`][] runs before compiling anything."""

    @abc.abstractmethod
    def __call__(self, module: PyTree, inputs: PyTree) -> tuple[Array, dict[str, Array]]:
        """The loss and its per-sample metrics."""

    @abc.abstractmethod
    def check(self, module: PyTree, inputs: PyTree) -> None:
        """Raise `ValueError` on inputs that cannot be evaluated (before compiling)."""


class SettlingObjective(AbstractObjective):
    """Aggregate of the convergence time over a batch, plus penalties.

    **Arguments:**
    - `t1`, `dt`: horizon and step of each simulation [s] (static; `t0 = 0` unless given).
    - `tolerance`: the band of the convergence time (on `norm(signal)`).
    - `aggregate`: `Mean()` (default), `Quantile(q)`, `CVaR(alpha)` or `WorstCase()`.
    - `penalties`: [`Penalty`][]s added to the loss.
    - `signal`: the name of the trajectory signal whose convergence is timed; default
      `"attitude_error_vector"` ($e_v$ for quaternion plants, $\\sigma_e$ for MRP plants).
    - `norm`: how the signal is reduced to a magnitude (default
      [`jaxatt.metrics.Euclidean`][]`()`).
    - `chattering_window`: `(start, end)` [s] of the chattering metric (default the last half
      of the horizon, or the whole run when that half holds no save interval): numbers with
      `start < end` that hold at least one save interval of `[t0, t1]` (a window outside the
      run, or between two saves, would make the chattering 0, and its penalty silently
      nothing).
    - `save_every`, `sampling`, `solver`, `performance`, `t0`: as
      [`jaxatt.montecarlo.monte_carlo`][] (the crossing is interpolated between saves).
    - `checkpoint`, `checkpoints`: how reverse mode stores the loop, as
      [`jaxatt.simulation.Simulation`][]'s (`True`: one stored loop state per save;
      `"recursive"`: at most `checkpoints` whatever the horizon; `False`). The metrics are
      reduced on the fly (nothing is saved), so with `"recursive"` the gradient's memory does
      not grow with the horizon.

    Calling it as `objective(closed_loop, x0s)` (a batch of plant states with a leading axis)
    returns `(loss, aux)`, `aux` holding the per-sample metrics of `SAMPLE_METRICS` (the
    metric objects are `sample_metrics`; a failed sample gets `inf` times and NaN otherwise):
    `settling_time` (exact last exit, `inf` if unsettled), `objective_time` (the
    convergence time above), `peak_torque` and `peak_command` (max |u_i|, applied and
    commanded), `effort`, `chattering`, `settled`, `successful`, `status`, and
    `failure_time` (the time [s] of the first failure, `inf` for a successful sample).
    """

    simulation: Simulation
    aggregate: AbstractAggregate
    penalties: tuple[Penalty, ...]
    sample_metrics: dict[str, AbstractMetric]

    def __init__(
        self,
        t1: float | int,
        dt: float | int,
        tolerance: float | int,
        aggregate: AbstractAggregate | None = None,
        penalties: tuple[Penalty, ...] = (),
        signal: str = "attitude_error_vector",
        norm: AbstractNorm | None = None,
        chattering_window: tuple[float, float] | None = None,
        save_every: int = 1,
        *,
        sampling: AbstractSampling = Continuous(),
        solver: AbstractFixedStepSolver | dfx.AbstractSolver = RK4(),
        performance: Performance | None = None,
        t0: float = 0.0,
        checkpoint: bool | str = True,
        checkpoints: int | None = None,
    ):
        where = "SettlingObjective"
        self.simulation = Simulation(
            t0,
            t1,
            dt,
            sampling=sampling,
            solver=solver,
            save_every=save_every,
            checkpoint=checkpoint,
            checkpoints=checkpoints,
            performance=performance,
            where=where,
        )
        tolerance = check_positive(where, "tolerance", tolerance)
        self.aggregate = _aggregate(where, aggregate)
        for p in penalties:
            if not isinstance(p, Penalty) or p.metric not in PENALIZED_METRICS:
                raise ValueError(
                    f"{where}: `penalties` must be Penalty objects on one of "
                    f"{PENALIZED_METRICS}, got {p!r}."
                )
        self.penalties = tuple(penalties)
        if not isinstance(signal, str):
            raise ValueError(
                f"{where}: `signal` must be the name of a trajectory signal (e.g. "
                f"'attitude_error_vector'), got {signal!r}."
            )
        norm = Euclidean() if norm is None else norm
        start, end = _chattering_window(where, chattering_window, self.simulation)
        # Built once, here, from checked values: inside the compiled loss they are plain
        # pytrees (no run-time checks, no host callbacks).
        self.sample_metrics = {
            "settling_time": SettlingTime(signal, tolerance, norm),
            "objective_time": ConvergenceTime(signal, tolerance, norm),
            "peak_torque": Peak("u"),
            "peak_command": Peak("u_cmd"),
            "effort": Effort("u"),
            "chattering": Chattering("u", start, end),
        }

    @property
    def t1(self) -> float:
        return self.simulation.t1

    @property
    def dt(self) -> float:
        return self.simulation.dt

    @property
    def tolerance(self) -> Float[Array, ""]:
        return self.sample_metrics["objective_time"].tolerance

    def check(self, closed_loop: AbstractClosedLoop, x0s: PyTree) -> None:
        _check_batch("SettlingObjective", closed_loop, x0s)

    def batch_metrics(self, closed_loop: AbstractClosedLoop, x0s: PyTree) -> dict[str, Array]:
        """Per-sample metrics over a batch (the leading axis of `x0s`)."""
        metrics = _run_metrics(self.simulation, closed_loop, x0s, self.sample_metrics)
        settling = metrics["settling_time"]
        successful = metrics["successful"].reshape(-1, *(1,) * (settling.ndim - 1))
        metrics["settled"] = successful & jnp.isfinite(settling)
        return metrics

    def __call__(self, closed_loop: AbstractClosedLoop, x0s: PyTree):
        metrics = self.batch_metrics(closed_loop, x0s)
        return _loss(self.aggregate, self.penalties, metrics), metrics


_RESERVED = ("objective_time", "successful", "status", "failure_time")
"""The entries a [`MetricObjective`][] adds to its `aux` (no metric may be named like them)."""


class MetricObjective(AbstractObjective):
    r"""A weighted sum of convergence times (any signals, any norms), aggregated over a batch,
    plus penalties on any per-sample metric: the objective of plants whose performance is
    several error groups and whose limits are several signals (a relative pose: position,
    attitude, velocity and rate; force and torque).

    For each sample, $T = \sum_k T_k$ over the metric objects of `times` (each summed over
    its components, e.g. a [`jaxatt.metrics.ConvergenceTime`][] per error group); the loss is
    `aggregate` of $T$ over the batch plus each [`Penalty`][]'s
    `weight * mean(max(0, metric - bound)^2)` on a metric of `limits`.

    **Arguments:**
    - `t1`, `dt`: horizon and step [s]; `save_every`, `sampling`, `solver`, `performance`,
      `t0`, `checkpoint`, `checkpoints` as [`SettlingObjective`][].
    - `times`: name -> metric object whose value is a time (summed into the objective).
    - `limits`: name -> metric object the `penalties` bound (e.g. `Peak("force")`).
    - `penalties`: [`Penalty`][]s on names of `limits`.
    - `aggregate`: `Mean()` (default), `Quantile(q)`, `CVaR(alpha)`, `WorstCase()`.

    `aux` holds every metric of `times` and `limits` per sample, `objective_time` ($T$),
    `successful`, `status` and `failure_time` [s]. A failed sample (non-finite state, a
    constraint violated) has `inf` times, so the loss is `inf` and [`tune`][] stops (a failure
    never lowers the loss).
    """

    simulation: Simulation
    times: dict[str, AbstractMetric]
    limits: dict[str, AbstractMetric]
    penalties: tuple[Penalty, ...]
    aggregate: AbstractAggregate

    def __init__(
        self,
        t1: float | int,
        dt: float | int,
        times: dict[str, AbstractMetric],
        limits: dict[str, AbstractMetric] | None = None,
        penalties: tuple[Penalty, ...] = (),
        aggregate: AbstractAggregate | None = None,
        save_every: int = 1,
        *,
        sampling: AbstractSampling = Continuous(),
        solver: AbstractFixedStepSolver | dfx.AbstractSolver = RK4(),
        performance: Performance | None = None,
        t0: float = 0.0,
        checkpoint: bool | str = True,
        checkpoints: int | None = None,
    ):
        where = "MetricObjective"
        self.simulation = Simulation(
            t0,
            t1,
            dt,
            sampling=sampling,
            solver=solver,
            save_every=save_every,
            checkpoint=checkpoint,
            checkpoints=checkpoints,
            performance=performance,
            where=where,
        )
        limits = {} if limits is None else dict(limits)
        for label, group in (("times", times), ("limits", limits)):
            if not isinstance(group, dict) or not all(
                isinstance(m, AbstractMetric) for m in group.values()
            ):
                raise ValueError(
                    f"{where}: `{label}` must be a dict name -> jaxatt.metrics metric object, "
                    f"got {group!r}."
                )
        if not times:
            raise ValueError(f"{where}: `times` must name at least one time metric.")
        not_times = sorted(name for name, metric in times.items() if not metric.is_time)
        if not_times:
            # A peak or an effort summed as seconds would be an objective in no unit.
            raise ValueError(
                f"{where}: `times` must hold time metrics (is_time: ConvergenceTime, "
                f"SettlingTime, TimeOutside), got {not_times} (bound those through `limits` "
                "and `penalties`)."
            )
        # One name, one metric: `limits` would replace a time of the same name (the objective
        # would sum the limit's values as seconds), and the objective's own entries of `aux`
        # would replace a metric named like them.
        shared = sorted(set(times) & set(limits))
        reserved = sorted((set(times) | set(limits)) & set(_RESERVED))
        if shared or reserved:
            raise ValueError(
                f"{where}: every metric needs its own name, not shared by `times` and `limits` "
                f"nor one of {_RESERVED}; got "
                + ", ".join(f"{name!r}" for name in shared + reserved)
                + "."
            )
        for p in penalties:
            if not isinstance(p, Penalty) or p.metric not in limits:
                raise ValueError(
                    f"{where}: `penalties` must be Penalty objects on one of the `limits` "
                    f"{sorted(limits)}, got {p!r}."
                )
        check_metric_records(where, times | limits, self.simulation)
        self.times = dict(times)
        self.limits = limits
        self.penalties = tuple(penalties)
        self.aggregate = _aggregate(where, aggregate)

    def check(self, closed_loop: AbstractClosedLoop, x0s: PyTree) -> None:
        _check_batch("MetricObjective", closed_loop, x0s)

    def batch_metrics(self, closed_loop: AbstractClosedLoop, x0s: PyTree) -> dict[str, Array]:
        """Per-sample metrics over a batch (the leading axis of `x0s`)."""
        metrics = _run_metrics(self.simulation, closed_loop, x0s, self.times | self.limits)
        n = _batch_size(x0s)
        metrics["objective_time"] = sum(
            jnp.sum(metrics[name].reshape(n, -1), axis=1) for name in self.times
        )
        return metrics

    def __call__(self, closed_loop: AbstractClosedLoop, x0s: PyTree):
        metrics = self.batch_metrics(closed_loop, x0s)
        return _loss(self.aggregate, self.penalties, metrics), metrics


def _chattering_window(
    where: str, window: tuple[float, float] | None, simulation: Simulation
) -> tuple[float, float]:
    """The checked `(start, end)` of the chattering metric: it must hold at least one save
    interval of the run (else the chattering is 0 whatever the control does, and its penalty
    silently nothing). By default the last half of the run, or the whole run when that half
    holds no save interval (a run saved only at `t0` and `t1`)."""
    t0, t1 = simulation.t0, simulation.t1
    saves = simulation.save_times()
    if window is None:
        start = 0.5 * (t0 + t1)
        return (start if holds_save_interval(saves, start, t1) else t0), t1
    try:
        start, end = (float(v) for v in window)
    except (TypeError, ValueError):
        raise ValueError(
            f"{where}: `chattering_window` must be a pair of numbers (start, end) [s], "
            f"got {window!r}."
        ) from None
    if not (start < end and start < t1 and end > t0):  # False for NaN too
        raise ValueError(
            f"{where}: `chattering_window` must have start < end and overlap the run "
            f"[t0, t1] = [{t0}, {t1}] s, got {window!r}."
        )
    if not holds_save_interval(saves, start, end):
        raise ValueError(
            f"{where}: `chattering_window` {window!r} holds no save interval of the run (saved "
            f"every {saves[1] - saves[0]:g} s from t0 = {t0} s), so the chattering would be 0 "
            "whatever the control; widen it or save more often."
        )
    return start, end


def _loss(
    aggregate: AbstractAggregate, penalties: tuple[Penalty, ...], metrics: dict[str, Array]
) -> Float[Array, ""]:
    """`aggregate` of the objective times plus the penalties; `inf` when any sample failed.

    A failed sample's time is `inf`, but a quantile or a CVaR can rank it out of the loss (the
    median of four samples, one failed, is finite), so the rule is applied to the loss itself:
    whatever the aggregate, a failure never gives a finite loss, and [`tune`][] stops."""
    loss = aggregate(metrics["objective_time"])
    for penalty in penalties:
        loss = loss + penalty(metrics)
    return jnp.where(jnp.all(metrics["successful"]), loss, jnp.inf)


def _check_batch(where: str, closed_loop: AbstractClosedLoop, x0s: PyTree) -> None:
    """The host-side check of both objectives: a closed loop and a valid batch of states."""
    if not isinstance(closed_loop, AbstractClosedLoop):
        raise ValueError(
            f"{where}: the tuned module must be a jaxatt closed loop, got "
            f"{type(closed_loop).__name__}."
        )
    closed_loop.check_state(x0s, "inputs", (_batch_size(x0s),))


def _run_metrics(
    simulation: Simulation, closed_loop: AbstractClosedLoop, x0s: PyTree, metrics: dict
) -> dict[str, Array]:
    """Per-sample `metrics` plus `successful`, `status` and `failure_time` [s], from the Monte
    Carlo batch runner with the performance options resolved for the batch size, reduced on the
    fly when every metric streams (as [`jaxatt.montecarlo.monte_carlo`][] does: the same
    values, no saved trajectory to store or to differentiate through; else from the saved
    trajectory)."""
    sim = simulation.with_performance(simulation.performance.resolve(_batch_size(x0s)))
    result = run_batch(closed_loop, x0s, sim, metrics, stream=streamable(metrics))
    out = dict(result.metrics)
    out["successful"] = result.successful
    out["status"] = result.status
    out["failure_time"] = result.failure_time
    return out


def _batch_size(tree: PyTree) -> int:
    leaves = jtu.tree_leaves(tree)
    if not leaves or jnp.ndim(leaves[0]) == 0:
        raise ValueError("tune: the batch of initial states must have a leading batch axis.")
    return int(jnp.shape(leaves[0])[0])
