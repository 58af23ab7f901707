r"""The fixed-step time loop every simulation runs (`simulate`, the batch runner, objectives).

One step from $t_i$ to $t_{i+1} = t_i + dt$:

1. under a zero-order hold, at a sample instant ($i$ a multiple of the steps per sample,
   $i > 0$): the flight software's discrete update, then its held outputs (with an optional
   one-period delay of the command);
2. one solver step of the continuous dynamics;
3. the physical parts' discrete updates at $t_{i+1}$ (and their events), then, under
   continuous control, the flight software's;
4. the status check at $t_{i+1}$ (the first failure and its time are kept).

Signals are recorded at the save times from the state after these updates.
"""

import abc

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.lax as lax
import jax.numpy as jnp
import jax.tree_util as jtu
from jaxtyping import Array, PyTree

from ._closed_loop import AbstractClosedLoop, HeldOutputs
from ._pairing import Paired, pair, plan_pairs, signal_dependencies, unpair
from ._scalarize import scalarized_loop_step
from ._settings import Simulation
from ._trajectory import EVENT_CAPACITY, EventRecord, Trajectory


def _record_events(events: dict, flags: dict, t: Array) -> dict:
    out = {}
    for name, record in events.items():
        flag = jnp.asarray(flags[name])
        slot = jnp.arange(EVENT_CAPACITY) == record.count
        times = jnp.where(flag & slot, t, record.times)
        out[name] = EventRecord(record.count + flag.astype(record.count.dtype), times)
    return out


INNER_LOOP_STEPS = 4
"""How many iterations the innermost time loops run at once: an innermost loop of n > 64
iterations runs as n / k chunks of k, where k is the largest divisor of n not above this (the
smallest divisor up to 64 if none of 2..4 divides n; a loop of a prime length above 64 runs
unchunked, so that no remainder loop doubles the compiled step). Shorter loops, and loops
around loops, stay as they are. The same calls in the same order: the results are
the same to the bit.

XLA:CPU runs short innermost loops of small kernels much faster per iteration than long ones
(the mechanism inside XLA's runtime was not traced). One trajectory of Chen 2022 M1 (jax
0.10.2, 2-core Xeon, 2026-12-06): saving every k steps, the step took 3.3 us for k = 2 to 64
and 9.0-10.5 us for k >= 70; saving every step (a larger body, with outputs), 5.7 us in
chunks of 4, 5.8 us of 8 or 16, 10.5 us of 32, 12.2 us of 64, 9.4-10.7 us unchunked. Zhang
2021's hover, saving every step: 57-58 us in chunks of 4, 105-112 us of 8, 82-96 us unchunked.
Batches of 32 to 10 000 samples ran the same either way (benchmarks/README.md, "Short inner
loops")."""

_LONGEST_CHUNK = 64


def _chunk(length: int) -> int | None:
    """The chunk length of a loop of `length` iterations ([`INNER_LOOP_STEPS`][]), or `None`
    to run it as one loop."""
    if length <= _LONGEST_CHUNK:
        return None
    divisors = [d for d in range(2, _LONGEST_CHUNK + 1) if length % d == 0]
    short = [d for d in divisors if d <= INNER_LOOP_STEPS]
    if short:
        return max(short)
    return min(divisors) if divisors else None


def _scan(body, carry, xs, length: int):
    """`lax.scan(body, carry, xs)` (`xs` of leading length `length`, or `None`) as a loop over
    chunks of [`_chunk`][]`(length)` iterations: the same calls in the same order, the outputs
    stacked as `lax.scan` stacks them."""
    chunk = _chunk(length)
    if chunk is None:
        return lax.scan(body, carry, xs, length=length)
    chunks = length // chunk

    def run_chunk(carry, x):
        return lax.scan(body, carry, x, length=chunk)

    split = (
        None if xs is None else jtu.tree_map(lambda a: a.reshape(chunks, chunk, *a.shape[1:]), xs)
    )
    carry, ys = lax.scan(run_chunk, carry, split, length=chunks)
    return carry, jtu.tree_map(lambda y: y.reshape(length, *y.shape[2:]), ys)


