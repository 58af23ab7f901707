r"""Disturbance-observer compensation: any attitude controller plus any observer."""

import equinox as eqx
from jaxtyping import Array, PyTree

from .._custom_types import RealScalarLike, Vec3
from ..observers import AbstractObserver
from ..references import AttitudeReference
from ._base import AbstractController


class ObserverCompensatedState(eqx.Module):
    """The wrapped controller's state and the observer's state, integrated together."""

    controller: PyTree[Array]
    observer: PyTree[Array]


class ObserverCompensated(AbstractController):
    r"""$u = u_{\mathrm{inner}} - \hat d$: a controller with disturbance-estimate compensation.

    The composite of Yu et al. (2022) eq. (29): any attitude controller (FTAC, FT, PD, ...)
    and any [`jaxatt.observers.AbstractObserver`][]. The observer's state is part of the
    controller state, so it is integrated with the plant by the same solver, and the observer
    is driven by the torque this composite commands, $u$ (its model then contains
    $u + \hat d = u_{\mathrm{inner}}$).

    **Arguments:**
    - `controller`: the [`AbstractController`][] whose torque is compensated.
    - `observer`: the disturbance observer, e.g. [`jaxatt.observers.SuperTwistingObserver`][].

    `measurement_type` is the wrapped controller's. `diagnostics` returns the wrapped
    controller's signals (its `"violation"` included) plus the observer's (`"d_hat"`, ...);
    the estimation error is `traj.signals["d_hat"] - traj.signals["disturbance"]`.
    """

    controller: AbstractController
    observer: AbstractObserver

    def __init__(self, controller: AbstractController, observer: AbstractObserver):
        if not isinstance(controller, AbstractController):
            raise TypeError(
                "ObserverCompensated: `controller` must be an AbstractController, got "
                f"{type(controller).__name__}."
            )
        if not isinstance(observer, AbstractObserver):
            raise TypeError(
                "ObserverCompensated: `observer` must be an AbstractObserver, got "
                f"{type(observer).__name__}."
            )
        if not issubclass(controller.measurement_type, observer.measurement_type):
            raise ValueError(
                f"ObserverCompensated: {type(observer).__name__} reads "
                f"{observer.measurement_type.__name__} measurements but "
                f"{type(controller).__name__} is built for {controller.measurement_type.__name__}."
            )
        self.controller = controller
        self.observer = observer

    # The composite accepts whatever its inner controller accepts (ClosedLoop checks this).
    @property
    def measurement_type(self) -> type:  # type: ignore[override]
        return self.controller.measurement_type

    def init(
        self, t0: RealScalarLike, measurement, reference: AttitudeReference
    ) -> ObserverCompensatedState:
        return ObserverCompensatedState(
            controller=self.controller.init(t0, measurement, reference),
            observer=self.observer.init(t0, measurement),
        )

    def __call__(
        self,
        t: RealScalarLike,
        measurement,
        reference: AttitudeReference,
        state: ObserverCompensatedState,
    ) -> tuple[Vec3, ObserverCompensatedState]:
        u_inner, controller_dot = self.controller(t, measurement, reference, state.controller)
        u = u_inner - self.observer.estimate(state.observer)
        observer_dot = self.observer(t, measurement, u, state.observer)
        return u, ObserverCompensatedState(controller=controller_dot, observer=observer_dot)

    def diagnostics(
        self,
        t: RealScalarLike,
        measurement,
        reference: AttitudeReference,
        state: ObserverCompensatedState,
    ) -> dict[str, Array]:
        out = dict(self.controller.diagnostics(t, measurement, reference, state.controller))
        out.update(self.observer.diagnostics(t, measurement, state.observer))
        return out
