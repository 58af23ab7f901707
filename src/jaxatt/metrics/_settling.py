"""Settling (convergence) time of a sampled magnitude signal: exact and smooth.

[`settling_time`][] is the last exit time from the tolerance band, interpolated linearly between
samples, so that it is continuous in the data and has a useful gradient (the implicit-function
derivative of the crossing). [`soft_settling_time`][] is a smooth surrogate for optimization.
[`itae`][] and [`iae`][] are the classical integral criteria.
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Real

from .._custom_types import BoolScalar, RealScalarLike, Scalar
from .._validation import check_positive_scalar
from ..numerics import maximum
from ._signals import as_signal, as_times, trapezoid


def _last_above(x: Array, tol: Array) -> tuple[Array, Array]:
    """Index of the last sample outside the band (NaN counts as outside) and whether one exists."""
    outside = ~(x <= tol)
    n = x.shape[0]
    k = n - 1 - jnp.argmax(outside[::-1])
    return jax.lax.stop_gradient(k), jnp.any(outside)


@jax.jit
def _settling_time(ts: Array, x: Array, tol: Array) -> Array:
    n = x.shape[0]
    k, any_outside = _last_above(x, tol)
    k1 = jnp.minimum(k + 1, n - 1)
    x_k, x_k1 = x[k], x[k1]
    t_k, t_k1 = ts[k], ts[k1]
    interior = any_outside & (k < n - 1)
    # Inside the interior branch x_k > tol >= x_k1, so the denominator is positive. Elsewhere it
    # may be 0 (k = T - 1) or inf/NaN: the double where keeps those out of the backward pass.
    interpolate = interior & jnp.isfinite(x_k)
    safe_x_k = jnp.where(interpolate, x_k, 1.0)
    safe_x_k1 = jnp.where(interpolate, x_k1, 0.0)
    safe_tol = jnp.where(interpolate, tol, 0.5)
    fraction = (safe_x_k - safe_tol) / (safe_x_k - safe_x_k1)
    crossing = jnp.where(interpolate, t_k + fraction * (t_k1 - t_k), t_k1)
    dtype = jnp.result_type(ts, x)
    result = jnp.where(any_outside, jnp.where(interior, crossing, jnp.inf), ts[0])
    return result.astype(dtype)


def settling_time(
    ts: Real[ArrayLike, " T"], x: Float[ArrayLike, " T"], tol: RealScalarLike
) -> Scalar:
    r"""Last exit time of the magnitude `x` from the band $x \le \mathrm{tol}$.

    The time after which `x` stays within `tol` for the rest of the record. With $k$ the last
    index such that $x_k > \mathrm{tol}$, the crossing is linearly interpolated between samples
    $k$ and $k + 1$:

    $$t_s = t_k + \frac{x_k - \mathrm{tol}}{x_k - x_{k+1}}\,(t_{k+1} - t_k).$$

    - If no sample exceeds `tol`, $t_s = t_0$ (`ts[0]`).
    - If the last sample still exceeds `tol` (the signal has not settled within the record),
      $t_s = +\infty$; test for it with [`settled`][] or `jnp.isfinite`.
    - A signal that leaves the band and re-enters it counts from its **last** exit.
    - A NaN sample counts as outside the band; if $x_k$ is not finite the crossing is taken at
      $t_{k+1}$ (nothing to interpolate).

    Samples need not be uniformly spaced. Works under `jit`, `vmap` (the caller adds the batch
    axis) and `grad`.

    **Arguments:**
    - `ts`: sample times [s], shape `(T,)`, non-decreasing.
    - `x`: non-negative magnitude, shape `(T,)`, e.g. `safe_norm(sigma_e, axis=-1)` of an attitude
      error (any unit; the same unit as `tol`).
    - `tol`: band half-width, a positive scalar, in the unit of `x`.

    **Returns:** the settling time [s] as a scalar array, in the interval `[ts[0], ts[-1]]` or
    `inf`.

    **Gradients:** the index $k$ is piecewise constant and carries no gradient; the
    interpolation is differentiable in `ts`, `x` and `tol`. The result is the implicit-function
    derivative of the crossing of the piecewise-linear interpolant of the samples, e.g.
    $\partial t_s / \partial \mathrm{tol} = -(t_{k+1} - t_k)/(x_k - x_{k+1})$; it equals a
    finite difference of this function wherever the crossing is transversal and $k$ does not
    change. In the two flat branches (never above `tol`, never settled) the gradient with
    respect to `x` and `tol` is 0 (not NaN); with respect to `ts[0]` it is 1 in the first.
    """
    where = "settling_time"
    x = as_signal(where, "x", x, 1, " Pass a norm, e.g. jaxatt.numerics.safe_norm(e, axis=-1).")
    ts = as_times(where, ts, "x", x)
    tol = check_positive_scalar(where, "tol", tol)
    return _settling_time(ts, x, tol)


def settled(
    ts: Real[ArrayLike, " T"], x: Float[ArrayLike, " T"], tol: RealScalarLike
) -> BoolScalar:
    r"""Whether the record ends inside the band, $x_{T-1} \le \mathrm{tol}$.

    Exactly when [`settling_time`][] is finite (a NaN last sample counts as not settled).

    **Arguments:** as [`settling_time`][].

    **Returns:** a boolean scalar array.
    """
    where = "settled"
    x = as_signal(where, "x", x, 1, " Pass a norm, e.g. jaxatt.numerics.safe_norm(e, axis=-1).")
    as_times(where, ts, "x", x)
    tol = check_positive_scalar(where, "tol", tol)
    return x[-1] <= tol


@jax.jit
def _soft_settling_time(ts: Array, x: Array, tol: Array, width: Array) -> Array:
    dtype = jnp.result_type(ts, x)  # thresholds follow the signal's precision
    x, tol, width = x.astype(dtype), tol.astype(dtype), width.astype(dtype)
    positive = x > jnp.finfo(dtype).tiny
    log_x = jnp.log(jnp.where(positive, x, 1.0))
    # Tiny or zero samples count as inside the band; a NaN sample stays NaN (never "inside").
    z = jnp.where(positive, (log_x - jnp.log(tol)) / width, jnp.where(jnp.isnan(x), x, -jnp.inf))
    above = jax.nn.sigmoid(z)
    return trapezoid(ts.astype(dtype), above)


def soft_settling_time(
    ts: Real[ArrayLike, " T"],
    x: Float[ArrayLike, " T"],
    tol: RealScalarLike,
    width: RealScalarLike = 0.1,
) -> Scalar:
    r"""Smooth surrogate of the settling time: the time spent above `tol`, in log-magnitude.

    $$\tilde t_s = \int_{t_0}^{t_{T-1}} \sigma\!\left(\frac{\ln x(t) - \ln \mathrm{tol}}{w}\right)
    dt,\qquad \sigma(z) = \frac{1}{1 + e^{-z}},$$

    computed with the trapezoid rule on the samples. The sigmoid is 1/2 at `x = tol` and switches
    over a factor $e^{\pm w}$ in magnitude, so `width` $w$ is a relative (log) band: `0.1` means
    about 10 %.

    For a signal that decreases monotonically through `tol`, $\tilde t_s$ tends to the crossing
    time as $w \to 0$ (for $x = x_0 e^{-kt}$ exactly
    $\tilde t_s = w[\mathrm{softplus}(k t_s / w) - \mathrm{softplus}(k(t_s - t_{T-1})/w)]/k$).
    The sampled limit is within half a sample step of the crossing (the trapezoid of a step),
    so keep $w$ resolved by the grid: $k\,\Delta t \lesssim w$. Unlike [`settling_time`][] it
    counts **all** time spent above `tol`, not only the time until the last exit: a signal
    that leaves the band late adds only the time it spends outside.

    **Arguments:**
    - `ts`: sample times [s], shape `(T,)`, non-decreasing.
    - `x`: non-negative magnitude, shape `(T,)`; exact zeros are allowed.
    - `tol`: band, positive, unit of `x`.
    - `width`: sigmoid width $w$ in natural-log units (dimensionless), positive.

    **Returns:** a scalar [s] in `[0, ts[-1] - ts[0]]`.

    **Gradients:** smooth in `ts`, `x`, `tol` and `width`. Samples with
    $x \le$ `finfo.tiny` (including exact zeros and negative values) count as 0 and
    contribute gradient 0 (double `where` around the logarithm). For `width <= 1` the true
    derivative in `x` tends to 0 as $x \to 0$, so nothing is lost; for `width > 1` it is unbounded
    there and the masking cuts it off.
    """
    where = "soft_settling_time"
    x = as_signal(where, "x", x, 1, " Pass a norm, e.g. jaxatt.numerics.safe_norm(e, axis=-1).")
    ts = as_times(where, ts, "x", x)
    tol = check_positive_scalar(where, "tol", tol)
    width = check_positive_scalar(where, "width", width)
    return _soft_settling_time(ts, x, tol, width)


@jax.jit
def _itae(ts: Array, x: Array) -> Array:
    return trapezoid(ts, (ts - ts[0]) * jnp.abs(x))


@jax.jit
def _iae(ts: Array, x: Array) -> Array:
    return trapezoid(ts, jnp.abs(x))


def itae(ts: Real[ArrayLike, " T"], x: Float[ArrayLike, " T"]) -> Scalar:
    r"""Integral of time-weighted absolute error, $\int (t - t_0)\,|x(t)|\,dt$ (trapezoid).

    Time is measured from the first sample $t_0$ = `ts[0]`, so the value does not depend on the
    time origin (it is the textbook ITAE when `ts[0] = 0`).

    **Arguments:**
    - `ts`: sample times [s], shape `(T,)`, non-decreasing.
    - `x`: error signal, shape `(T,)` (a magnitude, or one signed component).

    **Returns:** a scalar in [unit of `x` s^2].

    **Gradients:** smooth except where `x` changes sign; `d|x|/dx = 1` at `x = 0` (JAX's
    subgradient), finite.
    """
    where = "itae"
    x = as_signal(where, "x", x, 1)
    ts = as_times(where, ts, "x", x)
    return _itae(ts, x)


def iae(ts: Real[ArrayLike, " T"], x: Float[ArrayLike, " T"]) -> Scalar:
    r"""Integral of absolute error, $\int |x(t)|\,dt$ (trapezoid).

    **Arguments:**
    - `ts`: sample times [s], shape `(T,)`, non-decreasing.
    - `x`: error signal, shape `(T,)`.

    **Returns:** a scalar in [unit of `x` s].

    **Gradients:** as [`itae`][].
    """
    where = "iae"
    x = as_signal(where, "x", x, 1)
    ts = as_times(where, ts, "x", x)
    return _iae(ts, x)


@jax.jit
def _time_outside(ts: Array, x: Array, tol: Array) -> Array:
    above = ~(x <= tol)  # NaN counts as outside
    a, b = x[:-1] - tol, x[1:] - tol
    one_side = above[:-1] != above[1:]
    crossing = one_side & jnp.isfinite(a) & jnp.isfinite(b)
    # A crossing: the fraction of the interval spent above, by linear interpolation. Double
    # where: the denominator of any other interval never enters the graph.
    numerator = jnp.where(crossing, jnp.where(a > 0, a, b), 0.0)
    denominator = jnp.where(crossing, jnp.abs(a) + jnp.abs(b), 1.0)
    whole = jnp.where((above[:-1] & above[1:]) | one_side, 1.0, 0.0)  # non-finite ends: all
    fraction = jnp.where(crossing, numerator / denominator, whole)
    return jnp.sum(fraction * jnp.diff(ts))


def time_outside(
    ts: Real[ArrayLike, " T"], x: Float[ArrayLike, " T"], tol: RealScalarLike
) -> Scalar:
    r"""Total time the magnitude `x` spends above `tol`, by linear interpolation of the samples.

    $$T_{\mathrm{out}} = \big|\{t \in [t_0, t_{T-1}] : \hat x(t) > \mathrm{tol}\}\big|,$$

    $\hat x$ the piecewise-linear interpolant of the samples. For a signal that crosses `tol`
    once, downwards, this is the [`settling_time`][] (minus $t_0$); unlike the last-exit time
    it is **continuous** in the samples: a late bump that pokes above `tol` adds the (short)
    time it spends outside, instead of moving the result to its end. Differentiable almost
    everywhere (at a sample exactly equal to `tol` it has a kink).

    A NaN sample counts as outside (a diverged signal never looks settled).

    **Bias.** The linear interpolant of a convex decaying signal lies above it, so each
    crossing is found late by at most about $\tfrac18 \lambda \Delta t^2$ for a local decay
    $x \propto e^{-\lambda t}$ sampled every $\Delta t$ (1e-5 s for $\lambda = 3$/s and
    $\Delta t = 5$ ms); a concave signal is found early by the same order.

    **Arguments:** as [`settling_time`][]. **Returns:** a scalar [s] in
    `[0, ts[-1] - ts[0]]`.
    """
    where = "time_outside"
    x = as_signal(where, "x", x, 1, " Pass a norm, e.g. jaxatt.numerics.safe_norm(e, axis=-1).")
    ts = as_times(where, ts, "x", x)
    tol = check_positive_scalar(where, "tol", tol)
    return _time_outside(ts, x, tol)


def decay_extrapolation(x_k, last, span, horizon, tol) -> tuple[Array, Array]:
    r"""The time [s] the final decay still needs, $\ln(x_{T-1}/\mathrm{tol})/\hat\lambda$ (0 when
    settled), and whether the run diverged (unsettled with a non-finite $x_k$ or $x_{T-1}$).

    $\hat\lambda = \max((\ln x_k - \ln x_{T-1})/\mathrm{span}, 1/\mathrm{horizon})$; a sample
    $x_k \le 0$ counts as $\ln x_k = -\infty$, the floored rate (the limit $x_k \to 0^+$), so
    the result is continuous there. Double where: no logarithm of 0 enters the graph.
    """
    unsettled = ~(last <= tol)
    finite = jnp.isfinite(last) & jnp.isfinite(x_k)
    measured = finite & (last > 0) & (x_k > 0)
    safe_last = jnp.where(measured, last, 1.0)
    safe_first = jnp.where(measured, x_k, 1.0)
    rate = jnp.where(measured, (jnp.log(safe_first) - jnp.log(safe_last)) / span, -jnp.inf)
    rate = maximum(rate, 1 / horizon)
    extrapolate = unsettled & finite  # then last > tol > 0
    ratio = jnp.where(extrapolate, last, tol) / tol
    remaining = jnp.where(extrapolate, jnp.log(ratio) / rate, 0.0)
    return remaining, unsettled & ~finite


@jax.jit
def _convergence_time(ts: Array, x: Array, tol: Array, window: Array) -> Array:
    dtype = jnp.result_type(ts, x)
    outside = _time_outside(ts, x, tol)
    last = x[-1]
    # Decay rate measured over the last `window` seconds (the sample closest to t_end - window).
    t_end = ts[-1]
    k = jnp.argmin(jnp.abs(ts - (t_end - window)))
    k = jax.lax.stop_gradient(jnp.minimum(k, ts.shape[0] - 2))
    span = t_end - ts[k]
    remaining, diverged = decay_extrapolation(x[k], last, span, t_end - ts[0], tol)
    total = ts[0] + outside + remaining
    return jnp.where(diverged, jnp.inf, total).astype(dtype)


def convergence_time(
    ts: Real[ArrayLike, " T"],
    x: Float[ArrayLike, " T"],
    tol: RealScalarLike,
    window: RealScalarLike | None = None,
) -> Scalar:
    r"""A convergence time a tuner can trust: continuous in the data, finite, extrapolated.

    $$T_c = t_0 + T_{\mathrm{out}} + \begin{cases}
    0, & x(t_{T-1}) \le \mathrm{tol},\\
    \ln\!\big(x(t_{T-1})/\mathrm{tol}\big)/\hat\lambda, & \text{otherwise},
    \end{cases}\qquad
    \hat\lambda = \max\!\Big(\frac{\ln x(t_{T-1} - w) - \ln x(t_{T-1})}{w},\
    \frac{1}{t_{T-1} - t_0}\Big),$$

    with $T_{\mathrm{out}}$ the [`time_outside`][] the band: for a signal that decays through
    `tol` once it equals the [`settling_time`][]; a late bump adds its duration instead of
    jumping the result. A signal still outside at the end of the record gets the time it
    would need at the decay rate $\hat\lambda$ measured over its last `window` $w$ seconds
    (exact for an exponential tail), floored at one e-fold per horizon so that a signal that
    does not decay still gets a finite penalty; a sample $x(t_{T-1} - w) \le 0$ counts as
    $\ln x = -\infty$ (its limit from above), i.e. takes the floored rate, so $T_c$ is
    continuous there too. $T_c$ is continuous across the settled/unsettled boundary (the
    extrapolation vanishes at $x = \mathrm{tol}$) and differentiable almost everywhere in the
    samples and `tol`.

    A non-finite last sample (a diverged run) gives `inf`.

    **Arguments:**
    - `ts`, `x`, `tol`: as [`settling_time`][].
    - `window`: $w$ [s], the span over which the final decay rate is measured; default a
      tenth of the record. The rate is measured from the sample closest to $t_{T-1} - w$ (never
      the last one), over the span actually covered: a window longer than the record measures
      it over the whole record, from $t_0$.

    **Returns:** a scalar [s], `>= ts[0]`, or `inf`.
    """
    where = "convergence_time"
    x = as_signal(where, "x", x, 1, " Pass a norm, e.g. jaxatt.numerics.safe_norm(e, axis=-1).")
    ts = as_times(where, ts, "x", x)
    if x.shape[0] < 2:
        raise ValueError(f"{where}: `x` must hold at least two samples, got {x.shape[0]}.")
    tol = check_positive_scalar(where, "tol", tol)
    if window is None:
        window = 0.1 * (ts[-1] - ts[0])
    window = check_positive_scalar(where, "window", window)
    return _convergence_time(ts, x, tol, window)
