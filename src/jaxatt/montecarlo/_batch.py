"""The one batch runner (`run_batch`) and `monte_carlo`, its checked, sharded front end.

`run_batch` is what every batched simulation in jaxatt runs: `monte_carlo`, the tuning
objectives, the scenarios' batched reproductions and the benchmarks. A tuning objective and a
Monte Carlo study with the same settings therefore run (and differentiate) the same time loop.
`monte_carlo` and the tuning objectives stream their metrics when every metric object can
(`stream=True`: reduced inside the loop, nothing saved); a metric function, or
`keep_trajectories=True`, reduces a saved trajectory instead (`stream=False`); both give the
same values.
"""

import inspect
from collections.abc import Callable, Mapping

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec
from jaxtyping import Array, ArrayLike, PyTree

from .._paths import parse_path, path_selector
from .._validation import check_flag, check_positive_int, check_tree_finite
from ..metrics import AbstractMetric
from ..simulation import (
    RK4,
    AbstractClosedLoop,
    AbstractFixedStepSolver,
    AbstractSampling,
    AbstractStream,
    Continuous,
    Performance,
    Simulation,
    Status,
    Trajectory,
    integrate,
    integrate_streaming,
    samples_at_once,
)
from ..simulation._compiled import compiled
from ..simulation._memory import check_saved_memory
from ..simulation._simulate import any_traced, check_closed_loop
from ._summary import MonteCarloResult


_BATCH_AXIS = "batch"

Metrics = Mapping[str, AbstractMetric] | Callable[[Trajectory], Mapping[str, Array]]
"""A dict name -> metric object (preferred), or a function `traj -> dict name -> array`."""


def default_metrics(closed_loop: AbstractClosedLoop, *, tolerance: float = 1e-2) -> dict:
    """The metrics [`monte_carlo`][] records when `metrics=None`: the closed loop's
    `default_metrics(tolerance)`, i.e. its plant's (for rigid bodies: `settling_time` of the
    attitude-error vector to `tolerance`, `peak_torque`, `effort`, `max_rate_error`)."""
    metrics = closed_loop.default_metrics(tolerance)
    if not metrics:
        raise ValueError(
            f"monte_carlo: {type(closed_loop).__name__} declares no default metrics; pass "
            "`metrics=` (a dict name -> metric object, e.g. "
            "{'settling_time': jaxatt.metrics.SettlingTime('error', 1e-2)})."
        )
    return metrics


def _failed_as(value: Array, ok: Array, failure_value: float) -> Array:
    """`value` where the sample succeeded, `failure_value` where it failed. A boolean or
    integer value becomes floating first: NaN cast to a boolean is True and to an integer
    undefined, so a failed sample would report a plausible flag or count."""
    value = jnp.asarray(value)
    if not jnp.issubdtype(value.dtype, jnp.inexact):
        value = value.astype(jnp.result_type(float))
    return jnp.where(ok, value, jnp.asarray(failure_value, value.dtype))


def evaluate_metrics(metrics: Metrics, traj: Trajectory) -> dict[str, Array]:
    """Per-sample metric values; a failed sample gets each metric's `failure_value` (`inf`
    for times, NaN otherwise; NaN for every value of a metric function). Boolean and integer
    values are returned as floats, so that a failed sample can hold NaN."""
    ok = traj.successful
    if isinstance(metrics, Mapping):
        return {
            str(name): _failed_as(metric(traj), ok, metric.failure_value)
            for name, metric in metrics.items()
        }
    values = metrics(traj)
    if not isinstance(values, Mapping):
        raise ValueError(
            "monte_carlo: `metrics(traj)` must return a dict name -> array, got "
            f"{type(values).__name__}."
        )
    return {str(name): _failed_as(value, ok, float("nan")) for name, value in values.items()}


