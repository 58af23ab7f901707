r"""Six-DOF sliding-mode control of a chaser near a target (translation + attitude)."""

from typing import ClassVar

import jax.numpy as jnp

from ..plants import Proximity, ProximityState
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
