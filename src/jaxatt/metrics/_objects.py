r"""Metrics as objects: a named signal, a norm, and a reduction over time.

A metric object names the signal it reads (`traj.signals[name]`) and says how to reduce it,
so a metric works on any plant's signals (scalar, per-axis, per-agent) without guessing what a
shape means. Tolerances and windows are array fields, so changing them does not recompile.

```python
metrics = {
    "settling_time": SettlingTime("attitude_error_vector", 1e-3),          # ||e_v|| < 1e-3
    "settling_time_inf": SettlingTime("attitude_error_vector", 1e-3, MaxAbs()),  # max|e_i|
    "per_agent": SettlingTime("position_error", 1e-2, Euclidean(axes=-1)), # one per agent
    "peak_torque": Peak("u"),
    "effort": Effort("u"),
}
```

Every metric declares the value a **failed** sample gets (`failure_value`): `inf` for times,
NaN for everything else. The batch runner writes it in place of the computed value for every
sample whose simulation did not succeed, so a diverged sample can never look like the best
one.

**Streaming.** Every metric here can also be reduced *on the fly*, one saved sample at a time,
without the trajectory ever being stored: `stream_init(t, signals, t_last)` on the first
sample (`t_last` is the time of the last one), `stream_update(state, t, signals)` on each
following sample in time order, `stream_value(state)` at the end. The result equals
`metric(traj)` on the trajectory of those samples to round-off (the only difference is the
order of a sum). [`jaxatt.montecarlo.monte_carlo`][] streams by default; a metric that sets
`streams = False` (the default of [`AbstractMetric`][]) is reduced from the saved trajectory.
"""

import abc
from typing import TYPE_CHECKING, ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, PyTree

from .._custom_types import RealScalarLike
from .._validation import check_less_than, check_positive_scalar
from ..numerics import amax, maximum, safe_norm
from ._chattering import chattering, holds_save_interval, in_window, window_bound
from ._effort import control_effort
from ._settling import convergence_time, decay_extrapolation, settling_time, time_outside


if TYPE_CHECKING:  # annotations only: jaxatt.simulation imports this module
    from ..simulation import Trajectory


def _check_axes(where: str, axes) -> int | tuple[int, ...] | None:
    """`axes` as a norm stores it: `None`, an integer, or a tuple of distinct integers."""
    if axes is None:
        return None
    listed = (axes,) if not isinstance(axes, (tuple, list)) else tuple(axes)
    if not listed or not all(isinstance(a, int) and not isinstance(a, bool) for a in listed):
        raise ValueError(
            f"{where}: `axes` must be None, an integer or a non-empty tuple of integers, "
            f"got {axes!r}."
        )
    if len(set(listed)) != len(listed):
        raise ValueError(f"{where}: `axes` must not repeat an axis, got {axes!r}.")
    return axes if isinstance(axes, int) else listed


def _axes(where: str, axes, ndim: int) -> tuple[int, ...]:
    """Non-time axes to reduce, normalised for a signal with `ndim` axes (time first). An axis
    outside `[-ndim, ndim)` is refused (never wrapped onto another axis)."""
    if axes is None:
        return tuple(range(1, ndim))
    axes = (axes,) if isinstance(axes, int) else tuple(axes)
    for a in axes:
        if not -ndim <= a < ndim:
            raise ValueError(
                f"{where}: axis {a} of `axes` is out of range for a signal with {ndim} axes "
                f"(time first); valid axes are 1..{ndim - 1} or {1 - ndim}..-1."
            )
    out = tuple(a % ndim for a in axes)
    if 0 in out:
        raise ValueError(f"{where}: a norm must not reduce the time axis (axis 0).")
    if len(set(out)) != len(out):
        raise ValueError(f"{where}: `axes` {axes!r} name the same axis twice.")
    return out


