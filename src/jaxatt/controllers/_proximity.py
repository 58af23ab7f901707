r"""Six-DOF sliding-mode control of a chaser near a target (translation + attitude)."""

from typing import ClassVar

import jax.numpy as jnp

from .._validation import check_instance
from ..plants import Proximity, ProximityState, QuaternionState
from ..references import PoseReference
from ._base import AbstractController
from ._translational import TranslationalSlidingMode


class ProximitySlidingMode(AbstractController):
    r"""Translational sliding mode in the Hill frame plus any attitude-tracking law, mapped to
    body-fixed thrust: $f_B = m\,C_{BN}C_{HN}^T u_H$, $u_H$ from
    [`TranslationalSlidingMode`][], $\tau$ from `attitude` (e.g.
    [`SlidingModeTracking`][] with a reaching law of [`jaxatt.reaching`][]).

    **Arguments:** `model` (a [`jaxatt.plants.Proximity`][]: the mass, orbit orientation and
    relative-motion model the law uses), `translation` (a [`TranslationalSlidingMode`][]),
    `attitude` (a controller reading `QuaternionState` and an `AttitudeReference`).
    **Signals:** `"s"` (translation) and the attitude law's, prefixed `attitude_`.
    """

    model: Proximity
    translation: TranslationalSlidingMode
    attitude: AbstractController
    measurement_type: ClassVar[type] = ProximityState
    reference_type: ClassVar[type] = PoseReference

    def __init__(
        self, model: Proximity, translation: TranslationalSlidingMode, attitude: AbstractController
    ):
        where = "ProximitySlidingMode"
        check_instance(where, "model", model, Proximity, "a jaxatt.plants.Proximity")
        check_instance(
            where,
            "translation",
            translation,
            TranslationalSlidingMode,
            "a TranslationalSlidingMode",
        )
        check_instance(where, "attitude", attitude, AbstractController, "an attitude controller")
        if not issubclass(QuaternionState, attitude.measurement_type):
            raise ValueError(
                f"{where}: `attitude` ({type(attitude).__name__}) reads "
                f"{attitude.measurement_type.__name__} measurements, but it is given the "
                "chaser's attitude as a QuaternionState; use a quaternion attitude law (e.g. "
                "SlidingModeTracking, QuaternionPD)."
            )
        self.model, self.translation, self.attitude = model, translation, attitude

    def init(self, t0, measurement, reference):
        return self.attitude.init(t0, measurement.attitude, reference.attitude)

    def __call__(self, t, measurement, reference, state):
        accel, _ = self.translation(t, measurement.orbit, reference.translation, None)
        torque, state_dot = self.attitude(t, measurement.attitude, reference.attitude, state)
        force = self.model.body_force(measurement, accel)
        return jnp.concatenate([force, torque]), state_dot

    def signals(self, t, measurement, reference, state):
        out = self.translation.signals(t, measurement.orbit, reference.translation, None)
        inner = self.attitude.signals(t, measurement.attitude, reference.attitude, state)
        out.update({f"attitude_{k}": v for k, v in inner.items()})
        return out
