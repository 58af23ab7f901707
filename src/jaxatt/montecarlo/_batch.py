"""`monte_carlo`: one compiled, batched (vmap / chunked / sharded) run of a closed loop."""

import numbers
from collections.abc import Callable, Mapping

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec
from jaxtyping import Array, ArrayLike, PyTree

from .._custom_types import Scalar
from .._validation import UNIT_QUATERNION_TOLERANCE
from ..metrics import control_effort, peak, settling_time
from ..numerics import safe_norm
from ..plants import QuaternionState
from ..simulation import (
    RK4,
    AbstractFixedStepSolver,
    AbstractSampling,
    ClosedLoop,
    Continuous,
    Trajectory,
    simulate,
)
from ..simulation._solvers import as_fixed_step_solver
from ._summary import MonteCarloResult


_BATCH_AXIS = "batch"

SCALARIZE_FROM = 1000
"""Batches (per device, or per `lax.map` chunk) from this size on are scalarized by default."""


def default_metrics(traj: Trajectory, *, tolerance: float = 1e-2) -> dict[str, Scalar]:
    r"""The metrics [`monte_carlo`][] records per sample when `metrics=None`.

    - `settling_time` [s]: last exit of the attitude-error magnitude from the band
      $\le$ `tolerance` ([`jaxatt.metrics.settling_time`][]; `inf` if not settled within the
      horizon). The magnitude is $\|e_v\|$ (components 1:4 of the error quaternion,
      $= \sin(\phi/2)$) for quaternion plants and $\|\sigma_e\|$ ($= \tan(\phi/4)$) for MRP
      plants.
    - `peak_torque` [N m]: $\max_{t,i}|u_i(t)|$ of the applied control.
    - `effort` [N^2 m^2 s]: $\int \|u\|^2 dt$ (trapezoid rule).
    - `max_rate_error` [rad/s]: $\max_t \|e_\omega(t)\|$.

    All are computed on the saved samples (so `save_every` sets their resolution). For
    another tolerance pass `metrics=functools.partial(default_metrics, tolerance=...)`
    (built once and reused, so that repeated runs do not recompile).

    **Arguments:**
    - `traj`: one (unbatched) trajectory.
    - `tolerance`: settling band, in the unit of the attitude-error magnitude.

    **Returns:** a dict of scalar arrays.
    """
    error = traj.signals["attitude_error"]
    vector = error[:, 1:] if error.shape[-1] == 4 else error
    u = traj.signals["u"]
    return {
        "settling_time": settling_time(traj.ts, safe_norm(vector), tolerance),
        "peak_torque": peak(u),
        "effort": control_effort(traj.ts, u),
        "max_rate_error": jnp.max(safe_norm(traj.signals["rate_error"])),
    }