class MetricStream(AbstractStream):
    """Metric objects reduced on the fly (their streaming protocol; see
    [`jaxatt.metrics.AbstractMetric`][]): the default of [`monte_carlo`][]."""

    metrics: dict

    def init(self, t, signals, t_last):
        return {name: m.stream_init(t, signals, t_last) for name, m in self.metrics.items()}

    def update(self, state, t, signals):
        return {name: m.stream_update(state[name], t, signals) for name, m in self.metrics.items()}

    def values(self, state: PyTree, ok: Array) -> dict[str, Array]:
        """Per-sample values; a failed sample gets each metric's `failure_value`."""
        return {
            name: _failed_as(metric.stream_value(state[name]), ok, metric.failure_value)
            for name, metric in self.metrics.items()
        }


def streamable(metrics: Metrics) -> bool:
    """Whether every metric of `metrics` can be reduced on the fly (a dict of metric objects
    that all implement the streaming protocol; a metric function cannot)."""
    return isinstance(metrics, Mapping) and all(
        getattr(metric, "streams", False) for metric in metrics.values()
    )


def _check_metrics(where: str, metrics) -> Metrics:
    if isinstance(metrics, Mapping):
        for name, metric in metrics.items():
            if not isinstance(metric, AbstractMetric):
                raise ValueError(
                    f"{where}: metric {name!r} must be a jaxatt.metrics metric object "
                    f"(SettlingTime, Peak, Effort, ...), got {type(metric).__name__}."
                )
        return dict(metrics)
    if not callable(metrics):
        raise ValueError(
            f"{where}: `metrics` must be a dict of metric objects or a function traj -> dict, "
            f"got {metrics!r}."
        )
    return metrics


def check_metric_records(where: str, metrics: Metrics, sim: Simulation) -> None:
    """Each metric object's [`check_record`][jaxatt.metrics.AbstractMetric.check_record] on
    the save times of `sim` (e.g. a chattering window that holds no save interval), before
    compiling."""
    if not isinstance(metrics, Mapping):
        return
    saves = sim.save_times()
    for name, metric in metrics.items():
        metric.check_record(where, str(name), saves)


def run_batch(
    closed_loop: AbstractClosedLoop,
    x0s: PyTree[Array],
    sim: Simulation,
    metrics: Metrics,
    *,
    batched: PyTree | None = None,
    keep_trajectories: bool = False,
    batch_size: int | None = None,
    stream: bool = False,
) -> MonteCarloResult:
    """Simulate every sample of a batch and reduce each to its metrics (traceable).

    Sample $k$ is `integrate(loop_k, x0s[k], sim)`, `loop_k` being `closed_loop` with the
    arrays of `batched` (a pytree of the loop's structure holding the batched fields, as
    `eqx.partition` makes) replaced by their $k$-th entries. No host-side checks: callers
    ([`monte_carlo`][], the tuning objectives) validate first (the states with
    [`check_batch_states`][]), and `sim.performance` must be resolved
    (`sim.with_performance(sim.performance.resolve(n))`).

    - `batch_size=None`: one `vmap` over the batch; else `lax.map` chunks of `batch_size`.
    - `stream`: reduce the metrics on the fly at every save time instead of from a saved
      trajectory (same values; see [`MetricStream`][]); requires `streamable(metrics)` and
      `keep_trajectories=False`.
    """
    if stream and (keep_trajectories or not streamable(metrics)):
        raise ValueError(
            "run_batch: `stream=True` needs metric objects that all stream and "
            "keep_trajectories=False."
        )

    def one(x):
        x0, loop_batch = x
        loop = closed_loop if loop_batch is None else eqx.combine(loop_batch, closed_loop)
        if stream:
            metric_stream = MetricStream(dict(metrics))
            run = integrate_streaming(loop, x0, sim, metric_stream)
            values = metric_stream.values(run.state, run.status == int(Status.successful))
            return values, run.status, run.failure_time, None
        traj = integrate(loop, x0, sim)
        values = evaluate_metrics(metrics, traj)
        return values, traj.status, traj.failure_time, traj if keep_trajectories else None

    def run(chunk):
        if batch_size is None:
            return jax.vmap(one)(chunk)
        return jax.lax.map(one, chunk, batch_size=batch_size)

    values, status, failure_time, trajs = run((x0s, batched))
    objects = metrics if isinstance(metrics, Mapping) else {}
    smallest_is_worst = tuple(name for name, m in objects.items() if m.worst == "smallest")
    time_metrics = tuple(name for name, m in objects.items() if m.is_time)
    return MonteCarloResult(
        metrics=values,
        status=status,
        failure_time=failure_time,
        trajectories=trajs,
        smallest_is_worst=smallest_is_worst,
        time_metrics=time_metrics,
    )


