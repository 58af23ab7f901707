"""Command shaping: zero-vibration smoothers and input shapers, and shaped attitude commands.

A shaper is a unit-integral kernel $u(\\tau)$ convolved with a command; applied to a step it
gives the shaped step response $S(t) = \\int_0^t u$, rising from 0 to 1. Shapers are designed
to leave no residual vibration in a second-order mode $(\\omega_k, \\zeta_k)$; their
`residual_vibration(frequency, damping)` is the classical sensitivity curve (1 for an
unshaped step). [`ShapedAttitude`][] turns one into an attitude reference.
"""

from ._base import AbstractShaper as AbstractShaper, damped_period as damped_period
from ._input_shapers import (
    AbstractImpulseShaper as AbstractImpulseShaper,
    ZeroVibration as ZeroVibration,
    ZeroVibrationDerivative as ZeroVibrationDerivative,
)
from ._reference import ShapedAttitude as ShapedAttitude
from ._smoother import ZeroVibrationSmoother as ZeroVibrationSmoother
