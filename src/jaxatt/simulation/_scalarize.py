r"""Scalarization: run a function of small arrays as a program on their scalar entries.

jaxatt's components work on one spacecraft (3-vectors, quaternions, 3x3 matrices) and are
batched with `jax.vmap` outside `simulate`. Batched this way, every small array becomes a
`(batch, n)` array with its components interleaved in memory, and XLA:CPU lowers the many
slices, stacks, `dot`s and reductions of one closed-loop step to dozens of kernels that
shuffle those components around. The same equations written as arithmetic on `(batch,)`
arrays, one per component (a struct of arrays), compile to a few fused elementwise loops. A
hand-written scan in that layout ran 1.8-2.7x faster than the vmapped Chen M1 program at
1000-10^4 samples (2026-12-01) and 5.5x faster than the vmapped rigid-body PD loop at 10^4
(2026-12-05; within 1.4x below 1000 samples) on a 2-core CPU (benchmarks/README.md).

[`scalarize`][] gets that layout automatically. It traces the function to a jaxpr and
re-evaluates it with every small array held as a NumPy object array of *scalar* JAX values:

- elementwise primitives (`add`, `mul`, `sin`, `select_n`, integer shifts, `bitcast_convert_type`
  between types of one width, ...) are applied entry by entry; a float64 `log` becomes
  `jaxatt.numerics.vectorized_log` (XLA:CPU's is a C-library call per element, which keeps the
  elementwise loops from vectorizing);
- structural primitives (`slice`, `concatenate`, `reshape`, `broadcast_in_dim`, `transpose`,
  `squeeze`, `stack`, ...) only rearrange the object arrays and emit nothing;
- `dot_general` and the `reduce_*` primitives become explicit sums (maxima, ...) of scalars,
  as long as a product needs at most `Limits.max_products` multiplications (a 3x3 matrix
  times a 3x3 matrix is 27); larger products (graph Laplacians, modal matrices) are evaluated
  packed, so scalarization never turns an O(n^3) product into O(n^3) scalar operations;
- calls (`pjit`, `closed_call`) and `cond`/`switch` are scalarized recursively;
- anything else (custom derivative rules such as `jaxatt.numerics.sig_pow`'s, loops,
  callbacks, large arrays) is evaluated *as is* on the re-assembled arrays and its result split
  again, so every program keeps its exact meaning, derivative rules included.

Under `vmap` each scalar becomes a contiguous `(batch,)` array, so what XLA finally sees for
a batch is elementwise. The arithmetic is the same as the original program's up to the order
of additions in dot products and reductions (a few ulps).
"""

import dataclasses
import functools as ft
import math
from collections.abc import Callable, Sequence
from typing import Any

import equinox as eqx
import jax
import jax.extend.core as jex
import jax.lax as lax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np

from ..numerics import vectorized_log


@dataclasses.dataclass(frozen=True)
class Limits:
    """Size limits of scalarization (static; see `jaxatt.simulation.Performance`).

    - `max_size`: arrays with more entries than this are kept whole (packed), e.g. long
      filter histories or the state of a large network.
    - `max_products`: a `dot_general` that needs more scalar multiplications than this is
      evaluated packed (a 3x3 matrix-vector product needs 9, a 3x3 matrix product 27).
    """

    max_size: int = 64
    max_products: int = 64


DEFAULT_LIMITS = Limits()


# --- Representation -------------------------------------------------------------------------
# A value is either a NumPy object array of scalar JAX values (`np.ndarray` with dtype object,
# its shape the array's) or an ordinary (packed) JAX array.


def _is_split(x) -> bool:
    return isinstance(x, np.ndarray) and x.dtype == object


def split(x, limits: Limits = DEFAULT_LIMITS) -> Any:
    """The object array of the scalar entries of `x` (arrays over `limits.max_size` stay)."""
    if _is_split(x):
        return x
    shape = np.shape(x)
    size = math.prod(shape)
    if size > limits.max_size:
        return x
    if isinstance(x, np.ndarray | np.generic):
        x = np.asarray(x)
        out = np.empty(size, dtype=object)
        for k, v in enumerate(x.reshape(-1)):
            out[k] = v
        return out.reshape(shape)
    x = jnp.asarray(x)
    flat = lax.reshape(x, (size,))
    entries = np.empty(size, dtype=object)
    for k in range(size):
        entries[k] = lax.index_in_dim(flat, k, keepdims=False)
    return entries.reshape(shape)


