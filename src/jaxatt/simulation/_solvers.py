r"""Fixed-step integrators for the closed loop.

jaxatt integrates closed loops with fixed steps on purpose: sliding-mode and other switching laws
make adaptive step-size control collapse (STYLE.md, behaviour 3), and fixed steps give static
shapes for `vmap`, predictable cost and clean reverse-mode gradients. `RK4` (the default) and
`Euler` are written directly; any diffrax solver can be used at a fixed step through
[`DiffraxSolver`][] (`simulate` wraps a bare `diffrax.AbstractSolver` automatically).
"""

import abc
import numbers
from collections.abc import Callable
from typing import Any, ClassVar

import diffrax as dfx
import equinox as eqx
import jax
import jax.tree_util as jtu
import numpy as np
from jaxtyping import Array, PyTree

from .._custom_types import RealScalarLike


def _is_tolerance(value) -> bool:
    """A root finder's tolerance given as a number or an array (not diffrax's placeholder
    that `diffeqsolve` fills from an adaptive step-size controller)."""
    return isinstance(value, (numbers.Real, np.ndarray, jax.Array))


VectorField = Callable[[Any, PyTree[Array], Any], PyTree[Array]]


def _start_derivative(vector_field, t, y, args, given):
    """$f(t, y, \\text{args})$: `given` if the caller passed it, evaluated otherwise."""
    return vector_field(t, y, args) if given is None else given


def _axpy(y: PyTree[Array], h, k: PyTree[Array]) -> PyTree[Array]:
    return jtu.tree_map(lambda yi, ki: yi + h * ki, y, k)


class AbstractFixedStepSolver(eqx.Module):
    """One step of size `dt` of $\\dot y = f(t, y, \\text{args})$ for a pytree `y`.

    A solver whose first stage evaluates $f(t, y, \\text{args})$ at the point the step starts
    from may declare `takes_start_derivative = True`; its `step` then accepts that value as
    `start_derivative=` and does not evaluate it again. The time loop passes it when it has
    already evaluated the flight software at the start of the step for the signals it streams
    (so the controller is evaluated once per stage, not once more per step). Other solvers
    (the default `False`) are called without it.
    """

    order: eqx.AbstractClassVar[int]
    takes_start_derivative: ClassVar[bool] = False

    @abc.abstractmethod
    def init(
        self,
        vector_field: VectorField,
        t0: RealScalarLike,
        dt: RealScalarLike,
        y0: PyTree[Array],
        args: PyTree,
    ) -> PyTree:
        """Solver state carried between steps (`None` for one-step methods)."""

    @abc.abstractmethod
    def step(
        self,
        vector_field: VectorField,
        t: RealScalarLike,
        dt: RealScalarLike,
        y: PyTree[Array],
        args: PyTree,
        state: PyTree,
    ) -> tuple[PyTree[Array], PyTree]:
        """`(y(t + dt), new_state)`."""


class Euler(AbstractFixedStepSolver):
    """Explicit Euler, order 1. With `ZeroOrderHold` and `period == dt` it is the classic
    discrete-time simulation of a sampled controller."""

    order: ClassVar[int] = 1
    takes_start_derivative: ClassVar[bool] = True

    def init(self, vector_field, t0, dt, y0, args) -> None:
        return None

    def step(self, vector_field, t, dt, y, args, state, start_derivative=None):
        """`start_derivative`: $f(t, y, \\text{args})$ if the caller has it."""
        k1 = _start_derivative(vector_field, t, y, args, start_derivative)
        return _axpy(y, dt, k1), None


class RK4(AbstractFixedStepSolver):
    r"""The classic fourth-order Runge-Kutta method (Butcher tableau 0, 1/2, 1/2, 1; weights
    1/6, 1/3, 1/3, 1/6): four vector-field evaluations per step, global error $O(dt^4)$ for
    smooth dynamics. This is the integrator of the papers jaxatt reproduces."""

    order: ClassVar[int] = 4
    takes_start_derivative: ClassVar[bool] = True

    def init(self, vector_field, t0, dt, y0, args) -> None:
        return None

    def step(self, vector_field, t, dt, y, args, state, start_derivative=None):
        """`start_derivative`: the first stage $f(t, y, \\text{args})$ if the caller has it."""
        half = 0.5 * dt
        k1 = _start_derivative(vector_field, t, y, args, start_derivative)
        k2 = vector_field(t + half, _axpy(y, half, k1), args)
        k3 = vector_field(t + half, _axpy(y, half, k2), args)
        k4 = vector_field(t + dt, _axpy(y, dt, k3), args)
        increment = jtu.tree_map(lambda a, b, c, d: (a + 2 * b + 2 * c + d) / 6, k1, k2, k3, k4)
        return _axpy(y, dt, increment), None