def _is_none(x) -> bool:
    return x is None


def _select(where) -> Callable:
    """A selector: `where` itself if callable, or the field at a dotted path."""
    if callable(where):
        return where
    return path_selector(where)


class _Path:
    """A leaf standing for the path to a leaf of the module (not a pytree itself)."""

    def __init__(self, keys):
        self.keys = keys


def _steps_from_keys(keys) -> tuple[tuple[str, object], ...]:
    steps = []
    for key in keys:
        if isinstance(key, jtu.GetAttrKey):
            steps.append(("attr", key.name))
        elif isinstance(key, jtu.SequenceKey):
            steps.append(("item", key.idx))
        elif isinstance(key, jtu.DictKey):
            steps.append(("item", key.key))
        else:
            return None
    return tuple(steps)


def _field_steps(module: PyTree, where) -> tuple[tuple[str, object], ...] | None:
    """The steps from `module` to the field `where` selects, or `None` if they cannot be found."""
    if isinstance(where, str):
        return parse_path(where)
    try:
        keyed = jtu.tree_map_with_path(lambda keys, _: _Path(keys), module)
        selected = where(keyed)
    except Exception:
        return None
    if isinstance(selected, _Path):
        return _steps_from_keys(selected.keys)
    inner = jtu.tree_flatten_with_path(selected, is_leaf=lambda x: isinstance(x, _Path))[0]
    if not inner or not isinstance(inner[0][1], _Path):
        return None
    relative, leaf = inner[0]
    return _steps_from_keys(leaf.keys[: len(leaf.keys) - len(relative)])


def _path_text(steps) -> str:
    text = ""
    for kind, key in steps:
        text += f".{key}" if kind == "attr" else f"[{key!r}]"
    return text.lstrip(".")


def _constructor_fields(module: eqx.Module) -> tuple[str, ...] | None:
    """The names of `module`'s constructor arguments if `type(module)(**fields)` rebuilds it
    exactly (the arguments are fields and the round trip gives an equal module), else `None`."""
    try:
        parameters = list(inspect.signature(type(module).__init__).parameters.values())[1:]
    except (TypeError, ValueError):
        return None
    names = []
    for parameter in parameters:
        if parameter.kind is inspect.Parameter.VAR_KEYWORD:
            continue
        if parameter.kind is inspect.Parameter.VAR_POSITIONAL:
            return None
        if parameter.name not in getattr(module, "__dataclass_fields__", {}):
            return None
        names.append(parameter.name)
    try:
        rebuilt = type(module)(**{name: getattr(module, name) for name in names})
        same = bool(eqx.tree_equal(rebuilt, module))
    except Exception:
        return None
    return tuple(names) if same else None