def _scan_intervals(body, carry, n: int, sim: Simulation, *, innermost: bool):
    """`lax.scan(body, carry, jnp.arange(n))` over the save intervals, stored for reverse mode
    as `sim.checkpoint` says: each interval under `jax.checkpoint` (`True`), with equinox's
    online treeverse (`"recursive"`, `equinox.internal.scan(kind="checkpointed")`: at most
    `sim.checkpoints` stored loop states; one loop), or not at all (`False`). `innermost`: the
    intervals hold no loop of their own (one step each), so the loop runs in chunks
    ([`_scan`][]); a loop around short loops stays one loop (chunking it gained nothing and
    made Zhang 2021's reverse-mode gradient check 1.24x slower to build)."""
    if sim.checkpoint == "recursive":
        # The treeverse recomputes an interval from its stored start and differentiates that
        # one call: a `jax.checkpoint` inside would recompute it a second time.
        return eqxi.scan(
            body, carry, jnp.arange(n), kind="checkpointed", checkpoints=sim.checkpoints
        )
    if sim.checkpoint:
        body = jax.checkpoint(body)
    if innermost:
        return _scan(body, carry, jnp.arange(n), n)
    return lax.scan(body, carry, jnp.arange(n))


def _scan_body(step, module, carry0, sim: Simulation, *, outputs: bool = False) -> tuple:
    """The `lax.scan` body running `carry = step(module, carry, i)` (with `outputs=True`,
    `step` returns `(carry, out)`), as [`scalarized_loop_step`][] returns it: `(flat0, body,
    unflatten)`, and `unflatten_outputs` with `outputs=True`.

    Scalarized (`._scalarize`) when `sim.performance.scalarize`; otherwise the step as it is,
    `flat0` is `carry0` and the unflattens are the identity.
    """
    if sim.performance.scalarize:
        return scalarized_loop_step(step, module, carry0, sim.performance.limits, outputs=outputs)

    def body(carry, i):
        result = step(module, carry, i)
        return result if outputs else (result, None)

    def identity(tree):
        return tree

    return (carry0, body, identity, identity) if outputs else (carry0, body, identity)


class Streamed(eqx.Module):
    """What [`integrate_streaming`][] returns: the stream's final state, and the run's status,
    failure time and events as in a [`Trajectory`][] (nothing else is stored)."""

    state: PyTree
    status: Array
    failure_time: Array
    events: dict


class AbstractStream(eqx.Module):
    """Something that reduces a run's signals on the fly, one save time at a time (e.g. the
    metrics of a Monte Carlo study): `init` on the first saved sample, `update` on each
    following one, in time order. Its arrays are arguments of the compiled program."""

    @abc.abstractmethod
    def init(self, t: Array, signals: dict[str, Array], t_last: Array) -> PyTree:
        """The state after the first sample (time `t`); `t_last` is the last save time."""

    @abc.abstractmethod
    def update(self, state: PyTree, t: Array, signals: dict[str, Array]) -> PyTree:
        """The state after one more sample at time `t`."""


def integrate(closed_loop: AbstractClosedLoop, x0: PyTree[Array], sim: Simulation) -> Trajectory:
    """Run the time loop of `sim` from the plant state `x0` (traceable; no host checks).

    `sim.performance.scalarize` must already be decided (`Performance.resolve`).

    The signals of a save time are those of the state after that time's updates. When every
    step saves, under continuous control, with a solver that `takes_start_derivative`, step
    $i$ computes the signals of $t_i$ with the flight-software outputs its first stage uses
    (one evaluation for both), scalarized or not; otherwise each save interval computes them
    at its end.
    """
    return _run(closed_loop, x0, sim, None)


