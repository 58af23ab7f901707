"""Closed-loop composition and fixed-step simulation."""

from ._actuators import (
    AbstractActuator as AbstractActuator,
    Chain as Chain,
    Ideal as Ideal,
    NormSaturation as NormSaturation,
    Saturation as Saturation,
)
from ._closed_loop import (
    ClosedLoop as ClosedLoop,
    ClosedLoopState as ClosedLoopState,
    HeldControl as HeldControl,
)
from ._sampling import (
    AbstractSampling as AbstractSampling,
    Continuous as Continuous,
    ZeroOrderHold as ZeroOrderHold,
)
from ._simulate import simulate as simulate
from ._solvers import (
    RK4 as RK4,
    AbstractFixedStepSolver as AbstractFixedStepSolver,
    DiffraxSolver as DiffraxSolver,
    Euler as Euler,
)
from ._trajectory import RESULTS as RESULTS, Trajectory as Trajectory
