r"""Tuning objectives over a Monte Carlo batch: a differentiable convergence time, aggregated
over the batch (mean, quantile, CVaR, worst case), plus penalties on torque and chattering.

**Convergence time.** For each sample, $T$ is the last exit time of $\|x(t)\|$ from the band
$\|x\| \le \text{tol}$, interpolated between saved samples (`jaxatt.metrics.settling_time`).
Its gradient is the implicit-function derivative of the interpolated crossing, which equals
the finite-difference derivative of the same time wherever the crossing is transversal and
its sample index does not change (tested). A sample that has not settled by $t_1$ gets
$t_1 + \ln(x(t_1)/\text{tol})$ instead, continuous with the settled branch and still
decreasing as the sample gets closer to settling, so the objective is finite and its gradient
informative for every sample.
"""

import abc
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._validation import check_in_open_interval, check_nonnegative, check_positive
from ..metrics import chattering, control_effort, peak, settling_time
from ..numerics import safe_norm
from ..simulation import ClosedLoop, Trajectory, simulate


def attitude_error_norm(traj: Trajectory) -> Float[Array, " T"]:
    """$\\|e_v\\|$ (quaternion error vector part) or $\\|\\sigma_e\\|$ (MRP error)."""
    error = traj.signals["attitude_error"]
    vector = error[..., 1:] if error.shape[-1] == 4 else error
    return safe_norm(vector)


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
        self.q = check_in_open_interval("Quantile", "q", q, 0.0, 1.0)

    def __call__(self, values):
        return jnp.quantile(values, self.q)


class CVaR(AbstractAggregate):
    r"""Conditional value at risk: the mean of the worst $(1 - \alpha)$ fraction of samples."""

    alpha: float = eqx.field(static=True)

    def __init__(self, alpha: float | int):
        if not 0.0 < alpha < 1.0:
            raise ValueError(f"CVaR: `alpha` must lie in (0, 1), got alpha={alpha}.")
        self.alpha = float(alpha)

    def __call__(self, values):
        k = max(1, int(round((1 - self.alpha) * values.shape[0])))
        return jnp.mean(jax.lax.top_k(values, k)[0])


class WorstCase(AbstractAggregate):
    """The batch maximum."""

    def __call__(self, values):
        return jnp.max(values)


class Penalty(eqx.Module):
    r"""`weight * mean(max(0, metric - bound)^2)` over the batch for a per-sample metric.

    `metric` is a key of [`SettlingObjective.sample_metrics`][]: `"peak_torque"`,
    `"peak_command"`, `"effort"` or `"chattering"`.
    """

    metric: str = eqx.field(static=True)
    bound: Float[Array, ""]
    weight: Float[Array, ""]

    def __init__(self, metric: str, bound: float | int, weight: float | int = 1.0):
        self.metric = metric
        self.bound = check_nonnegative("Penalty", "bound", bound)
        self.weight = check_positive("Penalty", "weight", weight)

    def __call__(self, metrics: dict[str, Array]) -> Float[Array, ""]:
        return self.weight * jnp.mean(jax.nn.relu(metrics[self.metric] - self.bound) ** 2)


SAMPLE_METRICS = (
    "settling_time",
    "objective_time",
    "peak_torque",
    "peak_command",
    "effort",
    "chattering",
    "settled",
    "successful",
)


class SettlingObjective(eqx.Module):
    """Aggregate of a differentiable convergence time over a batch, plus penalties.

    **Arguments:**
    - `t1`, `dt`: horizon and step of each simulation [s] (static; `t0 = 0`).
    - `tolerance`: the band of the convergence time (on `signal`).
    - `aggregate`: `Mean()` (default), `Quantile(q)`, `CVaR(alpha)` or `WorstCase()`.
    - `penalties`: [`Penalty`][]s added to the loss.
    - `signal`: `traj -> (T,)` magnitude whose settling is timed; default
      [`attitude_error_norm`][].
    - `chattering_window`: `(start, end)` [s] of the chattering metric (default the last
      half of the horizon).
    - `save_every`: saved steps (the crossing is interpolated between saves).

    Calling it as `objective(closed_loop, x0s)` (a batch of plant states with a leading axis)
    returns `(loss, aux)`, `aux` holding per-sample metrics for reports.
    """

    t1: float = eqx.field(static=True)
    dt: float = eqx.field(static=True)
    tolerance: Float[Array, ""]
    aggregate: AbstractAggregate
    penalties: tuple[Penalty, ...]
    signal: Callable = eqx.field(static=True)
    chattering_window: tuple[float, float] = eqx.field(static=True)
    save_every: int = eqx.field(static=True)

    def __init__(
        self,
        t1: float | int,
        dt: float | int,
        tolerance: float | int,
        aggregate: AbstractAggregate | None = None,
        penalties: tuple[Penalty, ...] = (),
        signal: Callable = attitude_error_norm,
        chattering_window: tuple[float, float] | None = None,
        save_every: int = 1,
    ):
        if not (t1 > 0 and dt > 0):
            raise ValueError(f"SettlingObjective: need t1 > 0 and dt > 0, got t1={t1}, dt={dt}.")
        self.t1, self.dt = float(t1), float(dt)
        self.tolerance = check_positive("SettlingObjective", "tolerance", tolerance)
        self.aggregate = Mean() if aggregate is None else aggregate
        for p in penalties:
            if not isinstance(p, Penalty) or p.metric not in SAMPLE_METRICS:
                raise ValueError(
                    f"SettlingObjective: `penalties` must be Penalty objects on one of "
                    f"{SAMPLE_METRICS}, got {p!r}."
                )
        self.penalties = tuple(penalties)
        self.signal = signal
        window = (0.5 * t1, t1) if chattering_window is None else chattering_window
        self.chattering_window = (float(window[0]), float(window[1]))
        self.save_every = int(save_every)

    def sample_metrics(self, closed_loop: ClosedLoop, x0) -> dict[str, Array]:
        """Simulate one sample and compute its metrics (differentiable)."""
        traj = simulate(
            closed_loop, x0, 0.0, self.t1, dt=self.dt, save_every=self.save_every, throw=False
        )
        x = self.signal(traj)
        time = settling_time(traj.ts, x, self.tolerance)
        settled = jnp.isfinite(time)
        excess = jnp.log(jnp.maximum(x[-1], self.tolerance) / self.tolerance)
        objective_time = jnp.where(settled, time, self.t1 + excess)
        u = traj.signals["u"]
        return {
            "settling_time": time,
            "objective_time": objective_time,
            "peak_torque": peak(u),
            "peak_command": peak(traj.signals["u_cmd"]),
            "effort": control_effort(traj.ts, u),
            "chattering": chattering(traj.ts, u, *self.chattering_window),
            "settled": settled,
            "successful": traj.successful,
        }

    def batch_metrics(self, closed_loop: ClosedLoop, x0s) -> dict[str, Array]:
        """Per-sample metrics over a batch (vmap over the leading axis of `x0s`)."""
        return jax.vmap(lambda x0: self.sample_metrics(closed_loop, x0))(x0s)

    def __call__(self, closed_loop: ClosedLoop, x0s) -> tuple[Array, dict[str, Array]]:
        metrics = self.batch_metrics(closed_loop, x0s)
        loss = self.aggregate(metrics["objective_time"])
        for penalty in self.penalties:
            loss = loss + penalty(metrics)
        return loss, metrics
