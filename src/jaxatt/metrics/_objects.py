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
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._custom_types import RealScalarLike
from .._validation import check_positive
from ..numerics import safe_norm
from ._chattering import chattering
from ._effort import control_effort
from ._settling import convergence_time, settling_time, time_outside


def _axes(axes, ndim: int) -> tuple[int, ...]:
    """Non-time axes to reduce, normalised for a signal with `ndim` axes (time first)."""
    if axes is None:
        return tuple(range(1, ndim))
    axes = (axes,) if isinstance(axes, int) else tuple(axes)
    out = tuple(a % ndim for a in axes)
    if 0 in out:
        raise ValueError("metrics: a norm must not reduce the time axis (axis 0).")
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

    def __call__(self, x):
        x = jnp.asarray(x)
        axes = _axes(self.axes, x.ndim)
        return safe_norm(x, axis=axes) if axes else jnp.abs(x)


class MaxAbs(AbstractNorm):
    """$\\max_i |x_i|$ over `axes` (default: every non-time axis): the infinity norm; NaN
    propagates."""

    axes: int | tuple[int, ...] | None = eqx.field(default=None, static=True)

    def __call__(self, x):
        x = jnp.asarray(x)
        axes = _axes(self.axes, x.ndim)
        return jnp.max(jnp.abs(x), axis=axes) if axes else jnp.abs(x)


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

    @abc.abstractmethod
    def __call__(self, traj) -> Array:
        """The metric of one (unbatched) trajectory."""


def _signal(traj, name: str) -> Array:
    if name not in traj.signals:
        raise ValueError(
            f"metrics: the trajectory has no signal {name!r}; it has {sorted(traj.signals)}."
        )
    return traj.signals[name]


class _AbstractBandTime(AbstractMetric):
    """A time computed from `norm(signal)` and a tolerance band, per component of the norm;
    `inf` for a failed sample. Concrete metrics say which time (`_time`)."""

    signal: str = eqx.field(static=True)
    tolerance: Float[Array, ""]
    norm: AbstractNorm
    failure_value: ClassVar[float] = float("inf")

    def __init__(
        self, signal: str, tolerance: RealScalarLike, norm: AbstractNorm | None = None
    ):
        self.signal = str(signal)
        self.tolerance = check_positive(type(self).__name__, "tolerance", tolerance)
        self.norm = Euclidean() if norm is None else norm

    @abc.abstractmethod
    def _time(self, ts: Array, x: Array) -> Array:
        """The time of one magnitude signal `x` (T,)."""

    def __call__(self, traj) -> Array:
        x = self.norm(_signal(traj, self.signal))
        return _per_component(self._time, traj.ts, x)


class SettlingTime(_AbstractBandTime):
    r"""Exact last exit time of `norm(signal)` from the band $\le$ `tolerance`
    ([`settling_time`][], interpolated): `inf` if the record ends outside; `inf` for a failed
    sample.

    **Arguments:**
    - `signal`: a signal name, e.g. `"attitude_error_vector"`.
    - `tolerance`: the band, in the signal's unit.
    - `norm`: [`Euclidean`][]`()` (default), [`MaxAbs`][]`()`, [`Absolute`][]`()`, ...
    """

    def _time(self, ts, x):
        return settling_time(ts, x, self.tolerance)


class TimeOutside(_AbstractBandTime):
    """Total time `norm(signal)` spends above `tolerance` ([`time_outside`][]); NaN counts as
    outside; `inf` for a failed sample. Arguments as [`SettlingTime`][]."""

    def _time(self, ts, x):
        return time_outside(ts, x, self.tolerance)


class ConvergenceTime(AbstractMetric):
    r"""The continuous, extrapolated convergence time of `norm(signal)`
    ([`convergence_time`][]): the time spent outside the band plus, when the record ends
    outside, the time the measured final decay still needs. The tuning objective's time.

    **Arguments:** as [`SettlingTime`][], and `window`: the span [s] over which the final decay
    rate is measured (default: a tenth of the record).
    """

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
        self.tolerance = check_positive("ConvergenceTime", "tolerance", tolerance)
        self.norm = Euclidean() if norm is None else norm
        if window is not None:
            window = check_positive("ConvergenceTime", "window", window)
        self.window = window

    def __call__(self, traj) -> Array:
        x = self.norm(_signal(traj, self.signal))
        return _per_component(
            lambda ts, v: convergence_time(ts, v, self.tolerance, self.window), traj.ts, x
        )


class Peak(AbstractMetric):
    """$\\max_t$ `norm(signal)(t)`: default [`MaxAbs`][], so `Peak("u")` is the largest
    $|u_i|$ over time and axes. NaN propagates; NaN for a failed sample."""

    signal: str = eqx.field(static=True)
    norm: AbstractNorm

    def __init__(self, signal: str, norm: AbstractNorm | None = None):
        self.signal = str(signal)
        self.norm = MaxAbs() if norm is None else norm

    def __call__(self, traj) -> Array:
        return jnp.max(self.norm(_signal(traj, self.signal)), axis=0)


class Final(AbstractMetric):
    """`norm(signal)` at the last saved time (default [`Euclidean`][]); NaN for a failed
    sample."""

    signal: str = eqx.field(static=True)
    norm: AbstractNorm

    def __init__(self, signal: str, norm: AbstractNorm | None = None):
        self.signal = str(signal)
        self.norm = Euclidean() if norm is None else norm

    def __call__(self, traj) -> Array:
        return self.norm(_signal(traj, self.signal))[-1]


class Effort(AbstractMetric):
    r"""$\int \|u\|^2 dt$ of `signal` (default `"u"`, the applied control; trapezoid rule);
    NaN for a failed sample."""

    signal: str = eqx.field(default="u", static=True)

    def __call__(self, traj) -> Array:
        u = _signal(traj, self.signal)
        return control_effort(traj.ts, u.reshape(u.shape[0], -1))


class Chattering(AbstractMetric):
    r"""Total variation of `signal` (default `"u"`) over $[t_{start}, t_{end}]$
    ([`chattering`][]); NaN for a failed sample."""

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
        self.start = jnp.asarray(start, dtype=jnp.result_type(float))
        self.end = jnp.asarray(end, dtype=jnp.result_type(float))

    def __call__(self, traj) -> Array:
        u = _signal(traj, self.signal)
        return chattering(traj.ts, u.reshape(u.shape[0], -1), self.start, self.end)
