"""Disturbance observers: internal states integrated with the plant through a composite
controller ([`jaxatt.controllers.ObserverCompensated`][])."""

from ._base import AbstractObserver as AbstractObserver
from ._super_twisting import (
    SuperTwistingGainCheck as SuperTwistingGainCheck,
    SuperTwistingObserver as SuperTwistingObserver,
    SuperTwistingState as SuperTwistingState,
    super_twisting_gain_condition as super_twisting_gain_condition,
)
