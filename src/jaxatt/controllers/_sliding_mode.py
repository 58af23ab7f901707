r"""Sliding-mode attitude tracking composed from a surface, a reaching law and a robust term."""

from typing import ClassVar

import equinox as eqx
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike, Vec3
from .._validation import check_flag, check_spd
from ..numerics import materialized
from ..plants import QuaternionState
from ..reaching import AbstractReachingLaw
from ..references import AttitudeReference
from ..sliding import AbstractSlidingSurface
from ._base import AbstractController
from ._robust import AbstractRobustTerm
from ._tracking import tracking_errors


class SlidingModeTracking(AbstractController):
    r"""Sliding-mode tracking $u = J_0(r(s) - F - \dot h - \nu(s))$: $\dot s = r(s) - \nu(s) + D$.

    With the surface $s = e_\omega + h(e)$, the reaching law $r$, the robust term $\nu$ and the
    error dynamics $\dot e_\omega = F + J_0^{-1}u + D$ (see `jaxatt.controllers._tracking`),
    this control makes $\dot s = r(s) - \nu(s) + D$. For Chen et al. (2022):

    - M1, eq. (41): `LinearSurface(5)`, `TwoPhasePower(1.2, 1.2, 31/11, 5/9)`,
      `NormRobustTerm(0.35, 0.01)`;
    - M2, eq. (57): the same with `Exponential(1.2, 0.01)`;
    - M3, eq. (58): the same with `DoublePower(1.2, 0.8, 31/11, 5/9)`.

    **Arguments:**
    - `surface`: an [`jaxatt.sliding.AbstractSlidingSurface`][].
    - `reaching_law`: an [`jaxatt.reaching.AbstractReachingLaw`][].
    - `inertia`: the nominal inertia $J_0$ the controller knows [kg m^2].
    - `robust`: an [`AbstractRobustTerm`][] or `None`.
    - `surface_feedforward`: include $\dot h$ (for the linear surface $\lambda\dot e_v$).
      `True` (default) is the correct law. `False` reproduces eqs. (57)-(58) as printed, which
      omit $\lambda\dot e_v$ (erratum E4), so that $s$ does not follow the intended law.

    The control is the *commanded* torque; saturation belongs to the actuator model.
    `signals` records the sliding variable as `"s"`. The law reads a `QuaternionState`
    measurement, so it flies any plant whose `measure` returns one (a rigid body with modal
    or slosh coordinates included).
    """

    surface: AbstractSlidingSurface
    reaching_law: AbstractReachingLaw
    inertia: Float[Array, "3 3"]
    robust: AbstractRobustTerm | None
    surface_feedforward: bool = eqx.field(static=True)
    measurement_type: ClassVar[type] = QuaternionState
    reference_type: ClassVar[type] = AttitudeReference

    def __init__(
        self,
        surface: AbstractSlidingSurface,
        reaching_law: AbstractReachingLaw,
        inertia: ArrayLike,
        robust: AbstractRobustTerm | None = None,
        *,
        surface_feedforward: bool = True,
    ):
        for name, value, kind in (
            ("surface", surface, AbstractSlidingSurface),
            ("reaching_law", reaching_law, AbstractReachingLaw),
            ("robust", robust, (AbstractRobustTerm, type(None))),
        ):
            if not isinstance(value, kind):
                raise TypeError(
                    f"SlidingModeTracking: `{name}` has the wrong type {type(value).__name__}."
                )
        self.surface = surface
        self.reaching_law = reaching_law
        self.inertia = check_spd("SlidingModeTracking", "inertia", inertia)
        self.robust = robust
        self.surface_feedforward = check_flag(
            "SlidingModeTracking", "surface_feedforward", surface_feedforward
        )

    def init(self, t0: RealScalarLike, measurement: QuaternionState, reference) -> None:
        del t0, measurement, reference
        return None

    def __call__(
        self,
        t: RealScalarLike,
        measurement: QuaternionState,
        reference: AttitudeReference,
        state: None,
    ) -> tuple[Vec3, None]:
        del state
        # Read by every component of the torque: computed once (exact; see `materialized`).
        errors = materialized(tracking_errors(measurement, reference, self.inertia), t)
        s = self.surface(errors.e, errors.e_omega)
        # The rate error derivative that makes s_dot = r(s) - nu(s) when D = 0.
        e_omega_dot = self.reaching_law.rate(s) - errors.drift
        if self.surface_feedforward:
            e_omega_dot = e_omega_dot - self.surface.attitude_term_rate(errors.e, errors.e_omega)
        if self.robust is not None:
            e_omega_dot = e_omega_dot - self.robust(s)
        return self.inertia @ e_omega_dot, None

    def signals(
        self, t: RealScalarLike, measurement: QuaternionState, reference, state: None
    ) -> dict[str, Array]:
        del t, state
        errors = tracking_errors(measurement, reference, self.inertia)
        return {"s": self.surface(errors.e, errors.e_omega)}
