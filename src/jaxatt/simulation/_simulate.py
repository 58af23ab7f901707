"""`simulate`: integrate a closed loop with fixed steps, continuous or sampled control."""

import math
import numbers

import diffrax as dfx
import equinox as eqx
import jax
import jax.lax as lax
import jax.numpy as jnp
import jax.tree_util as jtu
from jaxtyping import Array, PyTree

from ._closed_loop import ClosedLoop, ClosedLoopState
from ._sampling import AbstractSampling, Continuous
from ._scalarize import scalarized_loop_step
from ._solvers import RK4, AbstractFixedStepSolver, as_fixed_step_solver
from ._trajectory import RESULTS, Trajectory, all_finite


def _check_time(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(
            f"simulate: `{name}` must be a Python number (it fixes the number of steps, a "
            f"static shape), got {type(value).__name__}."
        )
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"simulate: `{name}` must be finite, got {name}={value}.")
    return value


def _step_count(t0: float, t1: float, dt: float, save_every) -> int:
    if dt <= 0:
        raise ValueError(f"simulate: `dt` must be positive, got dt={dt}.")
    if t1 <= t0:
        raise ValueError(f"simulate: `t1` must be greater than `t0`, got t0={t0}, t1={t1}.")
    ratio = (t1 - t0) / dt
    n_steps = round(ratio)
    if n_steps < 1 or abs(ratio - n_steps) > 1e-9 * max(1.0, ratio):
        raise ValueError(
            "simulate: `t1 - t0` must be a whole multiple of `dt`, got "
            f"t0={t0}, t1={t1}, dt={dt} ({ratio:.6g} steps)."
        )
    if (
        isinstance(save_every, bool)
        or not isinstance(save_every, numbers.Integral)
        or save_every < 1
    ):
        raise ValueError(f"simulate: `save_every` must be a positive integer, got {save_every!r}.")
    if n_steps % save_every:
        raise ValueError(
            f"simulate: `save_every` must divide the number of steps ({n_steps}), got "
            f"save_every={save_every}."
        )
    return n_steps


def simulate(
    closed_loop: ClosedLoop,
    x0: PyTree,
    t0: float,
    t1: float,
    *,
    dt: float,
    sampling: AbstractSampling = Continuous(),
    solver: AbstractFixedStepSolver | dfx.AbstractSolver = RK4(),
    save_every: int = 1,
    checkpoint: bool = True,
    throw: bool = True,
    scalarize: bool = False,
) -> Trajectory:
    r"""Integrate `closed_loop` from the plant state `x0` over `[t0, t1]` with fixed steps `dt`.

    **Arguments:**
    - `closed_loop`: a [`ClosedLoop`][] (plant, controller, reference, actuator).
    - `x0`: the plant's initial state (e.g. `QuaternionState(q, omega)`); checked by the
      plant (shapes; unit quaternion to 1e-6). Reference and controller states start from
      their `init`.
    - `t0`, `t1`, `dt`: Python numbers [s]; `t1 - t0` must be a whole multiple of `dt`.
      They fix the number of steps, so changing them recompiles (changing gains does not).
    - `sampling`: `Continuous()` (controller inside the vector field, the papers' setting) or
      `ZeroOrderHold(period)`.
    - `solver`: `RK4()` (default), `Euler()`, or any diffrax solver (used at fixed step).
    - `save_every`: save every this many steps (must divide the step count); the first save
      is at `t0`, the last at `t1`.
    - `checkpoint`: rematerialize each save interval in reverse-mode autodiff, so gradient
      memory grows with the number of saves rather than of steps. No effect without `grad`.
    - `throw`: raise if the state becomes non-finite. Use `throw=False` under `vmap`
      (Monte Carlo): failures are then reported per sample in `Trajectory.result`.
    - `scalarize`: run the time loop on the scalar entries of the state and of every small
      array inside a step (see `jaxatt.simulation._scalarize`), so that under `vmap` a batch
      lowers to elementwise code on one `(batch,)` array per component. Same values (to a few
      ulps) and derivatives. On a 2-core CPU it made batches of 1000 and more 1.5-3x faster
      (benchmarks/README.md), but it roughly doubles compile time and makes reverse-mode
      gradients slower, and it does not help one trajectory: [`jaxatt.montecarlo.monte_carlo`][]
      turns it on, `simulate` leaves it off by default.

    **Returns:** a [`Trajectory`][].

    `simulate` is compiled with `eqx.filter_jit`, works under `jax.vmap` (batch outside) and
    is differentiable (`jax.grad`/`eqx.filter_grad`) with respect to every array in
    `closed_loop` and `x0`. After each completed step the plant's `post_step` map is applied
    (MRP shadow switch, optional quaternion renormalization), never between solver stages.
    """
    if not isinstance(closed_loop, ClosedLoop):
        raise ValueError(
            f"simulate: `closed_loop` must be a ClosedLoop, got {type(closed_loop).__name__}."
        )
    if not isinstance(sampling, AbstractSampling):
        raise ValueError(
            "simulate: `sampling` must be Continuous() or ZeroOrderHold(period), got "
            f"{type(sampling).__name__}."
        )
    t0 = _check_time("t0", t0)
    t1 = _check_time("t1", t1)
    dt = _check_time("dt", dt)
    n_steps = _step_count(t0, t1, dt, save_every)
    steps_per_sample = sampling.steps_per_sample(dt)
    x0 = closed_loop.plant.check_state(x0, "x0")
    return _simulate(
        closed_loop,
        x0,
        t0=t0,
        dt=dt,
        n_steps=n_steps,
        save_every=int(save_every),
        steps_per_sample=steps_per_sample,
        solver=as_fixed_step_solver(solver),
        checkpoint=bool(checkpoint),
        throw=bool(throw),
        scalarize=bool(scalarize),
    )


