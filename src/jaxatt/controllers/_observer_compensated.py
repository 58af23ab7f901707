r"""Disturbance-observer compensation: any controller minus an observer's estimate."""

from typing import ClassVar

from jaxtyping import Array, Bool, PyTree

from .._custom_types import RealScalarLike
from ..observers import ObservedMeasurement
from ._base import AbstractController


class ObserverCompensated(AbstractController):
    r"""$u = u_{\mathrm{inner}} - \hat d$: a controller with disturbance-estimate compensation.

    The composite of Yu et al. (2022) eq. (29): any controller (FTAC, FT, PD, ...) whose
    command is corrected by the estimate of the closed loop's observer (any
    [`jaxatt.observers.AbstractObserver`][] whose estimate is in the control's units):

    ```python
    loop = ClosedLoop(plant, ObserverCompensated(law), observer=SuperTwistingObserver(J, 4, 2))
    ```

    The observer's state lives in the closed loop's observer slot and is driven by the
    command this composite returns, $u$ (so its model contains $u + \hat d = u_{\mathrm{inner}}$).

    **Arguments:**
    - `controller`: the [`AbstractController`][] whose command is compensated. It reads the
      plant's measurement, as it would without the observer.

    The composite reads an [`jaxatt.observers.ObservedMeasurement`][] (so a closed loop
    without an observer is refused when it is built); its state, signals, admissibility,
    discrete update and initial check are the inner controller's.
    """

    controller: AbstractController
    measurement_type: ClassVar[type] = ObservedMeasurement

    def __init__(self, controller: AbstractController):
        if not isinstance(controller, AbstractController):
            raise TypeError(
                "ObserverCompensated: `controller` must be an AbstractController, got "
                f"{type(controller).__name__}."
            )
        self.controller = controller

    @property
    def reference_type(self) -> type:  # type: ignore[override]
        return self.controller.reference_type

    def check_measurement(self, measurement_type: type, observed: bool) -> None:
        if not observed:
            raise ValueError(
                "ClosedLoop: ObserverCompensated subtracts an observer's estimate, but the loop "
                "has no observer; pass one, e.g. ClosedLoop(plant, ObserverCompensated(law), "
                "observer=SuperTwistingObserver(...))."
            )
        self.controller.check_measurement(measurement_type, False)

    def init(self, t0: RealScalarLike, measurement: ObservedMeasurement, reference) -> PyTree:
        return self.controller.init(t0, measurement.measurement, reference)

    def __call__(
        self, t: RealScalarLike, measurement: ObservedMeasurement, reference, state: PyTree
    ) -> tuple[Array, PyTree]:
        u_inner, state_dot = self.controller(t, measurement.measurement, reference, state)
        return u_inner - measurement.estimate, state_dot

    def update(
        self, t: RealScalarLike, measurement: ObservedMeasurement, reference, state: PyTree
    ) -> PyTree:
        return self.controller.update(t, measurement.measurement, reference, state)

    def signals(
        self, t: RealScalarLike, measurement: ObservedMeasurement, reference, state: PyTree
    ) -> dict[str, Array]:
        return self.controller.signals(t, measurement.measurement, reference, state)

    def admissible(
        self, t: RealScalarLike, measurement: ObservedMeasurement, reference, state: PyTree
    ) -> Bool[Array, ""]:
        return self.controller.admissible(t, measurement.measurement, reference, state)

    def check_initial(self, t0: float, measurement: ObservedMeasurement, reference) -> None:
        self.controller.check_initial(t0, measurement.measurement, reference)