class AbstractNorm(eqx.Module):
    """Reduces a signal of shape `(T, ...)` to magnitudes `(T,)` or `(T, k...)`."""

    @abc.abstractmethod
    def __call__(self, x: Float[Array, "T ..."]) -> Float[Array, "T ..."]:
        """Magnitudes; time stays the leading axis."""


class Euclidean(AbstractNorm):
    """$\\|x\\|_2$ over `axes` (default: every non-time axis); NaN propagates.

    `Euclidean(axes=-1)` on a `(T, n_agents, 3)` signal gives one magnitude per agent.
    """

    axes: int | tuple[int, ...] | None = eqx.field(default=None, static=True)

    def __init__(self, axes: int | tuple[int, ...] | None = None):
        self.axes = _check_axes("Euclidean", axes)

    def __call__(self, x):
        x = jnp.asarray(x)
        axes = _axes("Euclidean", self.axes, x.ndim)
        return safe_norm(x, axis=axes) if axes else jnp.abs(x)


class MaxAbs(AbstractNorm):
    """$\\max_i |x_i|$ over `axes` (default: every non-time axis): the infinity norm; NaN
    propagates."""

    axes: int | tuple[int, ...] | None = eqx.field(default=None, static=True)

    def __init__(self, axes: int | tuple[int, ...] | None = None):
        self.axes = _check_axes("MaxAbs", axes)

    def __call__(self, x):
        x = jnp.asarray(x)
        axes = _axes("MaxAbs", self.axes, x.ndim)
        return amax(jnp.abs(x), axis=axes) if axes else jnp.abs(x)


class Absolute(AbstractNorm):
    """$|x_i|$ per component: no reduction (one metric value per component)."""

    def __call__(self, x):
        return jnp.abs(jnp.asarray(x))


def _per_component(fn, ts: Array, x: Array) -> Array:
    """Apply a `(ts, (T,)) -> scalar` reduction to every component of `(T, ...)`."""
    if x.ndim == 1:
        return fn(ts, x)
    flat = x.reshape(x.shape[0], -1)
    out = jax.vmap(lambda column: fn(ts, column), in_axes=1)(flat)
    return out.reshape(x.shape[1:])


class AbstractMetric(eqx.Module):
    """A reduction of a trajectory to a number (or one number per component).

    `__call__(traj) -> Array`; `failure_value` is what a failed sample reports.
    """

    failure_value: ClassVar[float] = float("nan")
    worst: ClassVar[str] = "largest"
    """Which end of the metric's distribution is the worst case, `"largest"` (times, peaks,
    efforts) or `"smallest"` (margins); read by [`jaxatt.montecarlo.MonteCarloResult`][]'s
    summaries."""
    is_time: ClassVar[bool] = False
    """Whether the value is a time [s]: a summary's `time_limit` applies to it."""
    streams: ClassVar[bool] = False
    """Whether the metric implements the streaming protocol (`stream_init`, `stream_update`,
    `stream_value`); if not, batch runners reduce a saved trajectory with `__call__`."""

    @abc.abstractmethod
    def __call__(self, traj: "Trajectory") -> Array:
        """The metric of one (unbatched) trajectory."""

    def check_record(self, where: str, name: str, ts: Float[ArrayLike, " T"]) -> None:
        """Raise a `ValueError` if the metric cannot measure a record saved at the times `ts`
        [s] (a NumPy array, known before compiling); the batch runners' entry points call it.
        By default every record will do."""

    def stream_init(self, t: Array, signals: dict[str, Array], t_last: Array) -> PyTree:
        """The running state after the first sample `signals` at time `t` (one trajectory);
        `t_last` is the time of the last sample that will be streamed."""
        raise NotImplementedError(f"{type(self).__name__} has no streaming form.")

    def stream_update(self, state: PyTree, t: Array, signals: dict[str, Array]) -> PyTree:
        """The running state after one more sample, at time `t` (after the previous one)."""
        raise NotImplementedError(f"{type(self).__name__} has no streaming form.")

    def stream_value(self, state: PyTree) -> Array:
        """The metric from the running state after the last sample: equal to `__call__` on
        the trajectory of the streamed samples, up to the order of a sum."""
        raise NotImplementedError(f"{type(self).__name__} has no streaming form.")