def integrate_streaming(
    closed_loop: AbstractClosedLoop, x0: PyTree[Array], sim: Simulation, stream: AbstractStream
) -> Streamed:
    r"""Run the time loop of `sim` and hand the signals of every save time to `stream`,
    storing nothing (traceable; no host checks).

    The samples `stream` sees are exactly the saved signals of [`integrate`][] (same times, same
    right-continuous outputs under a zero-order hold), so a stream's result equals the same
    reduction of the saved trajectory. The signals of save time $t_i$ are computed at the start
    of step $i$, from the state that step starts from (the final sample after the loop):

    - when every step saves, under continuous control, with a solver that
      `takes_start_derivative` (`RK4`, `Euler`): one evaluation of the flight software at
      $(t_i, y_i)$ serves both the signals and the step's first stage $f(t_i, y_i)$;
    - otherwise inside the step when every step saves or the step is scalarized;
    - once per save interval, before its steps, in the remaining case (unscalarized, saving
      every k > 1 steps: no `lax.cond` in the step, a smaller program to compile and to
      differentiate).
    """
    return _run(closed_loop, x0, sim, stream)


def _run(closed_loop, x0, sim, stream):
    dtype = jnp.result_type(*jtu.tree_leaves(x0))
    sim.check_clock(dtype)
    t0, dt, sps, delay = sim.t0, sim.dt, sim.steps_per_sample, sim.sampling.delay

    def time(i) -> Array:
        return jnp.asarray(t0 + jnp.asarray(i) * dt, dtype=dtype)

    # Under a delay the actuator receives zeros over the first period: a stateful one (a
    # lag) starts from that command, not from the first computed one, which reaches it at t_1.
    y0 = (closed_loop.init_delayed if sps and delay else closed_loop.init)(time(0), x0)
    held0 = pending0 = None
    if sps:
        held0 = closed_loop.hold(time(0), y0)
        if delay:
            pending0 = held0.command
            held0 = HeldOutputs(
                jtu.tree_map(jnp.zeros_like, held0.command),
                held0.controller_dot,
                held0.observer_dot,
            )
    flags0 = jax.eval_shape(closed_loop.physics_update, time(0), y0)[1]
    events0 = {
        name: EventRecord(jnp.zeros((), jnp.int32), jnp.full(EVENT_CAPACITY, jnp.nan, dtype))
        for name in flags0
    }
    status0 = jnp.asarray(closed_loop.status(time(0), y0), jnp.int32)
    failure0 = jnp.where(status0 != 0, time(0), jnp.inf).astype(dtype)
    solver_state0 = sim.solver.init(closed_loop, time(0), dt, y0, held0)

    def sample(loop, t, y, held, pending):
        y = loop.flight_update(t, y)
        fresh = loop.hold(t, y)
        if not delay:
            return y, fresh, pending
        held = HeldOutputs(pending, fresh.controller_dot, fresh.observer_dot)
        return y, held, fresh.command

    def one_step(loop, carry, i, start_derivative=None):
        """Step i; `start_derivative`, if given, is $f(t_i, y_i)$ (solvers that take it)."""
        y, held, pending, solver_state, status, failure_time, events = carry
        t = time(i)
        if sps:
            y, held, pending = lax.cond(
                (i % sps == 0) & (i > 0),
                lambda: sample(loop, t, y, held, pending),
                lambda: (y, held, pending),
            )
        given = {} if start_derivative is None else {"start_derivative": start_derivative}
        y, solver_state = sim.solver.step(loop, t, dt, y, held, solver_state, **given)
        t_next = time(i + 1)
        y, flags = loop.physics_update(t_next, y)
        if not sps:
            y = loop.flight_update(t_next, y)
        events = _record_events(events, flags, t_next)
        code = jnp.asarray(loop.status(t_next, y), jnp.int32)
        first = (status == 0) & (code != 0)
        status = jnp.where(first, code, status)
        failure_time = jnp.where(first, t_next, failure_time)
        return y, held, pending, solver_state, status, failure_time, events

    # Under continuous control the signals of t_i and a solver's first stage f(t_i, y_i) need
    # the same flight-software outputs. When every step saves, the loops evaluate them once,
    # at the start of the step, for both. (XLA did not merge the two evaluations: 17
    # `exp`/`log` pairs per step against 14 for Chen 2022's loop; benchmarks/README.md.)
    shares_first_stage = sim.save_every == 1 and not sps and sim.solver.takes_start_derivative

    def observe_at_start(loop, y, i):
        """The signals of $t_i$ and $f(t_i, y_i)$, from one evaluation of the flight software."""
        t = time(i)
        flight = loop.hold(t, y)  # under continuous control: the outputs at (t_i, y_i)
        return loop.signals(t, y, flight), loop.vector_field(t, y, flight)

    carry0 = (y0, held0, pending0, solver_state0, status0, failure0, events0)
    if stream is not None:
        start = observe_at_start if shares_first_stage else None
        return _run_streaming(closed_loop, sim, stream, one_step, sample, time, carry0, start)
    if shares_first_stage:
        return _run_saving_every_step(closed_loop, sim, one_step, observe_at_start, time, carry0)
    # Scalarized, the time loop runs on scalar entries (a struct of arrays under vmap).
    flat0, step, unflatten = _scan_body(one_step, closed_loop, carry0, sim)
    every = sim.save_every
    n_intervals = sim.n_steps // every

    def save_interval(flat, j):
        flat, _ = _scan(step, flat, j * every + jnp.arange(every), every)
        y, held, pending, *_ = unflatten(flat)
        i_end = (j + 1) * every
        t_end = time(i_end)
        y_signals = y
        if sps:
            # Right-continuous outputs: at a sample instant, the outputs of the new sample.
            y_signals, held, _ = lax.cond(
                i_end % sps == 0,
                lambda: sample(closed_loop, t_end, y, held, pending),
                lambda: (y, held, pending),
            )
        return flat, (y, closed_loop.signals(t_end, y_signals, held))

    flat, (ys, signals) = _scan_intervals(
        save_interval, flat0, n_intervals, sim, innermost=every == 1
    )
    *_, status, failure_time, events = unflatten(flat)
    signals0 = closed_loop.signals(time(0), y0, held0)
    return Trajectory(
        ts=time(jnp.arange(n_intervals + 1) * every),
        states=jtu.tree_map(_prepend, y0, ys),
        signals=jtu.tree_map(_prepend, signals0, signals),
        status=status,
        failure_time=failure_time,
        events=events,
    )


