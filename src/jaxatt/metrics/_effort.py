"""Control effort and peak control."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, Real

from .._custom_types import Scalar
from ..numerics import amax
from ._signals import as_signal, as_times, trapezoid


_HINT = " For a single input pass u[:, None]."


@jax.jit
def _control_effort(ts: Array, u: Array) -> Array:
    return trapezoid(ts, jnp.sum(u * u, axis=-1))


def control_effort(ts: Real[ArrayLike, " T"], u: Float[ArrayLike, "T m"]) -> Scalar:
    r"""Control energy $\int_{t_0}^{t_{T-1}} \|u(t)\|_2^2\,dt$ (trapezoid rule).

    **Arguments:**
    - `ts`: sample times [s], shape `(T,)`, non-decreasing (need not be uniform).
    - `u`: control, shape `(T, m)`, e.g. a torque [N m].

    **Returns:** a scalar in [unit of `u`^2 s], e.g. [N^2 m^2 s].

    **Gradients:** smooth everywhere (a sum of squares, no square root).
    """
    u = as_signal("control_effort", "u", u, 2, _HINT)
    ts = as_times("control_effort", ts, "u", u)
    return _control_effort(ts, u)


def peak(u: Float[ArrayLike, "T m"]) -> Scalar:
    r"""Largest absolute control over time and components, $\max_{t,i} |u_{t,i}|$.

    **Arguments:**
    - `u`: control, shape `(T, m)`, unit of `u` (e.g. [N m]).

    **Returns:** a scalar in the unit of `u`.

    **Gradients:** through the extreme entry only (the first, at a tie:
    [`jaxatt.numerics.amax`][]).
    """
    u = as_signal("peak", "u", u, 2, _HINT)
    return amax(jnp.abs(u))


def peak_per_axis(u: Float[ArrayLike, "T m"]) -> Float[Array, " m"]:
    r"""Largest absolute control per component, $\max_t |u_{t,i}|$, shape `(m,)`.

    **Arguments:**
    - `u`: control, shape `(T, m)`.

    **Returns:** shape `(m,)`, in the unit of `u`.

    **Gradients:** as [`peak`][].
    """
    u = as_signal("peak_per_axis", "u", u, 2, _HINT)
    return amax(jnp.abs(u), axis=0)
