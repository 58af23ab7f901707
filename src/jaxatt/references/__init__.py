"""Desired trajectories: attitude references and the reference interface."""

from ._base import (
    AbstractReference as AbstractReference,
    AttitudeReference as AttitudeReference,
    NoReference as NoReference,
)
from ._constant import ConstantAttitude as ConstantAttitude
from ._euler import (
    EulerAngleCommand as EulerAngleCommand,
    EulerAngleTrajectory as EulerAngleTrajectory,
)
from ._fly_around import FlyAround as FlyAround, FlyAroundState as FlyAroundState
from ._integrated import IntegratedReference as IntegratedReference
from ._translation import (
    ConstantPose as ConstantPose,
    ConstantPosition as ConstantPosition,
    PoseReference as PoseReference,
    TranslationReference as TranslationReference,
)