def _signal(traj, name: str) -> Array:
    if name not in traj.signals:
        raise ValueError(
            f"metrics: the trajectory has no signal {name!r}; it has {sorted(traj.signals)}."
        )
    return traj.signals[name]


def _sample(signals: dict, name: str) -> Array:
    """One sample of a signal (no time axis), from a dict of signals at one time."""
    if name not in signals:
        raise ValueError(
            f"metrics: the trajectory has no signal {name!r}; it has {sorted(signals)}."
        )
    return jnp.asarray(signals[name])


def _magnitude(norm: AbstractNorm, signals: dict, name: str) -> Array:
    """`norm` of one sample: the norm of a one-sample record, time axis dropped."""
    return norm(_sample(signals, name)[None])[0]


def _outside(x: Array, tol: Array) -> Array:
    return ~(x <= tol)  # NaN counts as outside


def _crossing_in(t_prev, x_prev, t, x, tol) -> Array:
    """Time of the downward crossing of `tol` between two samples (the interpolation of
    [`settling_time`][]); the later time when `x_prev` is not finite. Double where: the
    denominator of a non-crossing never enters the graph."""
    interpolate = _outside(x_prev, tol) & ~_outside(x, tol) & jnp.isfinite(x_prev)
    safe_prev = jnp.where(interpolate, x_prev, 1.0)
    safe_x = jnp.where(interpolate, x, 0.0)
    safe_tol = jnp.where(interpolate, tol, 0.5)
    fraction = (safe_prev - safe_tol) / (safe_prev - safe_x)
    return jnp.where(interpolate, t_prev + fraction * (t - t_prev), t)


def _outside_fraction(x_prev, x, tol) -> Array:
    """Fraction of the interval between two samples spent above `tol` ([`time_outside`][])."""
    above_prev, above = _outside(x_prev, tol), _outside(x, tol)
    a, b = x_prev - tol, x - tol
    one_side = above_prev != above
    crossing = one_side & jnp.isfinite(a) & jnp.isfinite(b)
    numerator = jnp.where(crossing, jnp.where(a > 0, a, b), 0.0)
    denominator = jnp.where(crossing, jnp.abs(a) + jnp.abs(b), 1.0)
    whole = jnp.where((above_prev & above) | one_side, 1.0, 0.0)
    return jnp.where(crossing, numerator / denominator, whole)


class _AbstractBandTime(AbstractMetric):
    """A time computed from `norm(signal)` and a tolerance band, per component of the norm;
    `inf` for a failed sample. Concrete metrics say which time (`_time`)."""

    is_time: ClassVar[bool] = True

    signal: str = eqx.field(static=True)
    tolerance: Float[Array, ""]
    norm: AbstractNorm
    failure_value: ClassVar[float] = float("inf")

    def __init__(self, signal: str, tolerance: RealScalarLike, norm: AbstractNorm | None = None):
        self.signal = str(signal)
        where = type(self).__name__
        self.tolerance = check_positive_scalar(where, "tolerance", tolerance)
        self.norm = Euclidean() if norm is None else norm

    @abc.abstractmethod
    def _time(self, ts: Array, x: Array) -> Array:
        """The time of one magnitude signal `x` (T,)."""

    def __call__(self, traj) -> Array:
        x = self.norm(_signal(traj, self.signal))
        return _per_component(self._time, traj.ts, x)

    def _x(self, signals) -> Array:
        return _magnitude(self.norm, signals, self.signal)