def default_scalarize(n: int, *, batch_size: int | None = None, devices: int = 1) -> bool:
    """Whether [`monte_carlo`][] scalarizes by default: when the samples one device runs at
    once (its share of `n`, or the `lax.map` chunk if smaller) number `SCALARIZE_FROM` or
    more."""
    per_device = -(-n // max(1, devices))
    at_once = per_device if batch_size is None else min(batch_size, per_device)
    return at_once >= SCALARIZE_FROM


def _is_none(x) -> bool:
    return x is None


def batch_field(
    module: PyTree,
    where: Callable[[PyTree], PyTree],
    values: PyTree[ArrayLike],
    in_axes: PyTree | None = None,
) -> tuple[PyTree, PyTree]:
    r"""Replace the leaf (or subtree) `where(module)` by a stacked batch and mark its axis.

    **Arguments:**
    - `module`: a pytree, typically a [`jaxatt.ClosedLoop`][].
    - `where`: selects the field, as in `eqx.tree_at`, e.g.
      `lambda loop: loop.plant.body.inertia`.
    - `values`: the batch: an array with a leading axis of length `n` and otherwise the shape
      of the field it replaces, or a pytree whose leaves all have leading axis `n` (e.g. the
      `Sinusoid` from [`sinusoid_dispersion`][]).
    - `in_axes`: the `in_axes` returned by a previous call, to batch several fields; `None`
      for the first call.

    **Returns:** `(batched_module, in_axes)`: the module with the batch in place, and a pytree
    of the module's structure with `0` at the batched fields and `None` elsewhere, for
    `jax.vmap`/`eqx.filter_vmap` (`in_axes=(in_axes, ...)`) or
    [`monte_carlo`][]`(..., loop_axes=in_axes)`.

    !!! example
        ```python
        loop, axes = batch_field(loop, lambda m: m.plant.body.inertia, inertias)
        loop, axes = batch_field(loop, lambda m: m.plant.body.disturbance, signals, axes)
        result = monte_carlo(loop, x0s, 0.0, 10.0, dt=1e-3, loop_axes=axes)
        ```
    """
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


def _loop_filter(loop_axes: PyTree, closed_loop: ClosedLoop) -> PyTree[bool]:
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


def _check_quaternions(x0s: PyTree) -> None:
    if not isinstance(x0s, QuaternionState) or isinstance(x0s.q, jax.core.Tracer):
        return
    norms = np.linalg.norm(np.asarray(x0s.q), axis=-1)
    bad = np.flatnonzero(~(np.abs(norms - 1) <= UNIT_QUATERNION_TOLERANCE))
    if bad.size:
        raise ValueError(
            "monte_carlo: `x0s.q` must hold unit quaternions (| ||q|| - 1 | <= "
            f"{UNIT_QUATERNION_TOLERANCE:g}); samples {bad[:10].tolist()} are not (norms "
            f"{norms[bad[:10]].tolist()}). Normalize them first."
        )


def _check_positive_int(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"monte_carlo: `{name}` must be a positive integer, got {value!r}.")
    return int(value)


def _pad(x: Array, size: int) -> Array:
    """Pad the leading axis to `size` with copies of the first sample (a valid input)."""
    extra = size - x.shape[0]
    if extra == 0:
        return x
    return jnp.concatenate([x, jnp.repeat(x[:1], extra, axis=0)], axis=0)


def _place(x: Array, sharding: NamedSharding) -> Array:
    if isinstance(x, jax.core.Tracer):
        return jax.lax.with_sharding_constraint(x, sharding)
    if isinstance(x, jax.Array) and not x.is_fully_addressable:
        return jax.device_put(x, sharding)
    # Every process holds the full batch (same key, same draws); each supplies its shards.
    host = np.asarray(x)
    return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])


def _evaluate(metrics: Callable, traj: Trajectory) -> dict[str, Array]:
    values = metrics(traj)
    if not isinstance(values, Mapping):
        raise ValueError(
            "monte_carlo: `metrics(traj)` must return a dict name -> scalar array, got "
            f"{type(values).__name__}."
        )
    out = {}
    for name, value in values.items():
        value = jnp.asarray(value)
        if value.shape != ():
            raise ValueError(
                f"monte_carlo: metric {name!r} must be a scalar per sample, got shape "
                f"{value.shape}; return one entry per component instead."
            )
        out[str(name)] = value
    return out