def pack(x, dtype=None) -> Any:
    """The JAX array with the entries of an object array (anything else is returned as is)."""
    if not _is_split(x):
        return x
    if x.size == 0:
        return jnp.zeros(x.shape, dtype)
    flat = [lax.broadcast_in_dim(jnp.asarray(v, dtype), (1,), ()) for v in x.reshape(-1)]
    return lax.reshape(lax.concatenate(flat, 0), x.shape)


# --- Primitive rules ------------------------------------------------------------------------

_ELEMENTWISE = {
    p
    for p in (
        "abs acos acosh add and asin asinh atan atan2 atanh cbrt ceil clamp convert_element_type "
        "copy copy_p cos cosh div eq erf erf_inv erfc exp exp2 expm1 floor ge gt imag "
        "integer_pow is_finite le log log1p logistic lt max min mul ne neg nextafter not or pow "
        "real reduce_precision rem round rsqrt select_n shift_left shift_right_arithmetic "
        "shift_right_logical sign sin sinh sqrt square "
        "stop_gradient sub tan tanh xor"
    ).split()
}


def _vectorized(eqn) -> Callable | None:
    """The vectorizable replacement of an elementwise primitive, if it has one: XLA:CPU computes
    a float64 `log` by a C-library call per element, which keeps a loop over `(batch,)` arrays
    from vectorizing (Chen M1's scalarized Monte Carlo: 1.08x faster at 1000 samples with
    `vectorized_log`, 1.20x at 10^4; benchmarks/README.md). The plain (vmapped) program keeps
    XLA's `log`, which is the faster one there (1.24x at 256 samples)."""
    if eqn.primitive.name == "log" and eqn.outvars[0].aval.dtype == jnp.float64:
        return vectorized_log
    return None


def _is_elementwise_bitcast(eqn) -> bool:
    # Reinterpreting bits between types of one width (float64 <-> int64) keeps the shape.
    return (
        eqn.primitive.name == "bitcast_convert_type"
        and eqn.outvars[0].aval.shape == eqn.invars[0].aval.shape
    )


def _elementwise(prim, params, args):
    return _entrywise(lambda *entries: prim.bind(*entries, **params), args)


def _entrywise(fun, args):
    arrays = np.broadcast_arrays(*args)
    out = np.empty(arrays[0].shape, dtype=object)
    for index in np.ndindex(out.shape):
        out[index] = fun(*(a[index] for a in arrays))
    return out


def _broadcast_in_dim(x, *, shape, broadcast_dimensions, **_):
    expanded = [1] * len(shape)
    for axis, dim in enumerate(broadcast_dimensions):
        expanded[dim] = x.shape[axis]
    return np.broadcast_to(x.reshape(expanded), shape)


def _reshape(x, *, new_sizes, dimensions=None, **_):
    if dimensions is not None:
        x = np.transpose(x, dimensions)
    return x.reshape(new_sizes)


def _slice(x, *, start_indices, limit_indices, strides=None, **_):
    strides = strides or (1,) * x.ndim
    return x[tuple(slice(a, b, s) for a, b, s in zip(start_indices, limit_indices, strides))]


def _dynamic_slice(x, *indices, slice_sizes, **_):
    starts = []
    for index, size, dim in zip(indices, slice_sizes, x.shape):
        value = index.item() if _is_split(index) else index
        if isinstance(value, jax.core.Tracer) or not np.ndim(value) == 0:
            return None  # a traced start: evaluate packed
        starts.append(int(np.clip(int(value), 0, dim - size)))
    return x[tuple(slice(a, a + s) for a, s in zip(starts, slice_sizes))]