class SettlingTime(_AbstractBandTime):
    r"""Exact last exit time of `norm(signal)` from the band $\le$ `tolerance`
    ([`settling_time`][], interpolated): `inf` if the record ends outside; `inf` for a failed
    sample.

    **Arguments:**
    - `signal`: a signal name, e.g. `"attitude_error_vector"`.
    - `tolerance`: the band, in the signal's unit: a positive scalar (one band for every
      component; checked at construction).
    - `norm`: [`Euclidean`][]`()` (default), [`MaxAbs`][]`()`, [`Absolute`][]`()`, ...
    """

    streams: ClassVar[bool] = True

    def _time(self, ts, x):
        return settling_time(ts, x, self.tolerance)

    # Running state: the last sample and the settling time of the record so far (the
    # interpolated last entry into the band; inf while outside; t0 if never outside).
    def stream_init(self, t, signals, t_last):
        x = self._x(signals)
        dtype = jnp.result_type(t, x)
        settled_at = jnp.where(_outside(x, self.tolerance), jnp.inf, t).astype(dtype)
        return t, x, settled_at

    def stream_update(self, state, t, signals):
        t_prev, x_prev, settled_at = state
        x = self._x(signals)
        entering = _outside(x_prev, self.tolerance) & ~_outside(x, self.tolerance)
        crossing = _crossing_in(t_prev, x_prev, t, x, self.tolerance)
        new = jnp.where(
            _outside(x, self.tolerance), jnp.inf, jnp.where(entering, crossing, settled_at)
        )
        return t, x, new.astype(settled_at.dtype)

    def stream_value(self, state):
        return state[2]


class TimeOutside(_AbstractBandTime):
    """Total time `norm(signal)` spends above `tolerance` ([`time_outside`][]); NaN counts as
    outside; `inf` for a failed sample. Arguments as [`SettlingTime`][]."""

    streams: ClassVar[bool] = True

    def _time(self, ts, x):
        return time_outside(ts, x, self.tolerance)

    def stream_init(self, t, signals, t_last):
        x = self._x(signals)
        return t, x, jnp.zeros_like(x, dtype=jnp.result_type(t, x))

    def stream_update(self, state, t, signals):
        t_prev, x_prev, total = state
        x = self._x(signals)
        step = _outside_fraction(x_prev, x, self.tolerance) * (t - t_prev)
        return t, x, (total + step).astype(total.dtype)

    def stream_value(self, state):
        return state[2]


class ConvergenceTime(AbstractMetric):
    r"""The continuous, extrapolated convergence time of `norm(signal)`
    ([`convergence_time`][]): the time spent outside the band plus, when the record ends
    outside, the time the measured final decay still needs. The tuning objective's time.

    **Arguments:** as [`SettlingTime`][], and `window`: the span [s] over which the final decay
    rate is measured, a positive scalar (default: a tenth of the record; one longer than the
    record measures the rate over the whole record).
    """

    is_time: ClassVar[bool] = True

    signal: str = eqx.field(static=True)
    tolerance: Float[Array, ""]
    norm: AbstractNorm
    window: Float[Array, ""] | None
    failure_value: ClassVar[float] = float("inf")

    def __init__(
        self,
        signal: str,
        tolerance: RealScalarLike,
        norm: AbstractNorm | None = None,
        window: RealScalarLike | None = None,
    ):
        self.signal = str(signal)
        where = "ConvergenceTime"
        self.tolerance = check_positive_scalar(where, "tolerance", tolerance)
        self.norm = Euclidean() if norm is None else norm
        if window is not None:
            window = check_positive_scalar(where, "window", window)
        self.window = window

    streams: ClassVar[bool] = True

    def __call__(self, traj) -> Array:
        x = self.norm(_signal(traj, self.signal))
        return _per_component(
            lambda ts, v: convergence_time(ts, v, self.tolerance, self.window), traj.ts, x
        )

    # Running state: t0, the decay-window target time, the time outside so far, the last
    # sample, and the sample closest to the target (the first such, never the last sample:
    # as [`convergence_time`][]'s argmin clipped to T - 2).
    def stream_init(self, t, signals, t_last):
        x = _magnitude(self.norm, signals, self.signal)
        dtype = jnp.result_type(t, x)
        window = 0.1 * (t_last - t) if self.window is None else self.window
        target = t_last - window
        distance = jnp.where(t < t_last, jnp.abs(t - target), jnp.inf)
        zero = jnp.zeros_like(x, dtype=dtype)
        return t, t_last, target, t, x, zero, distance, x, t

    def stream_update(self, state, t, signals):
        t0, t_last, target, t_prev, x_prev, outside, best, x_k, t_k = state
        x = _magnitude(self.norm, signals, self.signal)
        outside = outside + _outside_fraction(x_prev, x, self.tolerance) * (t - t_prev)
        distance = jnp.where(t < t_last, jnp.abs(t - target), jnp.inf)
        closer = distance < best
        return (
            t0,
            t_last,
            target,
            t,
            x,
            outside.astype(state[5].dtype),
            jnp.where(closer, distance, best),
            jnp.where(closer, x, x_k),
            jnp.where(closer, t, t_k),
        )

    def stream_value(self, state):
        t0, _, _, t_end, last, outside, _, x_k, t_k = state
        remaining, diverged = decay_extrapolation(
            x_k, last, t_end - t_k, t_end - t0, self.tolerance
        )
        total = t0 + outside + remaining
        return jnp.where(diverged, jnp.inf, total).astype(outside.dtype)


