"""Values XLA computes once for all their readers, instead of once per reader."""

import jax.lax as lax
import jax.numpy as jnp
import jax.tree_util as jtu
from jaxtyping import ArrayLike, PyTree


def materialized(tree: PyTree, t: ArrayLike) -> PyTree:
    r"""`tree` with the same values, which XLA computes once and stores for all their readers.

    XLA's loop fusion copies cheap elementwise arithmetic into every kernel that reads it
    rather than storing it. In a closed-loop step the attitude errors feed every component of
    the control and of the state derivative. In a scalarized batch each component is its own
    kernel, so each one recomputed the quaternion error, its rotation matrix and the rate
    error. `jax.lax.optimization_barrier` cannot stop this: XLA:CPU removes barriers before
    fusion (its `cse_barrier_expander` pass).

    XLA does not copy a *division* into several readers. So every floating leaf is divided by
    $1 + 0 \cdot t$, a one that XLA cannot prove is one, made from the time `t` the caller
    has at hand. Each leaf is then the output of one kernel.

    This needs `t` batched like the values, as in jaxatt's vmapped time loop (one time per
    sample). With a scalar `t` and batched values, XLA turns the division by the broadcast
    divisor into a multiplication. The values are still exact, but the mark has no effect.

    **Exact.**
    - Every floating leaf is returned as $x / 1$, which is $x$ bit for bit in IEEE 754 (NaN,
      $\pm\infty$ and $-0$ included). `t` must be finite.
    - Like all of XLA:CPU's arithmetic, the division flushes subnormal numbers
      ($|x| < 2.2 \times 10^{-308}$ in float64) to zero.
    - The divisor is held constant under differentiation (`stop_gradient`), so the derivative
      is the identity.
    - Other leaves (integers, booleans) are returned as they are.

    Other kernels' rounding can still change when a program is re-fused (multiply-adds
    contract differently). For Chen 2022's loops over 1 s, final states moved by up to
    2.5e-14 relative and metrics by 5e-16.

    **Measured** (`SlidingModeTracking` materializes its tracking errors; Chen 2022 M1,
    float64, 2-core AVX-512 CPU, with the 512-bit vectors of the scalarized loop's default;
    benchmarks/README.md, "Materialized tracking errors"):
    - the default Monte Carlo call: 1.16-1.20x the hand scan at 1000 samples (0.97-1.00x
      before); at 10 000, 1.34-1.39x against 1.28-1.36x before, within the noise of the two
      scripts (`bench_defaults.py`: 1.36x both);
    - the plain program at 300 samples: 1.07-1.14x faster;
    - the demo's 32-sample tuning gradient: 1.14x faster.

    With no compiler option (the default from 2026-12-03 to 2026-12-04) the default call ran at
    1.08-1.13x the hand scan at 1000 samples and 1.18-1.22x at 10 000 ("The 512-bit default
    withdrawn"); with the 512-bit default restored, 1.29x and 1.34x ("The 512-bit default
    restored").

    Materializing the sliding variable as well, or every RK4 stage's state or derivative, made
    the step slower: where to use it is measured, not guessed.
    """
    one = lax.stop_gradient(1 + jnp.asarray(t) * 0)

    def divide(x):
        if not jnp.issubdtype(jnp.result_type(x), jnp.floating):
            return x
        return x / one.astype(jnp.result_type(x))

    return jtu.tree_map(divide, tree)