def _dot_general(lhs, rhs, *, dimension_numbers, preferred_element_type=None, **_):
    (lc, rc), (lb, rb) = dimension_numbers
    lf = [d for d in range(lhs.ndim) if d not in lc and d not in lb]
    rf = [d for d in range(rhs.ndim) if d not in rc and d not in rb]
    lhs = np.transpose(lhs, [*lb, *lf, *lc])
    rhs = np.transpose(rhs, [*rb, *rf, *rc])
    nb, nlf, nrf = len(lb), len(lf), len(rf)
    batch_shape = lhs.shape[:nb]
    out_shape = (*batch_shape, *lhs.shape[nb : nb + nlf], *rhs.shape[nb : nb + nrf])
    contract = lhs.shape[nb + nlf :]
    out = np.empty(out_shape, dtype=object)

    def convert(v):
        if preferred_element_type is None:
            return v
        return lax.convert_element_type(v, preferred_element_type)

    for index in np.ndindex(out_shape):
        b, i, j = index[:nb], index[nb : nb + nlf], index[nb + nlf :]
        terms = [
            lax.mul(convert(lhs[(*b, *i, *k)]), convert(rhs[(*b, *j, *k)]))
            for k in np.ndindex(contract)
        ]
        out[index] = ft.reduce(lax.add, terms) if terms else None
    if contract and math.prod(contract) == 0 or any(v is None for v in out.reshape(-1)):
        return None  # an empty contraction: let XLA produce the zeros
    return out


def _reduce(combine):
    def rule(x, *, axes, **_):
        keep = [d for d in range(x.ndim) if d not in axes]
        moved = np.transpose(x, [*keep, *axes])
        out_shape = moved.shape[: len(keep)]
        reduced = moved.reshape(*out_shape, -1)
        if reduced.shape[-1] == 0:
            return None
        out = np.empty(out_shape, dtype=object)
        for index in np.ndindex(out_shape):
            out[index] = ft.reduce(combine, reduced[index])
        return out

    return rule


_STRUCTURAL: dict[str, Callable] = {
    "broadcast_in_dim": lambda x, **p: _broadcast_in_dim(x, **p),
    "reshape": lambda x, **p: _reshape(x, **p),
    "squeeze": lambda x, *, dimensions, **_: np.squeeze(x, axis=tuple(dimensions)),
    "expand_dims": lambda x, *, dimensions, **_: np.expand_dims(x, tuple(dimensions)),
    "transpose": lambda x, *, permutation, **_: np.transpose(x, permutation),
    "rev": lambda x, *, dimensions, **_: np.flip(x, axis=tuple(dimensions)),
    "slice": lambda x, **p: _slice(x, **p),
    "concatenate": lambda *xs, dimension, **_: np.concatenate(xs, axis=dimension),
    "stack": lambda *xs, axis, **_: np.stack(xs, axis=axis),
    "dot_general": lambda a, b, **p: _dot_general(a, b, **p),
    "reduce_sum": _reduce(lax.add),
    "reduce_max": _reduce(lax.max),
    "reduce_min": _reduce(lax.min),
    "reduce_prod": _reduce(lax.mul),
    "reduce_and": _reduce(lax.bitwise_and),
    "reduce_or": _reduce(lax.bitwise_or),
}


def _split_output(value, aval, limits: Limits):
    """Split a packed result, unless it is large."""
    if math.prod(aval.shape) > limits.max_size:
        return value
    return split(value, limits)


# --- The interpreter ------------------------------------------------------------------------


def _bind(eqn, args: Sequence):
    """Apply `eqn`'s primitive, with its parameters, to `args` (arrays)."""
    bind = eqn.primitive.get_bind_params(eqn.params)
    # JAX before 0.9 returns (subfunctions, parameters), later versions the parameters alone.
    subfuns, params = bind if isinstance(bind, tuple) else ((), bind)
    return eqn.primitive.bind(*subfuns, *args, **params)


def _call_packed(eqn, invals, limits: Limits):
    args = [pack(v, var.aval.dtype) for v, var in zip(invals, eqn.invars)]
    with eqn.ctx.manager:
        out = _bind(eqn, args)
    if eqn.primitive.multiple_results:
        return [_split_output(o, v.aval, limits) for o, v in zip(out, eqn.outvars)]
    return [_split_output(out, eqn.outvars[0].aval, limits)]


def _dot_products(eqn) -> int:
    """Scalar multiplications of a `dot_general`: output entries times contraction length."""
    (lc, _), _ = eqn.params["dimension_numbers"]
    lhs = eqn.invars[0].aval.shape
    contraction = math.prod(lhs[d] for d in lc)
    return math.prod(eqn.outvars[0].aval.shape) * contraction


