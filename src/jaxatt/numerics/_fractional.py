r"""Fractional derivatives of sampled signals: Grunwald-Letnikov, Riemann-Liouville, Caputo.

On a uniform grid $t_k = t_0 + kh$ the Grunwald-Letnikov (GL) derivative of order $q$ is

$$D^q f(t_k) \approx h^{-q}\sum_{j=0}^{k} w_j^{(q)} f(t_{k-j}),\qquad
w_0 = 1,\ w_j = w_{j-1}\Big(1 - \frac{q + 1}{j}\Big),$$

the binomial weights $w_j = (-1)^j\binom{q}{j}$. With the lower terminal at $t_0$ it converges
at first order in $h$ to the **Riemann-Liouville** derivative ${}^{RL}D^q f$ for smooth $f$
([`riemann_liouville`][] is this sum); the **Caputo** derivative is the RL derivative of
$f - f(t_0)$ ([`caputo`][]), so ${}^{C}D^q c = 0$.

**Memory.** The exact sum needs every past sample ("full memory"): $O(k)$ work at step $k$,
$O(N^2)$ over $N$ steps, and $O(N)$ storage. [`FractionalMemory`][] keeps a ring buffer of
the last $L$ samples; with $L$ at least the number of samples of the horizon it is exact
(full memory), with a smaller $L$ it is the *short-memory principle* (Podlubny 1999, 7.3):
the terms older than $L h$ are dropped. For $0 < q < 1$ every $w_j$, $j \ge 1$, is negative
and $\sum_{j<n} w_j \approx n^{-q}/\Gamma(1-q)$, so for a signal bounded by $M$ the error at
time $t$ is at most $M((Lh)^{-q} - t^{-q})/\Gamma(1 - q) < M (Lh)^{-q}/\Gamma(1 - q)$, e.g. for
$q = 0.8$, $L h = 10$ s: $0.16\,M/4.59 \approx 0.035M$ (a bias that does not vanish as
$h \to 0$).

!!! cite
    I. Podlubny, *Fractional Differential Equations*, Academic Press 1999, sections 2.2, 7.2-7.3.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike


def grunwald_letnikov_weights(order: RealScalarLike, n: int) -> Float[Array, " n"]:
    r"""The first `n` GL weights $w_0 = 1$, $w_j = w_{j-1}(1 - (q + 1)/j)$ of order $q$.

    Differentiable in `order` (a cumulative product).
    """
    order = jnp.asarray(order, dtype=jnp.result_type(float))
    j = jnp.arange(1, n, dtype=order.dtype)
    return jnp.concatenate([jnp.ones(1, order.dtype), jnp.cumprod(1 - (order + 1) / j)])


def riemann_liouville(
    samples: Float[ArrayLike, "N ..."], step: RealScalarLike, order: RealScalarLike
) -> Float[Array, "N ..."]:
    r"""GL approximation of the Riemann-Liouville derivative $D^q f(t_k)$ at every sample.

    **Arguments:**
    - `samples`: $f(t_0 + kh)$, $k = 0 \dots N-1$, along the first axis.
    - `step`: $h > 0$ [s]; `order`: $q$ (any real; negative orders are fractional integrals).

    **Returns:** the array of $h^{-q}\sum_{j\le k} w_j f_{k-j}$, same shape as `samples`.
    First-order accurate for smooth $f$ (and for $f = t^p$, $p > 0$, away from $t_0$).
    """
    f = jnp.asarray(samples)
    n = f.shape[0]
    w = grunwald_letnikov_weights(order, n)
    # Lower-triangular Toeplitz product: out_k = sum_j w_j f_{k-j}.
    index = jnp.arange(n)[:, None] - jnp.arange(n)[None, :]
    matrix = jnp.where(index >= 0, w[jnp.clip(index, 0, n - 1)], 0.0)
    return jnp.tensordot(matrix, f, axes=1) * jnp.asarray(step, f.dtype) ** (-order)


def caputo(
    samples: Float[ArrayLike, "N ..."], step: RealScalarLike, order: RealScalarLike
) -> Float[Array, "N ..."]:
    r"""Caputo derivative ${}^C D^q f = {}^{RL}D^q [f - f(t_0)]$ ($0 < q < 1$) at every
    sample, by the GL sum of [`riemann_liouville`][]."""
    f = jnp.asarray(samples)
    return riemann_liouville(f - f[0], step, order)


class FractionalMemory(eqx.Module):
    r"""The sample memory of a running GL sum: a ring buffer of the last `L` samples.

    - `buffer`: shape `(L, *shape)`; the sample with index $m$ sits in slot $m \bmod L$;
    - `count`: the number of samples pushed so far (the newest has index `count - 1`), a
      float (exact up to 2^53) so that fixed-step solvers can carry the memory in a
      controller state with a zero time derivative.
    """

    buffer: Float[Array, "L ..."]
    count: Float[Array, ""]


def memory_init(capacity: int, sample: Float[ArrayLike, "*shape"]) -> FractionalMemory:
    """A memory of `capacity` slots holding one sample (the one at $t_0$)."""
    sample = jnp.asarray(sample)
    buffer = jnp.zeros((capacity, *sample.shape), sample.dtype).at[0].set(sample)
    return FractionalMemory(buffer, jnp.ones((), sample.dtype))


def memory_push(memory: FractionalMemory, sample: Float[ArrayLike, "*shape"]) -> FractionalMemory:
    """Store the next sample (overwriting the oldest once the buffer is full)."""
    slot = jnp.asarray(memory.count, jnp.int32) % memory.buffer.shape[0]
    buffer = jax.lax.dynamic_update_index_in_dim(memory.buffer, jnp.asarray(sample), slot, 0)
    return FractionalMemory(buffer, memory.count + 1)


def memory_derivative(
    memory: FractionalMemory, step: RealScalarLike, order: RealScalarLike
) -> Float[Array, "*shape"]:
    r"""$h^{-q}\sum_{j=0}^{\min(k, L-1)} w_j f_{k-j}$ at the newest sample $k$ = `count - 1`.

    Exact GL (full memory) while `count <= L`; short memory of `L` samples afterwards.
    $O(L)$ work.
    """
    capacity = memory.buffer.shape[0]
    newest = jnp.asarray(memory.count, jnp.int32) - 1
    slots = jnp.arange(capacity)
    lag = jnp.mod(newest - slots, capacity)  # j of the sample held in each slot
    w = grunwald_letnikov_weights(order, capacity)
    weights = jnp.where(lag <= newest, w[lag], 0.0)
    total = jnp.tensordot(weights, memory.buffer, axes=1)
    return total * jnp.asarray(step, total.dtype) ** (-jnp.asarray(order, total.dtype))