class Peak(AbstractMetric):
    """$\\max_t$ `norm(signal)(t)`: default [`MaxAbs`][], so `Peak("u")` is the largest
    $|u_i|$ over time and axes. NaN propagates; NaN for a failed sample."""

    signal: str = eqx.field(static=True)
    norm: AbstractNorm

    def __init__(self, signal: str, norm: AbstractNorm | None = None):
        self.signal = str(signal)
        self.norm = MaxAbs() if norm is None else norm

    streams: ClassVar[bool] = True

    def __call__(self, traj) -> Array:
        return amax(self.norm(_signal(traj, self.signal)), axis=0)

    def stream_init(self, t, signals, t_last):
        return _magnitude(self.norm, signals, self.signal)

    def stream_update(self, state, t, signals):
        return maximum(state, _magnitude(self.norm, signals, self.signal))  # NaN stays

    def stream_value(self, state):
        return state


class Final(AbstractMetric):
    """`norm(signal)` at the last saved time (default [`Euclidean`][]); NaN for a failed
    sample."""

    signal: str = eqx.field(static=True)
    norm: AbstractNorm

    def __init__(self, signal: str, norm: AbstractNorm | None = None):
        self.signal = str(signal)
        self.norm = Euclidean() if norm is None else norm

    streams: ClassVar[bool] = True

    def __call__(self, traj) -> Array:
        return self.norm(_signal(traj, self.signal))[-1]

    def stream_init(self, t, signals, t_last):
        return _magnitude(self.norm, signals, self.signal)

    def stream_update(self, state, t, signals):
        return _magnitude(self.norm, signals, self.signal)

    def stream_value(self, state):
        return state