@eqx.filter_jit
def _run(
    loop: ClosedLoop,
    xs: tuple[PyTree, PyTree],
    sampling: AbstractSampling,
    solver: AbstractFixedStepSolver,
    *,
    t0: float,
    t1: float,
    dt: float,
    metrics: Callable,
    save_every: int,
    keep_trajectories: bool,
    batch_size: int | None,
    sharding: NamedSharding | None,
    scalarize: bool,
) -> MonteCarloResult:
    def one(x):
        x0, batched = x
        sample_loop = loop if batched is None else eqx.combine(batched, loop)
        traj = simulate(
            sample_loop,
            x0,
            t0,
            t1,
            dt=dt,
            sampling=sampling,
            solver=solver,
            save_every=save_every,
            throw=False,
            scalarize=scalarize,
        )
        return _evaluate(metrics, traj), traj.result, traj if keep_trajectories else None

    def batch(chunk):
        if batch_size is None:
            return jax.vmap(one)(chunk)
        return jax.lax.map(one, chunk, batch_size=batch_size)

    if sharding is None:
        values, result, trajs = batch(xs)
    else:
        # (n, ...) -> (devices, n / devices, ...): the device axis is vmapped and sharded; each
        # device runs its own samples (in chunks of `batch_size`) with no communication.
        shards = sharding.mesh.devices.size
        split = jtu.tree_map(lambda x: x.reshape(shards, -1, *x.shape[1:]), xs)
        split = jtu.tree_map(lambda x: jax.lax.with_sharding_constraint(x, sharding), split)
        out = jax.vmap(batch)(split)
        out = jtu.tree_map(lambda x: jax.lax.with_sharding_constraint(x, sharding), out)
        values, result, trajs = jtu.tree_map(lambda x: x.reshape(-1, *x.shape[2:]), out)
    return MonteCarloResult(metrics=values, result=result, trajectories=trajs)


