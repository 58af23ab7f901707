r"""Translational sliding-mode control of relative orbital motion (Zhang et al. 2017).

Both laws cancel the drift with a *model* of the relative motion (any
[`jaxatt.plants.AbstractRelativeOrbit`][]: the exact nonlinear one by default, or a linear one
for a mismatched design), and track a [`jaxatt.references.TranslationReference`][]
$(\rho_d, \dot\rho_d, \ddot\rho_d)$ with the error $e = \rho - \rho_d$.

Zhang writes $e = \rho_d - \rho$; with $s$ linear in $e$ and odd reaching laws both
conventions give the same control, and Zhang's sliding variable is $-s$.
"""

import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_in_open_interval, check_instance, check_positive, check_scalar
from ..numerics import FractionalMemory, memory_derivative, memory_init, memory_push
from ..plants import AbstractRelativeOrbit, RelativeOrbitState
from ..reaching import AbstractReachingLaw
from ..references import TranslationReference
from ..sliding import FractionalSurface, FractionalSurfaceState, PDSurface, TerminalSurface
from ._base import AbstractController


def _check_parts(where: str, model, reaching_law) -> None:
    plants = "a relative-orbit plant (RelativeOrbit, TschaunerHempel, ClohessyWiltshire)"
    check_instance(where, "model", model, AbstractRelativeOrbit, plants)
    check_instance(
        where, "reaching_law", reaching_law, AbstractReachingLaw, "a jaxatt.reaching law"
    )


class TranslationalSlidingMode(AbstractController):
    r"""$u = \ddot\rho_d - f(\theta, \rho, \dot\rho) - \dot h + r(s)$, so that $\dot s = r(s)$.

    With the surface $s = \dot e + h(e)$ ([`jaxatt.sliding.PDSurface`][] $h = ce$, or
    [`jaxatt.sliding.TerminalSurface`][]), the model's natural acceleration
    $f = A_1\rho + A_2\dot\rho + g$ and any reaching law $r$ of [`jaxatt.reaching`][].
    With `PDSurface(c)` and `Exponential(k, eps)` this is Zhang 2017 eq. (11):
    $u = c e_Z' + A_1 e_Z + A_2 e_Z' - g + \varepsilon\,\mathrm{sgn}\,s_Z + k s_Z$ ($e_Z = -e$).
    Without disturbance and with the exact model, each $s_i$ follows the reaching law, and
    reaches 0 at the law's `convergence_time(s_i(0))`.

    **Arguments:** `model`, `surface`, `reaching_law`. **Signals:** `"s"`.
    """

    model: AbstractRelativeOrbit
    surface: PDSurface | TerminalSurface
    reaching_law: AbstractReachingLaw
    measurement_type: ClassVar[type] = RelativeOrbitState
    reference_type: ClassVar[type] = TranslationReference

    def __init__(
        self,
        model: AbstractRelativeOrbit,
        surface: PDSurface | TerminalSurface,
        reaching_law: AbstractReachingLaw,
    ):
        _check_parts("TranslationalSlidingMode", model, reaching_law)
        check_instance(
            "TranslationalSlidingMode",
            "surface",
            surface,
            (PDSurface, TerminalSurface),
            "a PDSurface or TerminalSurface",
        )
        self.model, self.surface, self.reaching_law = model, surface, reaching_law

    def errors(
        self, y: RelativeOrbitState, r: TranslationReference
    ) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
        return y.rho - r.position, y.rho_dot - r.velocity

    def init(self, t0, measurement, reference) -> None:
        return None

    def __call__(self, t, measurement, reference, state):
        e, e_dot = self.errors(measurement, reference)
        s = self.surface(e, e_dot)
        u = (
            reference.acceleration
            - self.model.natural_acceleration(t, measurement)
            - self.surface.error_term_rate(e, e_dot)
            + self.reaching_law.rate(s)
        )
        return u, None

    def signals(self, t, measurement, reference, state) -> dict[str, Array]:
        e, e_dot = self.errors(measurement, reference)
        return {"s": self.surface(e, e_dot)}


def memory_samples(where: str, step: float, horizon: float, memory: float | None) -> int:
    """Samples kept by a fractional memory: the whole horizon (`memory=None`) or `memory` s.

    Refuses a memory longer than the horizon or shorter than one step.
    """
    step, horizon = float(step), float(horizon)
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"{where}: `step` must be positive, got step={step}.")
    if not (math.isfinite(horizon) and horizon >= step):
        raise ValueError(
            f"{where}: `horizon` must be at least one step ({step} s), got horizon={horizon}."
        )
    full = int(round(horizon / step)) + 1
    if memory is None:
        return full
    memory = float(memory)
    if not (memory >= step):
        raise ValueError(
            f"{where}: `memory` must be at least one step (step={step} s), got memory={memory}."
        )
    if memory > horizon:
        raise ValueError(
            f"{where}: `memory` must not exceed the horizon ({horizon} s), got memory={memory}; "
            "use memory=None for the full memory."
        )
    return int(round(memory / step)) + 1


