"""Overshoot of a regulated error: how far each component swings past zero."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..numerics import amax, maximum
from ._signals import as_signal


@jax.jit
def _overshoot(x: Array) -> Array:
    x0 = x[0]
    direction = jnp.sign(x0)
    excursion = maximum(amax(-direction[None, :] * x, axis=0), 0.0)
    zero = x0 == 0  # (not `!= 0`: a NaN start gives a NaN overshoot)
    scale = jnp.where(zero, 1.0, jnp.abs(x0))
    return jnp.where(zero, 0.0, excursion / scale)


def overshoot(x: Float[ArrayLike, "T n"]) -> Float[Array, " n"]:
    r"""Per-component overshoot of an error converging to 0, relative to its initial value.

    $$M_i = \frac{\max\left(0,\ \max_t -\operatorname{sign}(x_{0,i})\,x_{t,i}\right)}
    {|x_{0,i}|},$$

    i.e. the largest excursion on the far side of zero, as a fraction of the initial magnitude
    (`0.2` = 20 % overshoot). A component that approaches 0 from one side without crossing it has
    $M_i = 0$; a component that starts at exactly 0 has $M_i = 0$ by convention. Only the
    sampled values are inspected, so a peak between samples is missed (error at most
    $\tfrac18 \max|\ddot x|\,\Delta t^2$ relative to $|x_0|$).

    **Arguments:**
    - `x`: error components, shape `(T, n)`, time first, e.g. the MRP error `sigma_e` (rad-like,
      dimensionless) or a rate error [rad/s]. Samples need not be uniformly spaced, so no `ts`
      is needed. For a scalar signal pass `x[:, None]`.

    **Returns:** the dimensionless overshoot per component, shape `(n,)`.

    **Gradients:** through the extreme sample (piecewise smooth, as `max`), and through
    $1/|x_0|$; components with $x_0 = 0$ get gradient 0 (double `where`, no NaN).
    """
    x = as_signal("overshoot", "x", x, 2, " For a scalar signal pass x[:, None].")
    return _overshoot(x)