def monte_carlo(
    closed_loop: ClosedLoop,
    x0s: PyTree[ArrayLike],
    t0: float | int,
    t1: float | int,
    *,
    dt: float,
    metrics: Callable[[Trajectory], Mapping[str, Array]] | None = None,
    loop_axes: PyTree | None = None,
    sampling: AbstractSampling = Continuous(),
    solver: AbstractFixedStepSolver | dfx.AbstractSolver = RK4(),
    save_every: int = 1,
    keep_trajectories: bool = False,
    batch_size: int | None = None,
    shard: bool = True,
    scalarize: bool | None = None,
) -> MonteCarloResult:
    r"""Simulate `closed_loop` from every initial state of a batch, in one compiled call.

    Sample $k$ is `simulate(loop_k, x0s[k], t0, t1, dt=dt, ..., throw=False)` where `loop_k`
    is `closed_loop` with its batched fields (marked by `loop_axes`, e.g. from
    [`batch_field`][]) replaced by their $k$-th entries; `metrics(traj)` reduces each
    trajectory to scalars. All samples run in one `eqx.filter_jit` computation:

    - **vmap** over the batch (default), or **chunks** of `batch_size` samples with
      `jax.lax.map(..., batch_size=...)` when memory binds (the whole trajectory of every
      sample in flight is held in memory before the metrics reduce it);
    - **sharding** (`shard=True`, more than one device in `jax.devices()`): the batch axis is
      split over a 1-D `jax.sharding.Mesh` of all devices with
      `NamedSharding(mesh, PartitionSpec("batch"))`, padded to a multiple of the device count
      with copies of sample 0 (the padding is stripped from the result). Each device simulates
      its own samples without communication, chunked by `batch_size` if given. For several
      hosts call `jax.distributed.initialize()` first, in every process, and build the same
      batch in every process (same keys): `jax.devices()` then lists every host's devices,
      each process supplies its own shards, and [`MonteCarloResult`][]'s summaries gather the
      metrics to every host. `shard=False` keeps everything on the default device.

    A sample that fails (non-finite state, a controller's constraint violation) never aborts
    the batch: its outcome is kept in `result` and counted by the summaries. Non-unit initial
    quaternions are a configuration error and raise before compiling.

    **Arguments:**
    - `closed_loop`: a [`jaxatt.ClosedLoop`][], possibly with batched fields.
    - `x0s`: the batch of plant initial states, e.g. `QuaternionState(q, omega)` with `q` of
      shape `(n, 4)` and `omega` of shape `(n, 3)`.
    - `t0`, `t1`, `dt`: Python numbers [s], static as in [`jaxatt.simulate`][] (changing them
      recompiles; changing the values in `x0s` or in the loop does not).
    - `metrics`: `traj -> dict[str, scalar array]` for one trajectory; default
      [`default_metrics`][]. It is static: define it once (a new lambda per call
      recompiles).
    - `loop_axes`: `None` (nothing batched in the loop) or the `in_axes` pytree of
      [`batch_field`][]: 0 at fields with a leading batch axis of length `n`, `None` elsewhere.
    - `sampling`, `solver`, `save_every`: as in [`jaxatt.simulate`][].
    - `keep_trajectories`: also return the batched trajectories (memory: `n` times the saved
      trajectory; use a large `save_every` for big batches).
    - `batch_size`: samples per `lax.map` chunk (per device when sharded); `None` vmaps the
      whole batch at once.
    - `shard`: shard the batch over all devices when there are several.
    - `scalarize`: run every sample with `simulate(..., scalarize=True)`: the batch then
      lowers to elementwise code on one `(batch,)` array per state component, which on a
      2-core CPU was 1.5-3x faster from about 1000 samples on, at about twice the compile
      time, and no faster below (benchmarks/README.md). `None` (default) scalarizes batches of
      at least `SCALARIZE_FROM` = 1000 samples (per device when sharded).

    **Returns:** a [`MonteCarloResult`][] (`metrics`, `result`, `trajectories`, `summary()`).

    **Gradients:** without sharding (one device or `shard=False`) the call is traceable, so a
    loss built from its metrics can be differentiated with `eqx.filter_grad` with respect to
    the loop's arrays and `x0s` (as for `simulate`).
    """
    where = "monte_carlo"
    if not isinstance(closed_loop, ClosedLoop):
        raise ValueError(
            f"{where}: `closed_loop` must be a jaxatt ClosedLoop, got {type(closed_loop).__name__}."
        )
    metrics = default_metrics if metrics is None else metrics
    if not callable(metrics):
        raise ValueError(f"{where}: `metrics` must be callable (traj -> dict), got {metrics!r}.")
    save_every = _check_positive_int("save_every", save_every)
    if batch_size is not None:
        batch_size = _check_positive_int("batch_size", batch_size)
    n = _leading_size(where, "x0s", x0s)
    if n is None or n == 0:
        raise ValueError(f"{where}: `x0s` must be a non-empty batch of initial states.")
    if loop_axes is None:
        batched, loop = None, closed_loop
    else:
        batched, loop = eqx.partition(closed_loop, _loop_filter(loop_axes, closed_loop))
        sizes = {jnp.shape(leaf)[:1] for leaf in jtu.tree_leaves(batched)}
        if sizes != {(n,)}:
            raise ValueError(
                f"{where}: the batched fields of `closed_loop` (marked by `loop_axes`) must have "
                f"leading axis n = {n} (the batch size of `x0s`), got leading shapes "
                f"{sorted(sizes)}."
            )
    _check_quaternions(x0s)
    xs = (x0s, batched)
    if scalarize is None:
        devices = len(jax.devices()) if shard else 1
        scalarize = default_scalarize(n, batch_size=batch_size, devices=devices)
    devices = jax.devices() if shard else []
    sharding = None
    padded = n
    if len(devices) > 1:
        padded = -(-n // len(devices)) * len(devices)
        sharding = NamedSharding(
            Mesh(np.asarray(devices), (_BATCH_AXIS,)), PartitionSpec(_BATCH_AXIS)
        )
        xs = jtu.tree_map(lambda x: _place(_pad(jnp.asarray(x), padded), sharding), xs)
    out = _run(
        loop,
        xs,
        sampling,
        as_fixed_step_solver(solver),
        t0=t0,
        t1=t1,
        dt=dt,
        metrics=metrics,
        save_every=save_every,
        keep_trajectories=bool(keep_trajectories),
        batch_size=batch_size,
        sharding=sharding,
        scalarize=bool(scalarize),
    )
    if padded != n:
        out = jtu.tree_map(lambda x: x[:n], out)
    return out
