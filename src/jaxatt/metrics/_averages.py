"""Moving averages of sampled signals (e.g. to separate an estimator's bias from its chatter)."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Real

from .._custom_types import RealScalarLike
from .._validation import check_positive_scalar
from ._signals import as_signal, as_times


@jax.jit
def _moving_average(ts: Array, x: Array, window: Array) -> Array:
    flat = x.reshape(x.shape[0], -1)
    steps = jnp.diff(ts)[:, None]
    increments = 0.5 * (flat[1:] + flat[:-1]) * steps
    integral = jnp.concatenate(
        [jnp.zeros((1, flat.shape[1]), flat.dtype), jnp.cumsum(increments, axis=0)]
    )
    start = jnp.maximum(ts - window, ts[0])
    back = jax.vmap(lambda column: jnp.interp(start, ts, column), in_axes=1, out_axes=1)(integral)
    span = ts - start
    safe = jnp.where(span > 0, span, 1.0)
    average = jnp.where((span > 0)[:, None], (integral - back) / safe[:, None], flat)
    return average.reshape(x.shape)


def moving_average(
    ts: Real[ArrayLike, " T"], x: Float[ArrayLike, "T ..."], window: RealScalarLike
) -> Float[Array, "T ..."]:
    r"""Trailing moving average $\bar x(t) = \frac{1}{w}\int_{t-w}^{t} x(\tau)\,d\tau$.

    The integral is the trapezoid rule on the samples, interpolated linearly at $t - w$; near
    the start the window is shortened to $[t_0, t]$ (and $\bar x(t_0) = x(t_0)$). Every
    component is averaged separately. Averaging over a window much longer than a chatter's
    period removes the chatter and keeps a bias: a disturbance observer whose estimate
    chatters around the truth has a small average error, one whose estimate is stuck does not.

    **Arguments:**
    - `ts`: sample times [s], shape `(T,)`, non-decreasing.
    - `x`: the signal, shape `(T, ...)`.
    - `window`: $w > 0$ [s], a scalar.

    **Returns:** the average, with the shape of `x`.
    """
    where = "moving_average"
    x = jnp.asarray(x)
    if x.ndim == 1:
        return moving_average(ts, x[:, None], window)[:, 0]
    as_signal(where, "x", x.reshape(x.shape[0], -1), 2)
    ts = as_times(where, ts, "x", x)
    # One window for every component: a (T,) window broadcast against `ts` into one window
    # per sample, a plausible average.
    window = check_positive_scalar(where, "window", window)
    return _moving_average(ts, x, window)
