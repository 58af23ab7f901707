r"""Two fresh values per loop output: a stream's state carried as complex pairs.

XLA:CPU computes every output of a loop body in its own fused kernel and copies the cheap
arithmetic that output reads into that kernel instead of storing it. A metric stream's state
has several values computed from the same step's signals (for a rigid body: the largest
$|u_i|$ and $\|u\|^2$ for the peak and the effort, the attitude-error norm and the settling
time, the rate-error norm): each became a kernel that recomputed the controller and the
attitude error it reads. Carrying two of those values as the real and imaginary parts of one
complex number makes them one output, computed in one kernel: the default 4-metric
`monte_carlo` went from 0.79x to 0.90x the hand-written scan at batch 1000, and from 0.97x to
1.05x at 3000, on a 2-core CPU (`benchmarks/bench_quick.py --horizon 1`; `benchmarks/README.md`,
issue 18).

`signal_dependencies` finds the values worth pairing (the leaves of the stream's state
that depend on the step's signals, by a dependency pass over the update's jaxpr), `plan_pairs`
pairs them (values reading the same signals first), `pair` and
`unpair` pack and unpack them. Packing is exact: `real(complex(a, b))` is `a` bit for bit
(NaN and infinities included); only XLA's fusion of the loop changes (its rounding may differ
in the last bit, as for any change of fusion). Only the scalarized loop pairs: that is where
it was measured (XLA:CPU); the plain program, run below 1000 samples and on GPUs, is as
before.
"""

import equinox as eqx
import jax
import jax.extend.core as jex
import jax.lax as lax
import jax.numpy as jnp
import jax.tree_util as jtu
from jaxtyping import Array, PyTree


def signal_dependencies(fn, state: PyTree, signals: PyTree) -> list[frozenset[int]]:
    """For each leaf of `fn(state, signals)`: the indices of the leaves of `signals` it
    depends on (empty: it depends only on `state` or on constants), by a forward dependency
    pass over `fn`'s jaxpr."""
    jaxpr = jax.make_jaxpr(fn)(state, signals).jaxpr
    n_state = len(jtu.tree_leaves(state))
    depends = {v: frozenset([k]) for k, v in enumerate(jaxpr.invars[n_state:])}
    for eqn in jaxpr.eqns:
        found = frozenset().union(
            *(depends.get(v, frozenset()) for v in eqn.invars if isinstance(v, jex.Var))
        )
        if found:
            depends.update((v, found) for v in eqn.outvars)
    return [
        depends.get(v, frozenset()) if isinstance(v, jex.Var) else frozenset()
        for v in jaxpr.outvars
    ]


def _pairable(leaf) -> bool:
    return jnp.result_type(leaf) in (jnp.dtype(jnp.float32), jnp.dtype(jnp.float64))


def plan_pairs(leaves: list, dependencies: list[frozenset[int]]) -> tuple[tuple[int, int], ...]:
    """Pairs of fresh leaves (non-empty `dependencies`) of one shape and real dtype: first
    leaves that read the same signals (the peak and the effort of `u`: their shared arithmetic
    is then computed once), then the rest in order."""
    fresh = [k for k, leaf in enumerate(leaves) if dependencies[k] and _pairable(leaf)]

    def kind(k):
        return jnp.shape(leaves[k]), jnp.result_type(leaves[k])

    pairs: list[tuple[int, int]] = []
    for same_signals in (True, False):
        waiting: list[int] = []
        for k in fresh:
            partner = next(
                (
                    j
                    for j in waiting
                    if kind(j) == kind(k)
                    and (not same_signals or dependencies[j] == dependencies[k])
                ),
                None,
            )
            if partner is None:
                waiting.append(k)
            else:
                waiting.remove(partner)
                pairs.append((partner, k))
        fresh = waiting
    return tuple(sorted(pairs))


class Paired(eqx.Module):
    """A pytree with some pairs of its leaves `(a, b)` held as `complex(a, b)`."""

    pairs: tuple[tuple[int, int], ...] = eqx.field(static=True)
    treedef: jtu.PyTreeDef = eqx.field(static=True)
    packed: list[Array]
    rest: list[Array]


def pair(tree: PyTree, pairs: tuple[tuple[int, int], ...]) -> Paired:
    """`tree` with the leaves of each pair `(a, b)` (flattened indices) as `complex(a, b)`."""
    leaves, treedef = jtu.tree_flatten(tree)
    used = {k for p in pairs for k in p}
    packed = [lax.complex(leaves[a], leaves[b]) for a, b in pairs]
    rest = [leaf for k, leaf in enumerate(leaves) if k not in used]
    return Paired(pairs, treedef, packed, rest)


def unpair(paired: Paired) -> PyTree:
    """The pytree `pair` packed, exactly."""
    leaves: list = [None] * paired.treedef.num_leaves
    for (a, b), z in zip(paired.pairs, paired.packed):
        leaves[a], leaves[b] = jnp.real(z), jnp.imag(z)
    rest = iter(paired.rest)
    for k, leaf in enumerate(leaves):
        if leaf is None:
            leaves[k] = next(rest)
    return jtu.tree_unflatten(paired.treedef, leaves)
