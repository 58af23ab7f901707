"""Control laws. Paper variants are instances of these classes, never copies."""

from ._adaptive_tanh import (
    AbstractAdaptiveTanhSlidingMode as AbstractAdaptiveTanhSlidingMode,
    AdaptiveBoundState as AdaptiveBoundState,
    AdaptiveTanhMRP as AdaptiveTanhMRP,
    AdaptiveTanhQuaternion as AdaptiveTanhQuaternion,
)
from ._base import AbstractController as AbstractController
from ._consensus import TwoLayerConsensus as TwoLayerConsensus
from ._decoupling import (
    AbstractDecoupledLaw as AbstractDecoupledLaw,
    DecoupledPD as DecoupledPD,
    DecoupledSlidingMode as DecoupledSlidingMode,
    FeedbackLinearization as FeedbackLinearization,
    decoupling_drift as decoupling_drift,
    decoupling_matrix as decoupling_matrix,
)
from ._finite_time import (
    FiniteTimeMRP as FiniteTimeMRP,
    RateBarrierState as RateBarrierState,
    RateConstrainedFiniteTimeMRP as RateConstrainedFiniteTimeMRP,
    homogeneous_exponent as homogeneous_exponent,
)
from ._observer_compensated import ObserverCompensated as ObserverCompensated
from ._open_loop import OpenLoop as OpenLoop
from ._pd import MRPPD as MRPPD, QuaternionPD as QuaternionPD
from ._pose_sliding_mode import (
    POSE_COMPONENTS as POSE_COMPONENTS,
    PoseSlidingMode as PoseSlidingMode,
)
from ._proximity import ProximitySlidingMode as ProximitySlidingMode
from ._robust import (
    AbstractRobustTerm as AbstractRobustTerm,
    AxisRobustTerm as AxisRobustTerm,
    NormRobustTerm as NormRobustTerm,
)
from ._safe_approach import (
    SafeApproachSlidingMode as SafeApproachSlidingMode,
    SafeApproachState as SafeApproachState,
)
from ._six_dof import (
    AdaptiveTerminalSixDof as AdaptiveTerminalSixDof,
    SixDofAdaptiveState as SixDofAdaptiveState,
)
from ._sliding_mode import SlidingModeTracking as SlidingModeTracking
from ._time_varying_sliding_mode import (
    PAPER_ALPHA_BAR as PAPER_ALPHA_BAR,
    SHARP_ALPHA_BAR as SHARP_ALPHA_BAR,
    TimeVaryingSlidingMode as TimeVaryingSlidingMode,
    TimeVaryingSlidingModeState as TimeVaryingSlidingModeState,
)
from ._tracking import TrackingErrors as TrackingErrors, tracking_errors as tracking_errors
from ._translational import (
    FractionalSlidingMode as FractionalSlidingMode,
    FractionalSlidingState as FractionalSlidingState,
    TranslationalSlidingMode as TranslationalSlidingMode,
)