def _prepend(first, rest):
    return jnp.concatenate([first[None], rest], axis=0)


def _append(rest, last):
    return jnp.concatenate([rest, last[None]], axis=0)


def _run_saving_every_step(closed_loop, sim, one_step, observe_at_start, time, carry0):
    """[`integrate`][]'s loop when every step saves and shares its first stage: step $i$ saves
    the signals of $t_i$ (with $y_{i+1}$); the signals of the last time come after the loop."""

    def save_step(loop, carry, i):
        signals, start_derivative = observe_at_start(loop, carry[0], i)
        carry = one_step(loop, carry, i, start_derivative)
        return carry, (carry[0], signals)

    flat0, body, unflatten, unflatten_outputs = _scan_body(
        save_step, closed_loop, carry0, sim, outputs=True
    )
    flat, stacked = _scan_intervals(body, flat0, sim.n_steps, sim, innermost=True)
    ys, signals = unflatten_outputs(stacked)
    y, *_, status, failure_time, events = unflatten(flat)
    last = closed_loop.signals(time(sim.n_steps), y, None)
    return Trajectory(
        ts=time(jnp.arange(sim.n_steps + 1)),
        states=jtu.tree_map(_prepend, carry0[0], ys),
        signals=jtu.tree_map(_append, signals, last),
        status=status,
        failure_time=failure_time,
        events=events,
    )