class _Rebuilder:
    """Re-runs the constructors of the modules that own (or lie inside) a replaced field."""

    def __init__(self):
        self._fields: dict[int, tuple[str, ...] | None] = {}

    def fields(self, module: eqx.Module, cache_key) -> tuple[str, ...] | None:
        if cache_key not in self._fields:
            self._fields[cache_key] = _constructor_fields(module)
        return self._fields[cache_key]

    def subtree(self, node, trail=()):
        """`node` with every module inside it rebuilt through its constructor, bottom-up."""
        if isinstance(node, eqx.Module):
            names = self.fields(node, ("in", trail))
            if names is None:
                return node
            return type(node)(
                **{name: self.subtree(getattr(node, name), (*trail, name)) for name in names}
            )
        if isinstance(node, (list, tuple)) and not hasattr(node, "_fields"):
            return type(node)(self.subtree(x, (*trail, i)) for i, x in enumerate(node))
        if isinstance(node, dict):
            return {k: self.subtree(v, (*trail, k)) for k, v in node.items()}
        return node

    def replace(self, node, steps, new, depth=0):
        """`node` with the field at `steps` replaced by `new`, rebuilding the modules on the way
        (their constructors check the new value, and cross-field rules, again)."""
        if depth == len(steps):
            return self.subtree(new)
        kind, key = steps[depth]
        child = getattr(node, key) if kind == "attr" else node[key]
        child = self.replace(child, steps, new, depth + 1)
        if isinstance(node, eqx.Module):
            names = self.fields(node, ("on", depth))
            if names is not None and kind == "attr" and key in names:
                return type(node)(**{n: child if n == key else getattr(node, n) for n in names})
            return eqx.tree_at(lambda m: getattr(m, key) if kind == "attr" else m[key], node, child)
        if isinstance(node, dict):
            return {**node, key: child}
        items = list(node)
        items[key] = child
        return type(node)(items)


def _check_batch_samples(module: PyTree, where, values: PyTree, size: int) -> None:
    """Refuse the first sample that the constructors of the modules owning the field refuse."""
    if any_traced((module, values)):
        return  # traced values: the constructors' own traced checks apply at run time
    steps = _field_steps(module, where)
    if not steps:
        return
    path = where if isinstance(where, str) else _path_text(steps)
    host = jtu.tree_map(np.asarray, values)
    rebuilder = _Rebuilder()
    for i in range(size):
        sample = jtu.tree_map(lambda x: x[i], host)
        try:
            rebuilder.replace(module, steps, sample)
        except (ValueError, TypeError) as error:
            raise ValueError(
                f"batch_field: values[{i}] for `{path}` is refused by its owner: {error}"
            ) from None


