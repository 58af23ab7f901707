r"""`Simulation`: the settings of a fixed-step closed-loop run, validated once.

[`jaxatt.simulate`][], [`jaxatt.montecarlo.monte_carlo`][] and the tuning objectives all build
one of these from their arguments and hand it to the same time loop, so a tuning objective
and a Monte Carlo study with the same settings run the same compiled program.
"""

import math
import numbers

import diffrax as dfx
import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax.typing import DTypeLike

from .._validation import check_positive_int
from ._performance import Performance
from ._sampling import AbstractSampling, Continuous, whole_steps
from ._solvers import RK4, AbstractFixedStepSolver, as_fixed_step_solver


def _check_time(where: str, name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(
            f"{where}: `{name}` must be a Python number (it fixes the number of steps, a "
            f"static shape), got {type(value).__name__}."
        )
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{where}: `{name}` must be finite, got {name}={value}.")
    return value


class Simulation(eqx.Module):
    r"""Horizon, step, sampling, solver, saving and performance options of a run (all static).

    **Arguments:**
    - `t0`, `t1`, `dt`: Python numbers [s]; `t1 - t0` must be a whole multiple of `dt`.
      They fix the number of steps, so changing them recompiles (changing gains does not).
    - `sampling`: [`Continuous`][]`()` (controller inside the vector field, the papers'
      setting) or [`ZeroOrderHold`][]`(period)`.
    - `solver`: [`RK4`][]`()` (default), [`Euler`][]`()`, or any diffrax solver (used at a
      fixed step).
    - `save_every`: save every this many steps (must divide the step count); the first save
      is at `t0`, the last at `t1` (the save times are $t_0 + k\,dt$ in the state's dtype,
      so the last may be `t1` rounded by an ulp: `0.0 + 3 * 0.1` is 0.30000000000000004).
    - `checkpoint`: how reverse-mode autodiff stores the loop (no effect without `grad`):
      `True` rematerializes each save interval (the loop state is stored once per save, the
      steps inside an interval are recomputed); `"recursive"` runs the save intervals through
      equinox's checkpointed scan (`equinox.internal.scan(kind="checkpointed")`, the online
      treeverse of diffrax's `RecursiveCheckpointAdjoint`), which stores at most `checkpoints`
      loop states whatever the horizon and recomputes intervals as often as that budget
      requires (reverse mode only: `jax.jvp`/`jax.jacfwd` through it raise); `False` stores
      every step's residuals. Values that the run returns (the saved trajectory) are stored
      in every case; a streamed run (the Monte Carlo metrics, the tuning objectives) returns
      no trajectory, so with `"recursive"` its gradient's memory does not grow with the
      horizon.
    - `checkpoints`: with `checkpoint="recursive"`, the number of stored loop states
      (a positive integer); `None` (default) lets equinox choose (about $\sqrt{2N}$ for $N$
      save intervals). Not allowed with the other `checkpoint` settings.
    - `performance`: a [`Performance`][] (how the loop is compiled; never what it computes).
    - `where`: the name used in error messages (the public function building it).
    """

    t0: float = eqx.field(static=True)
    t1: float = eqx.field(static=True)
    dt: float = eqx.field(static=True)
    sampling: AbstractSampling
    solver: AbstractFixedStepSolver
    save_every: int = eqx.field(static=True)
    checkpoint: bool | str = eqx.field(static=True)
    checkpoints: int | None = eqx.field(static=True)
    performance: Performance
    n_steps: int = eqx.field(static=True)
    steps_per_sample: int = eqx.field(static=True)

    def __init__(
        self,
        t0: float,
        t1: float,
        dt: float,
        *,
        sampling: AbstractSampling = Continuous(),
        solver: AbstractFixedStepSolver | dfx.AbstractSolver = RK4(),
        save_every: int = 1,
        checkpoint: bool | str = True,
        checkpoints: int | None = None,
        performance: Performance | None = None,
        where: str = "simulate",
    ):
        self.t0 = _check_time(where, "t0", t0)
        self.t1 = _check_time(where, "t1", t1)
        self.dt = _check_time(where, "dt", dt)
        if self.dt <= 0:
            raise ValueError(f"{where}: `dt` must be positive, got dt={self.dt}.")
        if self.t1 <= self.t0:
            raise ValueError(
                f"{where}: `t1` must be greater than `t0`, got t0={self.t0}, t1={self.t1}."
            )
        span = self.t1 - self.t0
        n_steps = whole_steps(span, self.dt, max(abs(self.t0), abs(self.t1)))
        if n_steps is None:
            raise ValueError(
                f"{where}: `t1 - t0` must be a whole multiple of `dt`, got "
                f"t0={self.t0}, t1={self.t1}, dt={self.dt} ({span / self.dt:.12g} steps)."
            )
        self.n_steps = n_steps
        self.save_every = check_positive_int(where, "save_every", save_every)
        if n_steps % self.save_every:
            raise ValueError(
                f"{where}: `save_every` must divide the number of steps ({n_steps}), got "
                f"save_every={self.save_every}."
            )
        if not isinstance(sampling, AbstractSampling):
            raise ValueError(
                f"{where}: `sampling` must be Continuous() or ZeroOrderHold(period), got "
                f"{type(sampling).__name__}."
            )
        self.sampling = sampling
        self.steps_per_sample = sampling.steps_per_sample(self.dt)
        self.solver = as_fixed_step_solver(solver, where)
        # `1 in (True, False)` holds: without the type check 1, 0 and 1.0 passed as flags.
        if not (
            isinstance(checkpoint, (bool, np.bool_))
            or isinstance(checkpoint, str)
            and checkpoint == "recursive"
        ):
            raise ValueError(
                f"{where}: `checkpoint` must be True, False or 'recursive', got {checkpoint!r}."
            )
        self.checkpoint = checkpoint if checkpoint == "recursive" else bool(checkpoint)
        if checkpoints is not None:
            if self.checkpoint != "recursive":
                raise ValueError(
                    f"{where}: `checkpoints` applies to checkpoint='recursive' only, got "
                    f"checkpoints={checkpoints!r} with checkpoint={checkpoint!r}."
                )
            checkpoints = check_positive_int(where, "checkpoints", checkpoints)
        self.checkpoints = checkpoints
        if performance is None:
            performance = Performance()
        if not isinstance(performance, Performance):
            raise ValueError(
                f"{where}: `performance` must be a jaxatt.simulation.Performance, got "
                f"{type(performance).__name__}."
            )
        self.performance = performance

    def with_performance(self, performance: Performance) -> "Simulation":
        """The same settings with other performance options."""
        return Simulation(
            self.t0,
            self.t1,
            self.dt,
            sampling=self.sampling,
            solver=self.solver,
            save_every=self.save_every,
            checkpoint=self.checkpoint,
            checkpoints=self.checkpoints,
            performance=performance,
        )

    @property
    def n_saves(self) -> int:
        """Number of saved samples, `t0` included."""
        return self.n_steps // self.save_every + 1

    def save_times(self) -> np.ndarray:
        """The save times [s] as a NumPy float64 array (host side, before compiling):
        `t0 + k save_every dt`, k = 0 .. n_saves - 1, as the loop computes them."""
        return self.t0 + np.arange(self.n_saves) * (self.save_every * self.dt)

    def check_clock(self, dtype: DTypeLike) -> None:
        r"""Refuse a clock that the loop's precision cannot resolve.

        The loop's times $t_i = t_0 + i\,dt$ are held in `dtype`, the precision of the states.
        Where the spacing of `dtype` near $\max(|t_0|, |t_1|)$ exceeds 1 % of `dt`, the
        rounded times (and the solver's stage times, $t_i + dt/2$) can be off by more than
        0.5 % of a step, and at a spacing of `dt` or more the clock
        stalls: time-varying references, disturbances and time-varying gains would be
        evaluated at wrong times with no error. In float32 the check refuses horizons from
        128 s on at dt = 1 ms; float64 is safe for any practical horizon.
        """
        if not jnp.issubdtype(dtype, jnp.floating):
            return
        largest = max(abs(self.t0), abs(self.t1))
        finfo = jnp.finfo(dtype)
        # the distance from `largest` to the next number of `dtype` (its unit in the last place)
        spacing = 2.0 ** math.floor(math.log2(largest)) * float(finfo.eps) if largest else 0.0
        if spacing > 0.01 * self.dt:
            name = jnp.dtype(dtype).name
            raise ValueError(
                f"Simulation: in {name} the loop's clock cannot resolve dt={self.dt:g} s near "
                f"t={largest:g} s (the spacing of {name} there is {spacing:.3g} s, more than "
                f"1 % of dt): times would be rounded by up to half that or stall. Start the "
                f"run nearer t=0 (t0=0 with the time shifted into the reference), take a "
                f"larger dt, or run in float64."
            )
