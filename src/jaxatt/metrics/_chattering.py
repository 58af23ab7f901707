"""Chattering: the total variation of a sampled control signal."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Real

from .._custom_types import RealScalarLike, Scalar
from .._validation import check, check_less_than, is_traced
from ._signals import as_signal, as_times


# A sample time within WINDOW_ULPS * eps * max(1, |b|) seconds of a window bound b counts as on
# the bound: save times t0 + i * dt land an ulp or two off the bound they were meant to hit.
WINDOW_ULPS = 8


def _eps(x) -> float:
    dtype = jnp.result_type(x)
    if not jnp.issubdtype(dtype, jnp.floating):
        dtype = jnp.result_type(float)
    return float(jnp.finfo(dtype).eps)


def in_window(t_from: Array, t_to: Array, start: Array, end: Array) -> Array:
    r"""Whether the sample interval $[t_k, t_{k+1}]$ lies inside the window $[t_s, t_e]$ [s]:

    $$t_k \ge t_s - \delta(t_s),\quad t_{k+1} \le t_e + \delta(t_e),\qquad
    \delta(b) = 8\,\varepsilon \max(1, |b|),$$

    with $\varepsilon$ the machine epsilon of the coarsest dtype among the times and bounds,
    so a sample time rounded a few ulps off a bound counts as on it. An
    infinite bound admits everything on its side; a NaN bound admits nothing. The trajectory
    and streaming forms of the chattering metric share it, so they select the same intervals.
    """
    eps = max(_eps(t_from), _eps(t_to), _eps(start), _eps(end))
    slack_start = WINDOW_ULPS * eps * jnp.maximum(1.0, jnp.abs(start))
    slack_end = WINDOW_ULPS * eps * jnp.maximum(1.0, jnp.abs(end))
    return (t_from >= start - slack_start) & (t_to <= end + slack_end)


def holds_save_interval(ts, start, end) -> bool:
    """Whether the window `[start, end]` [s] holds at least one interval between two of the
    save times `ts` (host side, before compiling): else the chattering over it is 0 whatever
    the control does (a window past the horizon, or between two saves)."""
    ts = jnp.asarray(ts, dtype=jnp.result_type(float))
    bounds = (jnp.asarray(b, ts.dtype) for b in (start, end))
    return bool(jnp.any(in_window(ts[:-1], ts[1:], *bounds)))


def window_bound(where: str, name: str, value: RealScalarLike | None, default: float) -> Array:
    """A window bound [s]: a scalar, not NaN when concrete; `default` for `None`."""
    if value is None:
        return jnp.asarray(default)
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{where}: `{name}` must be a number or None, got {value!r}.")
    arr = jnp.asarray(value)
    if arr.ndim != 0:
        raise ValueError(f"{where}: `{name}` must be a scalar, got shape {arr.shape}.")
    if not is_traced(arr):
        check(where, name, arr, lambda xp, x: ~xp.isnan(x), "must not be NaN")
    return arr


@jax.jit
def _chattering(ts: Array, u: Array, start: Array, end: Array) -> Array:
    inside = in_window(ts[:-1], ts[1:], start, end)
    increments = jnp.sum(jnp.abs(jnp.diff(u, axis=0)), axis=-1)
    return jnp.sum(jnp.where(inside, increments, 0.0))


def chattering(
    ts: Real[ArrayLike, " T"],
    u: Float[ArrayLike, "T m"],
    t_start: RealScalarLike | None = None,
    t_end: RealScalarLike | None = None,
) -> Scalar:
    r"""Total variation of the control inside a time window.

    $$\mathrm{TV} = \sum_{k:\ t_{\mathrm{start}} \le t_k,\ t_{k+1} \le t_{\mathrm{end}}}
    \|u_{k+1} - u_k\|_1 .$$

    A smooth control sampled finely has a total variation close to $\int \|\dot u\|_1\,dt$,
    independent of the step; a switching (chattering) control adds about twice its amplitude per
    sign change, so the value grows with the number of switches. Restrict the window to the
    steady state (e.g. `t_start` after the settling time) to measure chattering rather than the
    transient.

    **Window ends and rounding.** A sample time within $8\,\varepsilon \max(1, |b|)$ seconds of
    a bound $b$ counts as on it ($\varepsilon$ the machine epsilon of the times' dtype, or of
    the bounds' if coarser): save times $t_0 + i\,\Delta t$ land an ulp or two off the bound
    they were meant to hit (`0 + 70 * 0.01 = 0.7000000000000001`), and a window `(t1 / 2, t1)`
    keeps the last interval of a record that ends at `t1`.

    The window is a mask over sample pairs (static shapes), so `t_start`/`t_end` may be traced
    (`jit`, `vmap`).

    **Arguments:**
    - `ts`: sample times [s], shape `(T,)`, non-decreasing.
    - `u`: control, shape `(T, m)`, e.g. torque [N m].
    - `t_start`: window start [s], a scalar, not NaN; `None` means from the first sample.
    - `t_end`: window end [s], a scalar, not NaN, greater than `t_start`; `None` means to the
      last sample. Concrete bounds are checked (`ValueError`); traced ones are not (a NaN
      bound then selects nothing).

    **Returns:** a scalar in the unit of `u` (0 if the window holds fewer than two samples).

    **Gradients:** with respect to `u`, the sign pattern of the increments (JAX takes
    `d|x|/dx = 1` at `x = 0`, finite). With respect to `t_start`/`t_end` it is 0: the window
    only selects samples.
    """
    where = "chattering"
    u = as_signal(where, "u", u, 2, " For a single input pass u[:, None].")
    ts = as_times(where, ts, "u", u)
    start = window_bound(where, "t_start", t_start, -jnp.inf)
    end = window_bound(where, "t_end", t_end, jnp.inf)
    if t_start is not None and t_end is not None:
        check_less_than(where, "t_start", start, "t_end", end)
    return _chattering(ts, u, start, end)