class DiffraxSolver(AbstractFixedStepSolver):
    """Any diffrax ODE solver (e.g. `diffrax.Tsit5()`, `diffrax.Heun()`) at a fixed step.

    An adaptive solver's error estimate is not used: every step has the size `dt`. An
    implicit solver (`diffrax.Kvaerno5()`, `diffrax.ImplicitEuler()`) needs a root finder
    with explicit tolerances, e.g. `root_finder=optimistix.Chord(rtol=1e-8, atol=1e-8)`
    (its default takes them from an adaptive step-size controller, which is refused here).
    Solvers of several terms (IMEX, SDE, partitioned: `KenCarp3`, `EulerHeun`,
    `SemiImplicitEuler`) are refused: a closed loop is one ODE term.

    Every step is flagged as following a jump (`made_jump=True`), because the state may be
    changed between steps (the discrete updates: MRP shadow switch, quaternion
    renormalization, controller memories) and the held control may change at sample instants;
    first-same-as-last solvers therefore re-evaluate their first stage, which is correct at
    the price of one evaluation per step.
    """

    solver: dfx.AbstractSolver
    order: ClassVar[int] = 0  # see `solver.order(terms)`

    def __init__(self, solver: dfx.AbstractSolver):
        if not isinstance(solver, dfx.AbstractSolver):
            raise ValueError(
                f"DiffraxSolver: `solver` must be a diffrax solver, got {type(solver).__name__}."
            )
        name = type(solver).__name__
        structure = solver.term_structure
        if not (isinstance(structure, type) and issubclass(dfx.ODETerm, structure)):
            # e.g. KenCarp3 (IMEX), SemiImplicitEuler (two terms), EulerHeun (an SDE): they
            # failed inside diffrax with an AssertionError or an unpacking error.
            raise ValueError(
                f"DiffraxSolver: {name} integrates several terms (an IMEX, SDE or partitioned "
                f"solver), but a closed loop is one ODE term; use an ODE solver (e.g. "
                f"diffrax.Tsit5(), diffrax.Kvaerno5(root_finder=...)) or RK4()."
            )
        root_finder = getattr(solver, "root_finder", None)
        if root_finder is not None and not all(
            _is_tolerance(getattr(root_finder, tol, 0.0)) for tol in ("rtol", "atol")
        ):
            # diffrax fills these tolerances from `diffeqsolve`'s PIDController; at a fixed
            # step there is none, and the step failed with "Type of `other` not understood".
            raise ValueError(
                f"DiffraxSolver: {name}'s root finder takes its tolerances from an adaptive "
                f"step-size controller, which a fixed-step run does not have; give it explicit "
                f"ones, e.g. diffrax.{name}(root_finder=optimistix.Chord(rtol=1e-8, atol=1e-8))."
            )
        self.solver = solver

    def init(self, vector_field, t0, dt, y0, args):
        return self.solver.init(dfx.ODETerm(vector_field), t0, t0 + dt, y0, args)

    def step(self, vector_field, t, dt, y, args, state):
        y1, _, _, state, _ = self.solver.step(
            dfx.ODETerm(vector_field), t, t + dt, y, args, state, made_jump=True
        )
        return y1, state


def as_fixed_step_solver(solver, where: str = "simulate") -> AbstractFixedStepSolver:
    """Accept a jaxatt solver or wrap a diffrax one; anything else is a clear error."""
    if isinstance(solver, AbstractFixedStepSolver):
        return solver
    if isinstance(solver, dfx.AbstractSolver):
        return DiffraxSolver(solver)
    raise ValueError(
        f"{where}: `solver` must be a jaxatt solver (RK4(), Euler()) or a diffrax solver, "
        f"got {type(solver).__name__}."
    )
