r"""Intermittent communication: sample schedules and zero-order-held links.

A link transmits a value only at the sampling instants $t_0 < t_1 < \dots$ and the receiver
holds the last sample: $\hat v(t) = v(t_i)$ for $t \in [t_i, t_{i+1})$, with intervals
$h_i = t_{i+1} - t_i \in (0, \tau]$ (Duan et al. 2024 write $\tau(t) = t - t_i \in [0,\tau)$).

The link follows the core's discrete-update lifecycle: `init(t0, value)` takes the first
sample, `update(t, value, state)` runs after every completed integration step (a controller's
`update` hook under continuous control) and takes a new sample when $t$ has reached the next
sampling instant. The schedule's intervals are whole multiples of its `step`, which must be
the integration step `dt`, so every sampling instant is a step boundary: the instants are
exact, and between them the held value is exactly constant.
"""

import math

import equinox as eqx
import jax.numpy as jnp
import jax.random as jr
import jax.tree_util as jtu
import numpy as np
from jaxtyping import Array, Float, PyTree

from .._custom_types import RealScalarLike
from .._validation import check_instance, check_positive_int, describe
from ._types import MatrixLike, as_float


class SampleSchedule(eqx.Module):
    r"""The intervals $h_0, h_1, \dots$ between sampling instants, repeated cyclically.

    **Arguments:**
    - `intervals`: $h_i > 0$ [s], each a whole multiple of `step` (to 1e-9 relative).
    - `step`: the time grid [s] on which sampling instants lie; simulate with `dt = step`.

    Build one with [`SampleSchedule.periodic`][] ($h_i = h$) or [`SampleSchedule.random`][]
    ($h_i$ uniform on the grid points of $(0, \tau]$). After the last interval the schedule
    starts again from the first, so a schedule never runs out (and every interval stays
    $\le \max h_i$).
    """

    intervals: Float[Array, " n"]
    step: float = eqx.field(static=True)

    def __init__(self, intervals: MatrixLike, step: float):
        where = "SampleSchedule"
        step = float(step)
        if not (math.isfinite(step) and step > 0):
            raise ValueError(f"{where}: `step` must be positive, got step={step!r}.")
        h = as_float(intervals, "intervals", where)
        if h.ndim != 1 or h.shape[0] < 1:
            raise ValueError(
                f"{where}: `intervals` must be a non-empty vector, got shape {h.shape}."
            )
        host = np.asarray(h)
        if not np.all(np.isfinite(host) & (host > 0)):
            raise ValueError(
                f"{where}: `intervals` must be positive (sampling intervals in (0, tau]), "
                f"got {describe(host)}."
            )
        ratio = host / step
        if np.any(np.abs(ratio - np.round(ratio)) > 1e-9 * np.maximum(1.0, ratio)):
            raise ValueError(
                f"{where}: `intervals` must be whole multiples of `step`={step} (sampling "
                f"instants on the integration grid), got {describe(host)}."
            )
        self.intervals = h
        self.step = step

    @classmethod
    def periodic(cls, period: float, step: float) -> "SampleSchedule":
        """Periodic sampling, $h_i = $ `period` [s] (a whole multiple of `step`)."""
        period = float(period)
        if not (math.isfinite(period) and period > 0):
            raise ValueError(
                f"SampleSchedule.periodic: `period` must be positive, got period={period!r}."
            )
        return cls(jnp.asarray([period]), step)

    @classmethod
    def random(cls, key: Array, tau: float, step: float, count: int = 4096) -> "SampleSchedule":
        r"""`count` intervals $h_i = m_i\,$`step`, $m_i$ uniform on $\{1, \dots,
        \lfloor\tau/\text{step}\rfloor\}$: the grid version of $h_i \sim U(0, \tau]$."""
        where = "SampleSchedule.random"
        tau, step = float(tau), float(step)
        if not (math.isfinite(tau) and tau > 0):
            raise ValueError(f"{where}: `tau` must be positive, got tau={tau!r}.")
        if not (math.isfinite(step) and step > 0):
            raise ValueError(f"{where}: `step` must be positive, got step={step!r}.")
        count = check_positive_int(where, "count", count)  # 2.5 was truncated to 2
        slots = int(math.floor(tau / step * (1 + 1e-12)))
        if slots < 1:
            raise ValueError(f"{where}: `tau` must be at least `step`, got tau={tau}, step={step}.")
        m = jr.randint(key, (count,), 1, slots + 1)
        return cls(m.astype(jnp.result_type(float)) * step, step)

    @property
    def max_interval(self) -> float:
        r"""$\max_i h_i$ [s] (the $\tau$ this schedule respects)."""
        return float(np.max(np.asarray(self.intervals)))

    def instants(self, t0: float, t1: float) -> np.ndarray:
        """The sampling instants in $[t_0, t_1]$, starting with $t_0$ (host-side, float64)."""
        h = np.asarray(self.intervals, dtype=float)
        times = [float(t0)]
        i = 0
        while True:
            nxt = times[-1] + h[i % len(h)]
            if nxt > t1 + 0.5 * self.step:
                return np.asarray(times)
            times.append(nxt)
            i += 1

    def intervals_over(self, t0: float, t1: float) -> np.ndarray:
        """The intervals that start in $[t_0, t_1)$ (host-side)."""
        h = np.asarray(self.intervals, dtype=float)
        count = len(self.instants(t0, t1))
        return h[np.arange(count) % len(h)]


class LinkState(eqx.Module):
    """A held sample, the next sampling instant and the number of samples taken (floats, so
    the fixed-step solvers can carry them with a zero derivative)."""

    held: PyTree[Array]
    next_time: Float[Array, ""]
    count: Float[Array, ""]


class SampledLink(eqx.Module):
    r"""A zero-order-held communication link driven by a [`SampleSchedule`][].

    `init(t0, value)` samples at $t_0$; `update(t, value, state)` samples when
    $t \ge t_{next} - \text{step}/2$ (the half step absorbs the rounding of the grid times)
    and schedules the next instant $t_{next} + h_i$. Between samples the state is constant
    (its continuous derivative is zero: `zero_derivative`).
    """

    schedule: SampleSchedule

    def __check_init__(self):
        # Another object failed later, inside the closed loop, with an AttributeError.
        check_instance("SampledLink", "schedule", self.schedule, SampleSchedule, "a SampleSchedule")

    def init(self, t0: RealScalarLike, value: PyTree[Array]) -> LinkState:
        dtype = jnp.result_type(*jtu.tree_leaves(value))
        t0 = jnp.asarray(t0, dtype)
        h = self.schedule.intervals.astype(dtype)
        return LinkState(value, t0 + h[0], jnp.ones((), dtype))

    def update(self, t: RealScalarLike, value: PyTree[Array], state: LinkState) -> LinkState:
        h = self.schedule.intervals.astype(state.next_time.dtype)
        due = t >= state.next_time - 0.5 * self.schedule.step
        index = state.count.astype(jnp.int32) % h.shape[0]
        held = jtu.tree_map(lambda new, old: jnp.where(due, new, old), value, state.held)
        return LinkState(
            held,
            jnp.where(due, state.next_time + h[index], state.next_time),
            state.count + due.astype(state.count.dtype),
        )

    @staticmethod
    def zero_derivative(state: LinkState) -> LinkState:
        """The continuous derivative of a link state: zero (it changes only at samples)."""
        return jtu.tree_map(jnp.zeros_like, state)
