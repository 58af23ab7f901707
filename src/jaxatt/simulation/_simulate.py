"""`simulate`: integrate a closed loop with fixed steps, continuous or sampled control."""

import diffrax as dfx
import equinox as eqx
import jax.tree_util as jtu
import numpy as np
from jaxtyping import PyTree

from .._validation import check_flag, is_traced
from ._closed_loop import AbstractClosedLoop
from ._compiled import compiled
from ._loop import integrate
from ._memory import check_saved_memory
from ._performance import Performance
from ._sampling import AbstractSampling, Continuous
from ._settings import Simulation
from ._solvers import RK4, AbstractFixedStepSolver
from ._status import SimulationFailed, Status
from ._trajectory import Trajectory


def any_traced(tree) -> bool:
    """Whether any leaf of `tree` is a JAX tracer (inside an outer `jit`/`vmap`/`grad`)."""
    return any(is_traced(leaf) for leaf in jtu.tree_leaves(tree))


def check_closed_loop(where: str, closed_loop) -> None:
    if not isinstance(closed_loop, AbstractClosedLoop):
        raise ValueError(
            f"{where}: `closed_loop` must be a jaxatt closed loop (e.g. "
            f"jaxatt.simulation.ClosedLoop), got {type(closed_loop).__name__}."
        )


def raise_on_failure(traj: Trajectory) -> Trajectory:
    """Raise [`SimulationFailed`][] if `traj` failed (on the host), or attach an `error_if`
    when the status is traced (inside a user's own `jit`/`vmap`)."""
    if is_traced(traj.status):
        message = (
            "simulate: the closed loop failed (a non-finite state, an invalid plant or a "
            "constraint violation). Simulate with throw=False and read `Trajectory.status` "
            "(jaxatt.simulation.Status) to see which sample and why."
        )
        return eqx.tree_at(lambda tr: tr.ts, traj, eqx.error_if(traj.ts, traj.status != 0, message))
    codes = np.asarray(traj.status)
    if np.any(codes != 0):
        index = np.unravel_index(int(np.argmax(codes != 0)), codes.shape) if codes.ndim else ()
        failure_time = float(np.asarray(traj.failure_time)[index])
        detail = f" (sample {index[0] if len(index) == 1 else index})" if codes.ndim else ""
        if failure_time == float(np.asarray(traj.ts).reshape(-1)[0]):
            # The status message speaks of a completed step; this one failed before any.
            detail += " It was detected on the initial state, at t0, before any step."
        raise SimulationFailed(Status(int(codes[index])), failure_time, detail)
    return traj


def simulate(
    closed_loop: AbstractClosedLoop,
    x0: PyTree,
    t0: float,
    t1: float,
    *,
    dt: float,
    sampling: AbstractSampling = Continuous(),
    solver: AbstractFixedStepSolver | dfx.AbstractSolver = RK4(),
    save_every: int = 1,
    checkpoint: bool | str = True,
    checkpoints: int | None = None,
    throw: bool = True,
    performance: Performance | None = None,
) -> Trajectory:
    r"""Integrate `closed_loop` from the plant state `x0` over `[t0, t1]` with fixed steps `dt`.

    **Arguments:**
    - `closed_loop`: any [`AbstractClosedLoop`][], e.g. a [`ClosedLoop`][] (plant, reference,
      observer, controller, actuator).
    - `x0`: the plant's initial state (e.g. `QuaternionState(q, omega)`); checked by the
      plant before anything is compiled (shapes, finite values, unit quaternions to 1e-6).
      The other components' states start from their `init`.
    - `t0`, `t1`, `dt`: Python numbers [s]; `t1 - t0` must be a whole multiple of `dt`.
      They fix the number of steps, so changing them recompiles (changing gains does not).
    - `sampling`: `Continuous()` (controller inside the vector field, the papers' setting) or
      `ZeroOrderHold(period, delay=False)`.
    - `solver`: `RK4()` (default), `Euler()`, or any diffrax solver (used at a fixed step).
    - `save_every`: save every this many steps (must divide the step count); the first save
      is at `t0`, the last at `t1` (the save times are $t_0 + k\,dt$ in the state's dtype,
      so the last may be `t1` rounded by an ulp: `0.0 + 3 * 0.1` is 0.30000000000000004).
    - `checkpoint`: rematerialize each save interval in reverse-mode autodiff, so gradient
      memory grows with the number of saves rather than of steps; `"recursive"` runs
      equinox's checkpointed scan (online treeverse), which stores at most `checkpoints` loop
      states whatever the horizon (reverse mode only; see [`Simulation`][]). No effect
      without `grad`. The saved trajectory itself is always stored.
    - `throw`: raise [`SimulationFailed`][] if the run fails (a non-finite state, an invalid
      plant, a constraint violation), after the compiled program has returned. Use
      `throw=False` for batches: failures are then reported per sample in
      `Trajectory.status` (see [`Status`][]) with their `failure_time`.
    - `performance`: a [`Performance`][] (how the loop is compiled, never what it computes);
      by default nothing special for one trajectory.

    **Returns:** a [`Trajectory`][].

    Before compiling, the controller's `check_initial` sees the concrete initial state, so an
    inadmissible start (e.g. outside a rate barrier) is refused with a `ValueError` that says
    why, and so is a trajectory that cannot fit in memory (saves x the bytes of one record
    (loop state, signals, time) beyond the host's physical memory, or a GPU's: raise
    `save_every`, shorten the horizon or raise `dt`). `simulate` is compiled with
    `eqx.filter_jit`, works under `jax.vmap` (batch outside) and is differentiable
    (`jax.grad`/`eqx.filter_grad`) with respect to every array in `closed_loop` and `x0`.
    After each completed step the discrete updates run (MRP shadow switch, quaternion
    renormalization, controller memories), never between solver stages.
    The compiled program holds no host callback; failures are raised here, on the host.
    """
    check_closed_loop("simulate", closed_loop)
    # `bool(throw)` would read throw="False" as True and throw=None as False.
    throw = check_flag("simulate", "throw", throw)
    sim = Simulation(
        t0,
        t1,
        dt,
        sampling=sampling,
        solver=solver,
        save_every=save_every,
        checkpoint=checkpoint,
        checkpoints=checkpoints,
        performance=performance,
        where="simulate",
    )
    x0 = closed_loop.check_state(x0, "x0")
    if not any_traced((closed_loop, x0)):
        closed_loop.check_initial(sim.t0, x0)
    check_saved_memory("simulate", closed_loop, x0, sim)
    sim = sim.with_performance(sim.performance.resolve(1))
    traj = compiled(integrate, sim.performance, (closed_loop, x0))(closed_loop, x0, sim)
    return raise_on_failure(traj) if throw else traj