def _eval_cond(eqn, invals, limits: Limits):
    index, *operands = invals
    if _is_split(index):
        index = pack(index, eqn.invars[0].aval.dtype)
    # Branches take and return flat lists of scalars (pytrees of leaves) so that lax.switch
    # sees only scalars; their structure is rebuilt inside.
    shapes = [np.shape(o) for o in operands]
    split_flags = [_is_split(o) for o in operands]
    flat = [list(o.reshape(-1)) if s else [o] for o, s in zip(operands, split_flags)]

    def rebuild(leaves):
        out, k = [], 0
        for shape, is_split, entries in zip(shapes, split_flags, flat):
            n = len(entries)
            if is_split:
                out.append(_object_array(leaves[k : k + n], shape))
            else:
                out.append(leaves[k])
            k += n
        return out

    def branch_fun(closed):
        def fun(leaves):
            results = eval_jaxpr(closed.jaxpr, closed.consts, rebuild(leaves), limits)
            return [pack(r, v.aval.dtype) for r, v in zip(results, closed.jaxpr.outvars)]

        return fun

    leaves = [entry for entries in flat for entry in entries]
    outs = lax.switch(index, [branch_fun(b) for b in eqn.params["branches"]], leaves)
    return [_split_output(o, v.aval, limits) for o, v in zip(outs, eqn.outvars)]


def _eval_barrier(invals):
    flat, spec = to_flat(list(invals))
    leaves, treedef = jtu.tree_flatten(flat)
    return from_flat(jtu.tree_unflatten(treedef, lax.optimization_barrier(leaves)), spec)


def _eval_custom_jvp(eqn, invals, limits: Limits):
    """A function with a custom derivative rule (e.g. `sig_pow`): its primal is scalarized, and
    its derivative is the original rule, applied to the re-assembled arrays."""
    in_avals = [v.aval for v in eqn.invars]
    if not all(jnp.issubdtype(a.dtype, jnp.floating) for a in in_avals):
        return None
    call = eqn.params["call_jaxpr"]
    in_spec = to_flat(list(invals))[1]
    out_avals = [v.aval for v in eqn.outvars]
    out_spec = (
        jtu.tree_structure([0] * len(out_avals)),
        tuple(a.shape if math.prod(a.shape) <= limits.max_size else None for a in out_avals),
    )

    def unflatten_in(leaves):
        return from_flat(tuple(_regroup(leaves, in_spec)), in_spec)

    @jax.custom_jvp
    def primal(*leaves):
        outs = eval_jaxpr(call.jaxpr, call.consts, unflatten_in(leaves), limits)
        return jtu.tree_leaves(to_flat([split(o, limits) for o in outs])[0])

    @primal.defjvp
    def rule(leaves, tangent_leaves):
        args = [pack(a, v.dtype) for a, v in zip(unflatten_in(leaves), in_avals)]
        tangents = [pack(a, v.dtype) for a, v in zip(unflatten_in(tangent_leaves), in_avals)]

        def original(*arrays):
            return _bind(eqn, arrays)

        outs, out_tangents = jax.jvp(original, args, tangents)
        flat_out = jtu.tree_leaves(to_flat([split(o, limits) for o in outs])[0])
        flat_tangent = jtu.tree_leaves(to_flat([split(o, limits) for o in out_tangents])[0])
        return flat_out, flat_tangent

    leaves = jtu.tree_leaves(to_flat(list(invals))[0])
    with eqn.ctx.manager:
        outs = primal(*leaves)
    grouped = from_flat(tuple(_regroup(outs, out_spec)), out_spec)
    return [_split_output(o, a, limits) for o, a in zip(grouped, out_avals)]


def _regroup(leaves, spec):
    """Group a flat list of scalars back into the per-leaf tuples of a `to_flat` spec."""
    _, shapes = spec
    out, k = [], 0
    for shape in shapes:
        n = 1 if shape is None else math.prod(shape)
        chunk = list(leaves[k : k + n])
        out.append(chunk[0] if shape is None else tuple(chunk))
        k += n
    return out