def batch_field(
    module: PyTree,
    where: Callable[[PyTree], PyTree] | str,
    values: PyTree[ArrayLike],
    in_axes: PyTree | None = None,
) -> tuple[PyTree, PyTree]:
    r"""Replace the leaf (or subtree) `where(module)` by a stacked batch and mark its axis.

    **Arguments:**
    - `module`: a pytree, typically a [`jaxatt.ClosedLoop`][].
    - `where`: selects the field, as in `eqx.tree_at` (e.g.
      `lambda loop: loop.plant.body.inertia`), or its dotted path (`"plant.body.inertia"`).
    - `values`: the batch: an array with a leading axis of length `n` and otherwise the shape
      of the field it replaces, or a pytree whose leaves all have leading axis `n` (e.g. the
      `Sinusoid` from [`sinusoid_dispersion`][]). Must be finite, and every sample must pass
      the checks of the modules that own the field (see below).
    - `in_axes`: the `in_axes` returned by a previous call, to batch several fields; `None`
      for the first call.

    **Returns:** `(batched_module, in_axes)`: the module with the batch in place, and a pytree
    of the module's structure with `0` at the batched fields and `None` elsewhere, for
    `jax.vmap`/`eqx.filter_vmap` (`in_axes=(in_axes, ...)`) or
    [`monte_carlo`][]`(..., loop_axes=in_axes)`.

    **Checks:** each sample is checked on the host, before anything is compiled, by the
    constructors that checked the field it replaces: the modules on the path to the field (and
    inside `values`, e.g. a `Sinusoid`) are rebuilt from their fields with sample $k$ in place,
    so `values[k]` meets the same rules as a module built with it (a gain must be positive, an
    inertia positive definite, ...). A refused sample raises a `ValueError` naming $k$, the
    field's path and the rule. A module whose constructor cannot rebuild it from its own fields
    (its arguments are not its fields, e.g. `RigidBodyMRP`, whose `body` is rebuilt instead) is
    left unchecked; with traced `values` the constructors' traced checks are not run either.
    The checks cost one constructor call per sample and module on the path: from well under a
    millisecond for a gain to about 0.5 ms for a `RigidBody` (0.52 s for 1000 inertias of Chen
    2022's loop on the 2-core Xeon, against 2.40 s when each rebuild traced its signals' shape
    check again, `benchmarks/bench_batch_field.py`; a signal's shape is traced once per signal
    object).

    !!! example
        ```python
        loop, axes = batch_field(loop, "plant.body.inertia", inertias)
        loop, axes = batch_field(loop, "plant.body.disturbance", signals, axes)
        result = monte_carlo(loop, x0s, 0.0, 10.0, dt=1e-3, loop_axes=axes)
        ```
    """
    where = _select(where)
    if in_axes is None:
        in_axes = jtu.tree_map(lambda _: None, module)
    try:
        current = where(in_axes)
    except (AttributeError, TypeError, IndexError, KeyError):
        current = 0
    if jtu.tree_leaves(current):  # unbatched fields hold only None (an empty pytree)
        raise ValueError(
            "batch_field: the field selected by `where` is already batched, or lies inside a "
            "batched field, according to `in_axes`."
        )
    old = where(module)
    values = jtu.tree_map(jnp.asarray, values)
    leaves = jtu.tree_leaves(values)
    if not leaves or any(leaf.ndim < 1 for leaf in leaves):
        raise ValueError(
            "batch_field: `values` must hold arrays with a leading batch axis, got "
            f"{type(values).__name__} with leaf shapes {[jnp.shape(x) for x in leaves]}."
        )
    sizes = {leaf.shape[0] for leaf in leaves}
    if len(sizes) != 1:
        raise ValueError(
            f"batch_field: every leaf of `values` must have the same leading axis, got {sizes}."
        )
    if isinstance(old, (jax.Array, np.ndarray)):
        if not isinstance(values, jax.Array) or values.shape[1:] != old.shape:
            raise ValueError(
                "batch_field: `values` must have shape (n, *field shape) = "
                f"(n, {', '.join(map(str, jnp.shape(old)))}), got "
                f"{jtu.tree_map(jnp.shape, values)}."
            )
    else:
        if jtu.tree_structure(values) != jtu.tree_structure(old):
            raise ValueError(
                "batch_field: `values` must have the pytree structure of the field it replaces "
                f"({type(old).__name__}), got {type(values).__name__}."
            )
    check_tree_finite("batch_field", "values", values)
    _check_batch_samples(module, where, values, sizes.pop())
    batched = eqx.tree_at(where, module, values)
    in_axes = eqx.tree_at(where, in_axes, 0, is_leaf=_is_none)
    return batched, in_axes


def _leading_size(where: str, name: str, tree: PyTree) -> int | None:
    leaves = jtu.tree_leaves(tree)
    if not leaves:
        return None
    shapes = [jnp.shape(leaf) for leaf in leaves]
    if any(len(s) == 0 for s in shapes) or len({s[0] for s in shapes}) != 1:
        raise ValueError(
            f"{where}: every array in `{name}` must have the same leading (batch) axis, got "
            f"shapes {shapes}."
        )
    return shapes[0][0]


def check_batch_states(
    where: str, closed_loop: AbstractClosedLoop, x0s: PyTree, name: str = "x0s"
) -> tuple[PyTree, int]:
    """The checked batch of initial states and its size: a non-empty leading axis shared by
    every array, and the closed loop's state checks (unit quaternions, finite values, one
    precision) on every sample. For the entry points that call [`run_batch`][] directly."""
    n = _leading_size(where, name, x0s)
    if n is None or n == 0:
        raise ValueError(f"{where}: `{name}` must be a non-empty batch of initial states.")
    return closed_loop.check_state(x0s, name, (n,)), n