@eqx.filter_jit
def _simulate(
    closed_loop: ClosedLoop,
    x0: PyTree[Array],
    *,
    t0: float,
    dt: float,
    n_steps: int,
    save_every: int,
    steps_per_sample: int,
    solver: AbstractFixedStepSolver,
    checkpoint: bool,
    throw: bool,
    scalarize: bool,
) -> Trajectory:
    dtype = jnp.result_type(*jtu.tree_leaves(x0))

    def time(i) -> Array:
        return jnp.asarray(t0 + jnp.asarray(i) * dt, dtype=dtype)

    def hold(loop, i, t, y, held):
        # Sample the controller at multiples of its period; otherwise keep the held value.
        if steps_per_sample == 0:
            return None
        return lax.cond(i % steps_per_sample == 0, lambda: loop.control(t, y), lambda: held)

    y0 = closed_loop.init(time(0), x0)
    held0 = None if steps_per_sample == 0 else closed_loop.control(time(0), y0)
    solver_state0 = solver.init(closed_loop, time(0), dt, y0, held0)

    def one_step(loop, carry, i):
        y, held, solver_state = carry
        t = time(i)
        held = hold(loop, i, t, y, held)
        y, solver_state = solver.step(loop, t, dt, y, held, solver_state)
        return loop.post_step(y), held, solver_state

    carry0 = (y0, held0, solver_state0)
    if scalarize:
        # The time loop runs on scalar entries (a struct of arrays under vmap): `._scalarize`.
        flat0, step, unflatten = scalarized_loop_step(one_step, closed_loop, carry0)
    else:
        flat0 = carry0

        def step(carry, i):
            return one_step(closed_loop, carry, i), None

        def unflatten(carry):
            return carry

    def save_interval(flat, j):
        flat, _ = lax.scan(step, flat, j * save_every + jnp.arange(save_every))
        y, held, _ = unflatten(flat)
        i_end = (j + 1) * save_every
        t_end = time(i_end)
        signals = closed_loop.signals(t_end, y, hold(closed_loop, i_end, t_end, y, held))
        return flat, (y, signals)

    if checkpoint:
        save_interval = jax.checkpoint(save_interval)

    n_saves = n_steps // save_every
    _, (ys, signals) = lax.scan(save_interval, flat0, jnp.arange(n_saves))
    signals0 = closed_loop.signals(time(0), y0, held0)

    def prepend(first, rest):
        return jnp.concatenate([first[None], rest], axis=0)

    states: ClosedLoopState = jtu.tree_map(prepend, y0, ys)
    signals = jtu.tree_map(prepend, signals0, signals)
    ts = time(jnp.arange(n_saves + 1) * save_every)
    result = RESULTS.where(all_finite(states), RESULTS.successful, RESULTS.nonfinite_state)
    if "violation" in signals:
        violated = jnp.any(signals["violation"])
        result = RESULTS.where(
            (result == RESULTS.successful) & violated, RESULTS.constraint_violated, result
        )
    if throw:
        ts = result.error_if(ts, result != RESULTS.successful)
    return Trajectory(ts=ts, states=states, signals=signals, result=result)
