"""Signed and absolute powers with finite, documented derivatives at x = 0."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ._extrema import maximum


def _slope_floor(dtype) -> Array:
    return jnp.sqrt(jnp.finfo(dtype).eps).astype(dtype)


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _abs_pow_primal(ax: Array, a: Array) -> Array:
    r"""$|x|^a$ for $|x| \ge 0$ as $\exp(a \ln|x|)$, exactly 0 at $x = 0$ ($a > 0$), 1 for $a = 0$.

    `exp(a * log(x))` is 1.6x cheaper than XLA:CPU's `pow` per element (benchmarks/README.md)
    and equal to it to a few ulps: the relative error is about $(1 + |a \ln x|)\,\varepsilon$.
    The logarithm is `jnp.log`: in a vmapped (plain) program XLA:CPU's own is the faster one
    (Chen M1's plain Monte Carlo of 256 samples ran 1.24x slower with
    [`vectorized_log`][jaxatt.numerics.vectorized_log]), and in a scalarized program
    ([`Performance`][jaxatt.simulation.Performance]`(scalarize=...)`) every float64 `log`
    becomes `vectorized_log`, which is the faster one there (1.08x at 1000 samples). Double
    where: the masked input keeps `log 0` (and its derivatives) out of the graph.
    """
    positive = ax > 0
    safe_ax = jnp.where(positive, ax, 1)
    power = jnp.exp(a * jnp.log(safe_ax))
    return jnp.where(positive, power, jnp.where(a == 0, 1, 0).astype(ax.dtype))


def _log_abs(ax: Array) -> Array:
    positive = ax > 0
    return jnp.where(positive, jnp.log(jnp.where(positive, ax, 1)), 0)


@jax.custom_jvp
def sig_pow(x: Float[ArrayLike, "*#shape"], a: Float[ArrayLike, "*#shape"]) -> Float[Array, "..."]:
    r"""Signed power $\mathrm{sig}^a(x) = |x|^a \operatorname{sign}(x)$, elementwise.

    `sign(0) = 0`, so `sig_pow(0, a) = 0` for every `a > 0`. `x` and `a` broadcast.

    **Gradients** (a `jax.custom_jvp`, finite everywhere for `a > 0`):
    - with respect to `x`: $a |x|^{a-1}$, exact for `a >= 1`; for `a < 1` the slope is capped
      at $a\,\max(|x|, \sqrt{\varepsilon})^{a-1}$ (`eps` the dtype's machine epsilon), so at
      `x = 0` it is large but finite instead of infinite.
    - with respect to `a`: $\mathrm{sig}^a(x) \ln|x|$, with its limit 0 at `x = 0`.

    **Arguments:**
    - `x`: base, any shape.
    - `a`: exponent, `a >= 0`, broadcastable against `x`.

    **Returns:** an array of the broadcast shape and dtype of `x`.
    """
    x = jnp.asarray(x)
    a = jnp.asarray(a, dtype=x.dtype) if not isinstance(a, jax.Array) else a
    return jnp.sign(x) * _abs_pow_primal(jnp.abs(x), a)


@sig_pow.defjvp
def _sig_pow_jvp(primals, tangents):
    x, a = primals
    x_dot, a_dot = tangents
    x = jnp.asarray(x)
    a = jnp.asarray(a)
    ax = jnp.abs(x)
    value = jnp.sign(x) * _abs_pow_primal(ax, a)
    # d/dx: a |x|^(a-1); below sqrt(eps) the base is floored when a < 1 (finite slope cap).
    floored = jnp.where(a < 1, maximum(ax, _slope_floor(ax.dtype)), ax)
    dx = a * _abs_pow_primal(floored, a - 1)
    da = value * _log_abs(ax)
    tangent = dx * jnp.asarray(x_dot) + da * jnp.asarray(a_dot)
    return value, tangent


def abs_pow(x: Float[ArrayLike, "*#shape"], a: Float[ArrayLike, "*#shape"]) -> Float[Array, "..."]:
    r"""Absolute power $|x|^a$ with the same derivative conventions as [`sig_pow`][].

    $|x|^a = \mathrm{sig}^a(x)\operatorname{sign}(x)$ away from 0 and 0 at x = 0 (for a > 0), so the
    derivative in `x` is $a|x|^{a-1}\operatorname{sign}(x)$, capped as in `sig_pow` when a < 1,
    and **0 at x = 0** for every `a` (the symmetric choice: $|x|^a$ is even, and for a < 1 both
    one-sided slopes are infinite). In `a` it is $|x|^a\ln|x|$, 0 at x = 0.
    """
    x = jnp.asarray(x)
    # The base is |x| computed as x sign(x), whose derivative is sign(x) (0 at x = 0); jnp.abs's
    # is 1 at 0, which gave the one-sided slope a sqrt(eps)^(a-1) (~4e3 for a = 1/2) there.
    # Same value bit for bit: x sign(x) is exact.
    return sig_pow(x * jnp.sign(x), a)