def _loop_filter(loop_axes: PyTree, closed_loop: AbstractClosedLoop) -> PyTree[bool]:
    def expand(axis, subtree):
        if axis is not None and not (isinstance(axis, int) and axis == 0):
            raise ValueError(
                f"monte_carlo: the leaves of `loop_axes` must be 0 or None, got {axis!r}."
            )
        return jtu.tree_map(lambda _: axis == 0, subtree)

    try:
        return jtu.tree_map(expand, loop_axes, closed_loop, is_leaf=_is_none)
    except ValueError as error:
        if "loop_axes" in str(error):
            raise
        raise ValueError(
            "monte_carlo: `loop_axes` must have the structure of `closed_loop` (a prefix of "
            "it), as returned by batch_field."
        ) from None


def _pad(x: Array, size: int) -> Array:
    """Pad the leading axis to `size` with copies of the first sample (a valid input)."""
    extra = size - x.shape[0]
    if extra == 0:
        return x
    return jnp.concatenate([x, jnp.repeat(x[:1], extra, axis=0)], axis=0)


def _place(x: Array, sharding: NamedSharding) -> Array:
    """The batch array `x` (concrete: a traced batch is never sharded) placed by `sharding`."""
    if isinstance(x, jax.Array) and not x.is_fully_addressable:
        return jax.device_put(x, sharding)
    # Every process holds the full batch (same key, same draws); each supplies its shards.
    host = np.asarray(x)
    return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])


def _on_each_device(run: Callable, shared: tuple, xs: PyTree, sharding: NamedSharding) -> PyTree:
    """`run(*shared, xs)` for a batch `xs` sharded by `sharding`: one single-device program per
    device of this process on that device's samples, the outputs assembled into arrays
    sharded the same way (batch axis first).

    Each device runs the program one device runs for a batch of its size. One `jit` of the
    whole sharded batch instead (XLA's SPMD partitioning, what `monte_carlo` ran until
    2026-12-06) ran Chen 2022 M1's scalarized loop 2.5x slower on XLA:CPU for the same samples
    per device, and rounded differently (benchmarks/README.md, "Sharding: one program per
    device"). The arrays of `shared` (loop, settings, metrics) are copied to each device.
    """
    here = [d for d in sharding.mesh.devices.flat if d.process_index == jax.process_index()]
    parts = []
    for device in here:
        local_shared = jtu.tree_map(
            lambda a: jax.device_put(a, device) if isinstance(a, jax.Array) else a, shared
        )
        local_xs = jtu.tree_map(lambda a: _shard_on(a, device), xs)
        parts.append(run(*local_shared, local_xs))
    devices = sharding.mesh.devices.size

    def assemble(*arrays):
        shape = (arrays[0].shape[0] * devices, *arrays[0].shape[1:])
        return jax.make_array_from_single_device_arrays(shape, sharding, list(arrays))

    return jtu.tree_map(assemble, *parts)


def _shard_on(x: Array, device) -> Array:
    """The part of the sharded batch array `x` that `device` holds."""
    return next(shard.data for shard in x.addressable_shards if shard.device == device)


def split_batched_fields(
    where: str, closed_loop: AbstractClosedLoop, loop_axes: PyTree | None, n: int
) -> tuple[PyTree | None, AbstractClosedLoop]:
    """`(batched, unbatched)` parts of a closed loop whose fields `loop_axes` marks."""
    if loop_axes is None:
        return None, closed_loop
    batched, loop = eqx.partition(closed_loop, _loop_filter(loop_axes, closed_loop))
    sizes = {jnp.shape(leaf)[:1] for leaf in jtu.tree_leaves(batched)}
    if sizes != {(n,)}:
        raise ValueError(
            f"{where}: the batched fields of `closed_loop` (marked by `loop_axes`) must have "
            f"leading axis n = {n} (the batch size of `x0s`), got leading shapes "
            f"{sorted(sizes)}."
        )
    return batched, loop


