"""Switching functions: the discontinuous sign and its boundary-layer approximations."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ._extrema import clip


def sign(x: Float[ArrayLike, "*#shape"]) -> Float[Array, "..."]:
    """`sign(x)` with `sign(0) = 0` (SPEC's convention).

    **Gradient:** 0 everywhere (as `jnp.sign`). A gain that multiplies only `sign(s)` therefore
    receives no gradient signal; tune such gains through [`smooth_sign`][] or [`sat`][].
    """
    return jnp.sign(jnp.asarray(x))


def sat(x: Float[ArrayLike, "*#shape"], width: Float[ArrayLike, "*#shape"]) -> Float[Array, "..."]:
    r"""Boundary-layer saturation $\mathrm{sat}(x/\phi) = \min(1, \max(-1, x/\phi))$.

    Equals `sign(x)` for $|x| \ge \phi$ and is linear inside the layer. **Gradient:** $1/\phi$
    inside the layer, 0 outside (at the corners JAX takes one side). `width` must be positive.
    """
    x = jnp.asarray(x)
    return clip(x / width, -1, 1)


def smooth_sign(
    x: Float[ArrayLike, "*#shape"], width: Float[ArrayLike, "*#shape"]
) -> Float[Array, "*#shape"]:
    r"""Smooth sign $\tanh(x/\phi)$: infinitely differentiable, slope $1/\phi$ at 0.

    Tends to `sign(x)` as `width -> 0`; $|\tanh(x/\phi) - \mathrm{sign}(x)| < 2 e^{-2|x|/\phi}$.
    """
    x = jnp.asarray(x)
    return jnp.tanh(x / width)


def rational_sign(
    x: Float[ArrayLike, "*#shape"], delta: Float[ArrayLike, "*#shape"]
) -> Float[Array, "*#shape"]:
    r"""Rational smooth sign $x / (|x| + \delta)$, slope $1/\delta$ at 0, `delta > 0`."""
    x = jnp.asarray(x)
    return x / (jnp.abs(x) + delta)