def _run_streaming(
    closed_loop, sim, stream, one_step, sample, time, carry0, observe_at_start
) -> Streamed:
    """[`integrate_streaming`][]'s loop: the stream's state rides in the step's carry.

    `observe_at_start(loop, y, i) -> (signals, f(t_i, y_i))`, or `None` where the signals and
    the first stage cannot share an evaluation (a hold, a solver without `start_derivative`,
    saves every k > 1 steps).
    """
    y0, held0 = carry0[0], carry0[1]
    sps, every = sim.steps_per_sample, sim.save_every

    def observed(loop, y, held, pending, t, i):
        """The signals saved at time t_i (after the sample update due at i, if any)."""
        if sps:
            y, held, _ = lax.cond(
                (i % sps == 0) & (i > 0),
                lambda: sample(loop, t, y, held, pending),
                lambda: (y, held, pending),
            )
        return loop.signals(t, y, held)

    def update(loop, strm, inner, state, i):
        """The stream's state after the signals of save time t_i."""
        y, held, pending = inner[:3]
        return strm.update(state, time(i), observed(loop, y, held, pending, time(i), i))

    def keep_initial(i, new, state):
        """`new`, except at i = 0, whose sample `stream.init` already took."""
        return jtu.tree_map(lambda a, b: jnp.where(i > 0, a, b), new, state)

    def streaming_step(module, carry, i):
        loop, strm = module
        inner, state = carry
        if observe_at_start is not None:
            # Every step saves: update unconditionally, sharing the first stage.
            signals, start_derivative = observe_at_start(loop, inner[0], i)
            new = strm.update(state, time(i), signals)
            return one_step(loop, inner, i, start_derivative), keep_initial(i, new, state)
        if every == 1:
            # Every step saves (a hold, or a solver without `start_derivative`): update
            # unconditionally.
            state = keep_initial(i, update(loop, strm, inner, state, i), state)
        else:
            state = lax.cond(
                (i % every == 0) & (i > 0),
                lambda s: update(loop, strm, inner, s, i),
                lambda s: s,
                state,
            )
        return one_step(loop, inner, i), state

    def plain_step(module, carry, i):
        """A step that leaves the stream's state alone (it is updated per interval)."""
        inner, state = carry
        return one_step(module[0], inner, i), state

    t_last = time(sim.n_steps)
    signals0 = closed_loop.signals(time(0), y0, held0)
    state0 = stream.init(time(0), signals0, t_last)
    # Unscalarized, saving every k > 1 steps: one observation per save interval, before its
    # steps (in `interval`), instead of a `lax.cond` in every step: a smaller program to
    # compile and differentiate, the same values.
    per_interval = every > 1 and not sim.performance.scalarize
    if sim.performance.scalarize:
        # Carry the stream's fresh values two per complex number: one XLA:CPU kernel each
        # (`._pairing`; same values).
        reads = signal_dependencies(lambda s, x: stream.update(s, time(0), x), state0, signals0)
        pairs = plan_pairs(jtu.tree_leaves(state0), reads)
        stream = _PairedStream(stream, pairs)
        state0 = pair(state0, pairs)
    flat0, step, unflatten = _scan_body(
        plain_step if per_interval else streaming_step, (closed_loop, stream), (carry0, state0), sim
    )

    def interval(flat, j):
        i = j * every
        if per_interval:
            inner, state = flat
            flat = (inner, keep_initial(i, update(closed_loop, stream, inner, state, i), state))
        flat, _ = _scan(step, flat, i + jnp.arange(every), every)
        return flat, None

    flat, _ = _scan_intervals(interval, flat0, sim.n_steps // every, sim, innermost=every == 1)
    inner, state = unflatten(flat)
    y, held, pending, _, status, failure_time, events = inner
    signals = observed(closed_loop, y, held, pending, t_last, sim.n_steps)
    state = stream.update(state, t_last, signals)
    if isinstance(state, Paired):
        state = unpair(state)
    return Streamed(state, status, failure_time, events)


class _PairedStream(AbstractStream):
    """`stream` with its state held as a `._pairing.Paired` (complex pairs; same values)."""

    stream: AbstractStream
    pairs: tuple[tuple[int, int], ...] = eqx.field(static=True)

    def init(self, t, signals, t_last):
        return pair(self.stream.init(t, signals, t_last), self.pairs)

    def update(self, state, t, signals):
        return pair(self.stream.update(unpair(state), t, signals), self.pairs)