def monte_carlo(
    closed_loop: AbstractClosedLoop,
    x0s: PyTree[ArrayLike],
    t0: float | int,
    t1: float | int,
    *,
    dt: float,
    metrics: Metrics | None = None,
    loop_axes: PyTree | None = None,
    sampling: AbstractSampling = Continuous(),
    solver: AbstractFixedStepSolver | dfx.AbstractSolver = RK4(),
    save_every: int = 1,
    keep_trajectories: bool = False,
    batch_size: int | None = None,
    shard: bool = True,
    performance: Performance | None = None,
) -> MonteCarloResult:
    r"""Simulate `closed_loop` from every initial state of a batch, in one compiled call (one
    per device when sharded).

    Sample $k$ is `simulate(loop_k, x0s[k], t0, t1, dt=dt, ..., throw=False)` where `loop_k`
    is `closed_loop` with its batched fields (marked by `loop_axes`, e.g. from
    [`batch_field`][]) replaced by their $k$-th entries; the metrics reduce each trajectory.
    The samples run in one `eqx.filter_jit` computation of [`run_batch`][] (one per device
    when sharded):

    - **vmap** over the batch (default), or **chunks** of `batch_size` samples with
      `jax.lax.map(..., batch_size=...)` when memory binds (the whole trajectory of every
      sample in flight is held in memory before the metrics reduce it);
    - **sharding** (`shard=True`, more than one device in `jax.devices()`): the batch axis is
      split over a 1-D `jax.sharding.Mesh` of all devices with
      `NamedSharding(mesh, PartitionSpec("batch"))`, padded to a multiple of the device count
      with copies of sample 0 (the padding is stripped from the result). Each device runs,
      without communication, the single-device program of its own samples (the program one
      device would run for that many), chunked by `batch_size` if given. On a CPU, XLA
      already spreads one device's kernels over the cores: forced host devices in one process
      ran 0.80-0.84x as fast as one device, one process per core (`jax.distributed`, each
      pinned to its core) 1.42-1.51x (Chen 2022 M1, 10 000 samples, 2 cores;
      `bench_devices.py`). For several hosts call `jax.distributed.initialize()` first, in
      every process, and build the same batch in every process (same keys): `jax.devices()`
      then lists every host's devices, each process supplies its own shards, and
      [`MonteCarloResult`][]'s summaries gather the metrics to every host. `shard=False` keeps
      everything on the default device.

    **Failures never abort the batch and never look good.** A sample that fails (non-finite
    state, invalid plant, a controller's constraint violation; see
    [`jaxatt.simulation.Status`][]) keeps its status and failure time, and its metric values
    are replaced by the metrics' `failure_value` (`inf` for times, NaN otherwise): summaries
    count it as failed, plots draw it as failed, and no mean includes it. Initial states are
    checked before compiling (shapes, finite values, unit quaternions), naming bad samples.

    **Arguments:**
    - `closed_loop`: any [`jaxatt.AbstractClosedLoop`][], possibly with batched fields.
    - `x0s`: the initial plant states with a leading batch axis `n`.
    - `t0`, `t1`, `dt`, `sampling`, `solver`, `save_every`: as [`jaxatt.simulate`][].
      `save_every` sets the resolution of the metrics (the samples they read) and of the
      kept trajectories.
    - `metrics`: a dict name -> metric object ([`jaxatt.metrics.SettlingTime`][],
      [`jaxatt.metrics.Peak`][], ...), or a function `traj -> dict`; `None` gives
      [`default_metrics`][]. Metric values may be scalars or one value per component.
    - `loop_axes`: the `in_axes` from [`batch_field`][] marking batched loop fields.
    - `keep_trajectories`: also return the batched [`jaxatt.Trajectory`][]. By default
      (`False`) nothing is stored: metric objects are reduced **on the fly** at every save
      time ([`MetricStream`][], the metrics' streaming protocol), so the default call
      (`save_every=1`, metrics at every step) costs about what the sparsest save costs, with
      the same values as reducing the saved trajectory (to round-off: the order of a sum). A
      metric function, or a metric object without a streaming form, is reduced from the
      saved trajectory instead. Saved trajectories that cannot fit in memory (every sample's
      when kept, the samples in flight otherwise) are refused before compiling, with the
      size they need.
    - `batch_size`: `lax.map` chunk size (memory); `shard`: see above.
    - `performance`: a [`jaxatt.simulation.Performance`][]; by default the loop is
      scalarized on CPU for 1000 or more samples run at once per device.

    **Returns:** a [`MonteCarloResult`][] (`metrics`, `status`, `failure_time`,
    `trajectories`, `summary()`).

    **Gradients:** without sharding (one device or `shard=False`) the underlying
    [`run_batch`][] is traceable, which is what the tuning objectives differentiate.
    """
    where = "monte_carlo"
    check_closed_loop(where, closed_loop)
    sim = Simulation(
        t0,
        t1,
        dt,
        sampling=sampling,
        solver=solver,
        save_every=save_every,
        performance=performance,
        where=where,
    )
    metrics = default_metrics(closed_loop) if metrics is None else metrics
    metrics = _check_metrics(where, metrics)
    check_metric_records(where, metrics, sim)
    keep_trajectories = check_flag(where, "keep_trajectories", keep_trajectories)
    if batch_size is not None:
        batch_size = check_positive_int("monte_carlo", "batch_size", batch_size)
    x0s, n = check_batch_states(where, closed_loop, x0s)
    batched, loop = split_batched_fields(where, closed_loop, loop_axes, n)
    devices = jax.devices() if shard else []
    at_once = samples_at_once(n, batch_size=batch_size, devices=max(1, len(devices)))
    sim = sim.with_performance(sim.performance.resolve(at_once))
    xs = (x0s, batched)
    stream = not keep_trajectories and streamable(metrics)
    if not stream:
        # Kept, every sample's trajectory is returned; reduced afterwards (metrics that cannot
        # stream), `at_once` of them are in flight.
        one = jtu.tree_map(lambda a: jax.ShapeDtypeStruct(a.shape[1:], a.dtype), xs)
        check_saved_memory(
            where,
            loop if batched is None else eqx.combine(one[1], loop),
            one[0],
            sim,
            samples=n if keep_trajectories else at_once,
            remedy=", or leave `keep_trajectories` off (the metrics stream)"
            if keep_trajectories
            else ", or lower `batch_size` (the samples in flight)",
        )
    sharding = None
    padded = n
    if len(devices) > 1 and not any_traced(xs):
        padded = -(-n // len(devices)) * len(devices)
        sharding = NamedSharding(
            Mesh(np.asarray(devices), (_BATCH_AXIS,)), PartitionSpec(_BATCH_AXIS)
        )
        xs = jtu.tree_map(lambda x: _place(_pad(jnp.asarray(x), padded), sharding), xs)

    def run(loop, sim, metrics, xs):
        # Checked on the host above: the program holds no host callback.
        return compiled(run_batch, sim.performance, (loop, xs))(
            loop,
            xs[0],
            sim,
            metrics,
            batched=xs[1],
            keep_trajectories=keep_trajectories,
            batch_size=batch_size,
            stream=stream,
        )

    if sharding is None:
        out = run(loop, sim, metrics, xs)
    else:
        out = _on_each_device(run, (loop, sim, metrics), xs, sharding)
    if padded != n:
        out = jtu.tree_map(lambda x: x[:n], out)
    return out
