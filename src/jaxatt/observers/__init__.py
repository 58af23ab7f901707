"""Disturbance observers, integrated in their own slot of the closed loop."""

from ._base import (
    AbstractObserver as AbstractObserver,
    ObservedMeasurement as ObservedMeasurement,
)
from ._integral_sliding_mode import (
    IntegralSlidingModeObserver as IntegralSlidingModeObserver,
    IntegralSlidingModeState as IntegralSlidingModeState,
)
from ._super_twisting import (
    SuperTwistingGainCheck as SuperTwistingGainCheck,
    SuperTwistingObserver as SuperTwistingObserver,
    SuperTwistingState as SuperTwistingState,
    super_twisting_gain_condition as super_twisting_gain_condition,
)