class Effort(AbstractMetric):
    r"""$\int \|u\|^2 dt$ of `signal` (default `"u"`, the applied control; trapezoid rule);
    NaN for a failed sample."""

    signal: str = eqx.field(default="u", static=True)

    streams: ClassVar[bool] = True

    def __call__(self, traj) -> Array:
        u = _signal(traj, self.signal)
        return control_effort(traj.ts, u.reshape(u.shape[0], -1))

    def _power(self, signals) -> Array:
        u = _sample(signals, self.signal).reshape(-1)
        return jnp.sum(u * u)

    # Streaming state after sample k: (t_{k-1}, t_k, p_k, sum_{j<k} w_j p_j) with the trapezoid
    # weights w_j = (t_{j+1} - t_{j-1}) / 2 (t_{-1} = t_0). Each new power p is only carried,
    # and enters the sum one sample later: with the fresh p used twice (carried *and* added,
    # as `total + (p + p_prev) dt / 2` does) a Monte Carlo streaming only this metric ran at
    # 0.90x the sparsest save at batch 1000 on XLA:CPU, against 1.05x this way
    # (benchmarks/README.md, issue 18).
    def stream_init(self, t, signals, t_last):
        power = self._power(signals)
        return t, t, power, jnp.zeros((), jnp.result_type(t, power))

    def stream_update(self, state, t, signals):
        t_before, t_prev, power_prev, total = state
        weighted = total + 0.5 * (t - t_before) * power_prev
        return t_prev, t, self._power(signals), weighted.astype(total.dtype)

    def stream_value(self, state):
        t_before, t_last, power_last, total = state
        return total + 0.5 * (t_last - t_before) * power_last


class Chattering(AbstractMetric):
    r"""Total variation of `signal` (default `"u"`) over $[t_{start}, t_{end}]$
    ([`chattering`][]); NaN for a failed sample.

    The sum runs over the sample intervals $[t_k, t_{k+1}]$ with $t_k \ge t_{start}$ and
    $t_{k+1} \le t_{end}$, where a sample time within $8\,\varepsilon \max(1, |b|)$ seconds
    of a bound $b$ counts as on it ($\varepsilon$ the machine epsilon of the times' dtype),
    so a window ending at `t1` keeps the last interval of a record whose last save time
    rounded to `t1 + 1 ulp`. The streaming form selects the same intervals.

    **Arguments:**
    - `signal`: a signal name (default `"u"`).
    - `start`, `end`: the window [s], scalars, not NaN, `start < end` (infinite ends allowed:
      the defaults take the whole record). Checked at construction.
    """

    signal: str = eqx.field(static=True)
    start: Float[Array, ""]
    end: Float[Array, ""]

    def __init__(
        self,
        signal: str = "u",
        start: RealScalarLike = -float("inf"),
        end: RealScalarLike = float("inf"),
    ):
        self.signal = str(signal)
        dtype = jnp.result_type(float)
        self.start = window_bound("Chattering", "start", start, -jnp.inf).astype(dtype)
        self.end = window_bound("Chattering", "end", end, jnp.inf).astype(dtype)
        check_less_than("Chattering", "start", self.start, "end", self.end)

    streams: ClassVar[bool] = True

    def __call__(self, traj) -> Array:
        u = _signal(traj, self.signal)
        return chattering(traj.ts, u.reshape(u.shape[0], -1), self.start, self.end)

    def check_record(self, where, name, ts) -> None:
        """The window must hold at least one interval between two save times: else the value
        is 0 whatever the control does (a window past the horizon, or between two saves)."""
        if not holds_save_interval(ts, self.start, self.end):
            ts = jnp.asarray(ts)
            raise ValueError(
                f"{where}: the window [{float(self.start)}, {float(self.end)}] s of the "
                f"Chattering metric {name!r} holds no interval between two save times of the "
                f"run ({float(ts[0])} to {float(ts[-1])} s, saved every "
                f"{float(ts[1] - ts[0]):g} s), so it would be 0 whatever the control; widen "
                "it or save more often."
            )

    def stream_init(self, t, signals, t_last):
        u = _sample(signals, self.signal).reshape(-1)
        return t, u, jnp.zeros((), jnp.result_type(t, u))

    def stream_update(self, state, t, signals):
        t_prev, u_prev, total = state
        u = _sample(signals, self.signal).reshape(-1)
        inside = in_window(t_prev, t, self.start, self.end)
        step = jnp.where(inside, jnp.sum(jnp.abs(u - u_prev)), 0.0)
        return t, u, (total + step).astype(total.dtype)

    def stream_value(self, state):
        return state[2]