class FractionalSlidingState(eqx.Module):
    """Memories of the surface and of the bracket of (17), and their values at the newest
    sample: the surface `s` and the fractional term `term` $= D^{1-\\alpha}[b]$."""

    surface: FractionalSurfaceState
    bracket: FractionalMemory
    s: Float[Array, "3"]
    term: Float[Array, "3"]


class FractionalSlidingMode(AbstractController):
    r"""Fractional PD$^\alpha$ sliding mode (Zhang et al. 2017 eqs. 12 and 17, SPEC 001(e)).

    Surface $S = D^\alpha e + c\,e$ (Caputo, [`jaxatt.sliding.FractionalSurface`][]), and

    $$u = \ddot\rho_d - f(\theta, \rho, \dot\rho) + D^{1-\alpha}\big[r(S) - c\,\dot e\big],$$

    with $D^{1-\alpha}$ **Riemann-Liouville** (the GL sum of the bracket itself). With
    `Exponential(k, eps)`, $r(S) = -\varepsilon\,\mathrm{sgn}S - kS$, this is (17) with
    $B'^{-1}$ read as the lower block $-I_3$ (SPEC 001(e) [E]).

    **A digital law.** The memories hold the samples at the instants $t_k = t_0 + kh$ where
    the discrete `update` runs, so fly it under `ZeroOrderHold(step)` with an integration step
    dividing $h$ (SPEC: $h$ = 0.01 s). $S$ and $D^{1-\alpha}[\cdot]$ are computed at each
    sample; the drift cancellation $f$ uses the current measurement. Work: $O(L)$ per sample
    and $O(NL)$ in all ($O(N^2)$ with full memory); storage $O(L)$.

    **Arguments:**
    - `model`: the relative-orbit model the law cancels; `slope` $c > 0$;
      `reaching_law`: any [`jaxatt.reaching`][] law; `alpha` $\in (0, 1)$;
    - `step`: $h$ [s]; `horizon` [s]: the simulated duration; `memory`: `None` (full memory,
      the default) or a duration [s] in $[h, \text{horizon}]$ (short memory, see
      [`jaxatt.numerics`][]);
    - `caputo`: the surface's reading (True: Caputo, SPEC's choice).

    If the run outlasts `horizon` with full memory, the oldest samples would be dropped
    silently: `admissible` turns False then (status `constraint_violated`).
    **Signals:** `"s"` (at the newest sample), `"fractional_term"`.
    """

    model: AbstractRelativeOrbit
    surface: FractionalSurface
    reaching_law: AbstractReachingLaw
    full_memory: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = RelativeOrbitState
    reference_type: ClassVar[type] = TranslationReference

    def __init__(
        self,
        model: AbstractRelativeOrbit,
        slope: Float[ArrayLike, "*k"],
        reaching_law: AbstractReachingLaw,
        alpha: RealScalarLike,
        step: float,
        horizon: float,
        memory: float | None = None,
        *,
        caputo: bool = True,
    ):
        where = "FractionalSlidingMode"
        _check_parts(where, model, reaching_law)
        check_in_open_interval(where, "alpha", check_scalar(where, "alpha", alpha), 0.0, 1.0)
        check_positive(where, "slope", slope)
        capacity = memory_samples(where, step, horizon, memory)
        self.model, self.reaching_law = model, reaching_law
        self.surface = FractionalSurface(slope, alpha, step, capacity, caputo)
        self.full_memory = memory is None

    @property
    def alpha(self) -> Float[Array, ""]:
        return self.surface.order

    def errors(
        self, y: RelativeOrbitState, r: TranslationReference
    ) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
        return y.rho - r.position, y.rho_dot - r.velocity

    def _evaluate(self, surface_state, bracket_memory, e, e_dot):
        s = self.surface(surface_state, e)
        bracket = self.reaching_law.rate(s) - self.surface.slope * e_dot
        bracket_memory = (
            memory_init(self.surface.capacity, bracket)
            if bracket_memory is None
            else memory_push(bracket_memory, bracket)
        )
        term = memory_derivative(bracket_memory, self.surface.step, 1 - self.surface.order)
        return FractionalSlidingState(surface_state, bracket_memory, s, term)

    def init(self, t0, measurement, reference) -> FractionalSlidingState:
        e, e_dot = self.errors(measurement, reference)
        return self._evaluate(self.surface.init(e), None, e, e_dot)

    def update(self, t, measurement, reference, state) -> FractionalSlidingState:
        e, e_dot = self.errors(measurement, reference)
        return self._evaluate(self.surface.push(state.surface, e), state.bracket, e, e_dot)

    def __call__(self, t, measurement, reference, state):
        u = reference.acceleration - self.model.natural_acceleration(t, measurement) + state.term
        # The memories change only in `update`: zero rate for the continuous integration.
        return u, jax.tree_util.tree_map(jnp.zeros_like, state)

    def admissible(self, t, measurement, reference, state):
        if not self.full_memory:
            return jnp.array(True)
        return state.bracket.count <= self.surface.capacity

    def signals(self, t, measurement, reference, state) -> dict[str, Array]:
        return {"s": state.s, "fractional_term": state.term}