def _eval_eqn(eqn, invals, limits: Limits):
    name = eqn.primitive.name
    if name in ("pjit", "jit", "closed_call", "core_call"):
        inner = eqn.params.get("jaxpr") or eqn.params.get("call_jaxpr")
        if isinstance(inner, jex.ClosedJaxpr):
            return eval_jaxpr(inner.jaxpr, inner.consts, invals, limits)
        return eval_jaxpr(inner, (), invals, limits)
    if name == "cond":
        return _eval_cond(eqn, invals, limits)
    if name == "optimization_barrier":
        return _eval_barrier(invals)
    if name == "custom_jvp_call" and all(_is_split(v) for v in invals):
        out = _eval_custom_jvp(eqn, invals, limits)
        if out is not None:
            return out
    if invals and all(_is_split(v) for v in invals):
        params = dict(eqn.params)
        replacement = _vectorized(eqn)
        if replacement is not None:
            with eqn.ctx.manager:
                return [_entrywise(replacement, invals)]
        if name in _ELEMENTWISE or _is_elementwise_bitcast(eqn):
            with eqn.ctx.manager:
                return [_elementwise(eqn.primitive, params, invals)]
        rule = _STRUCTURAL.get(name)
        if name == "dot_general" and _dot_products(eqn) > limits.max_products:
            rule = None  # a large product stays one packed dot (no O(n^3) scalar program)
        if rule is not None:
            with eqn.ctx.manager:
                out = rule(*invals, **params)
            if out is not None:
                return list(out) if eqn.primitive.multiple_results else [out]
        if name == "dynamic_slice":
            out = _dynamic_slice(*invals, **params)
            if out is not None:
                return [out]
    return _call_packed(eqn, invals, limits)


def eval_jaxpr(
    jaxpr: jex.Jaxpr, consts: Sequence, args: Sequence, limits: Limits = DEFAULT_LIMITS
) -> list:
    """Evaluate `jaxpr` on split (object-array) or packed inputs; outputs split where small."""
    env: dict = {}

    def read(v):
        if isinstance(v, jex.Literal):
            return split(np.asarray(v.val, dtype=v.aval.dtype), limits)
        return env[v]

    for var, value in zip(jaxpr.constvars, consts):
        env[var] = _split_output(value, var.aval, limits)
    for var, value in zip(jaxpr.invars, args):
        env[var] = value
    for eqn in jaxpr.eqns:
        outs = _eval_eqn(eqn, [read(v) for v in eqn.invars], limits)
        # A dropped output (`DropVar`) is stored too: nothing reads it.
        env.update(zip(eqn.outvars, outs))
    return [read(v) for v in jaxpr.outvars]


def scalarize(fun: Callable, limits: Limits = DEFAULT_LIMITS) -> Callable:
    """`fun` evaluated entry by entry on its small arrays (same values; see the module).

    The returned function takes and returns the same pytrees as `fun`, but every small array
    leaf of its arguments and results may be given (and is returned) as its object array of
    scalars: [`split`][] and [`pack`][] convert. It traces `fun` at every call, with the
    shapes of the arguments.
    """

    def wrapped(*args):
        leaves, treedef = jtu.tree_flatten(args)
        avals = [jax.ShapeDtypeStruct(np.shape(x), _dtype(x)) for x in leaves]
        closed, out_shape = jax.make_jaxpr(
            lambda *flat: fun(*jtu.tree_unflatten(treedef, flat)), return_shape=True
        )(*avals)
        outs = eval_jaxpr(closed.jaxpr, closed.consts, leaves, limits)
        return jtu.tree_unflatten(jtu.tree_structure(out_shape), outs)

    return wrapped


def _dtype(x):
    if _is_split(x):
        first = x.reshape(-1)[0] if x.size else np.float64(0)
        return jnp.result_type(first)
    return jnp.result_type(x)


def split_tree(tree, limits: Limits = DEFAULT_LIMITS):
    """[`split`][] every leaf of a pytree."""
    return jtu.tree_map(lambda x: split(x, limits), tree)


def pack_tree(tree, like):
    """[`pack`][] every object-array leaf of `tree` (with the dtypes of `like`'s leaves)."""
    return jtu.tree_map(lambda x, ref: pack(x, jnp.result_type(ref)), tree, like, is_leaf=_is_split)


def _object_array(entries, shape) -> np.ndarray:
    out = np.empty(len(entries), dtype=object)
    for k, v in enumerate(entries):
        out[k] = v
    return out.reshape(shape)


def to_flat(tree) -> tuple[tuple, tuple]:
    """A pytree with object-array leaves as a tuple of scalars (a valid `lax.scan` carry),
    and the static spec that [`from_flat`][] rebuilds it with."""
    leaves, treedef = jtu.tree_flatten(tree, is_leaf=_is_split)
    shapes = tuple(x.shape if _is_split(x) else None for x in leaves)
    flat = tuple(tuple(x.reshape(-1)) if _is_split(x) else x for x in leaves)
    return flat, (treedef, shapes)


def from_flat(flat: tuple, spec: tuple):
    """Inverse of [`to_flat`][]."""
    treedef, shapes = spec
    leaves = [
        entries if shape is None else _object_array(entries, shape)
        for entries, shape in zip(flat, shapes)
    ]
    return jtu.tree_unflatten(treedef, leaves)


def scalarized_loop_step(
    step: Callable, module, carry0, limits: Limits = DEFAULT_LIMITS, *, outputs: bool = False
) -> tuple:
    r"""A `lax.scan` body for `carry = step(module, carry, i)` that runs on scalar entries.

    **Returns:** `(flat0, body, unflatten)`: the initial scan carry (`carry0` as a flat tuple of
    scalars), the scan body `(flat, i) -> (flat, None)`, and `unflatten(flat) -> carry`.

    With `outputs=True`, `step` returns `(carry, out)` and the body `(flat, flat_out)`, the
    outputs as scalars too; a fourth function, `unflatten_outputs(stacked)`, re-assembles what
    `lax.scan` stacked of them (each leaf gets the scan's axis first, as `lax.scan` would give
    for `step`'s own outputs).

    The body's forward pass is `step` scalarized. Its derivative rule (a `jax.custom_jvp`) is
    the JVP of `step` itself on re-assembled arrays: differentiating the scalarized program
    gives the same numbers but made XLA compile times explode (minutes for a 0.3 s gradient),
    so forward- and reverse-mode autodiff see the ordinary program. The arrays of `module` are
    explicit arguments of the rule, so gradients with respect to gains flow through it.
    """
    params, static = eqx.partition(module, eqx.is_array)
    flat0, spec = to_flat(split_tree(carry0, limits))
    scalar_step = scalarize(lambda p, carry, i: step(eqx.combine(p, static), carry, i), limits)

    def unflatten(flat):
        return pack_tree(from_flat(flat, spec), carry0)

    def to_scalars(result):
        if not outputs:
            return to_flat(split_tree(result, limits))[0]
        new, out = result
        return to_flat(split_tree(new, limits))[0], to_flat(split_tree(out, limits))[0]

    def plain(p, flat, i):
        return to_scalars(step(eqx.combine(p, static), unflatten(flat), i))

    @jax.custom_jvp
    def fast(p, flat, i):
        return to_scalars(
            scalar_step(split_tree(p, limits), from_flat(flat, spec), split(i, limits))
        )

    @fast.defjvp
    def _fast_jvp(primals, tangents):
        return jax.jvp(plain, primals, tangents)

    def body(flat, i):
        result = fast(params, flat, i)
        return result if outputs else (result, None)

    if not outputs:
        return flat0, body, unflatten
    out_shape = jax.eval_shape(lambda c: step(module, c, 0)[1], carry0)
    out_treedef = jtu.tree_structure(out_shape)

    def unflatten_outputs(stacked):
        leaves = []
        for entries, like in zip(stacked, jtu.tree_leaves(out_shape)):
            if math.prod(like.shape) > limits.max_size:
                leaves.append(entries)  # kept whole: already (steps, *shape)
            else:
                columns = jnp.stack(entries, axis=-1).astype(like.dtype)
                leaves.append(columns.reshape(*columns.shape[:-1], *like.shape))
        return jtu.tree_unflatten(out_treedef, leaves)

    return flat0, body, unflatten, unflatten_outputs
