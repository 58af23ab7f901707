"""The closed-loop contract, its components' glue, and fixed-step simulation."""

from ._actuators import (
    AbstractActuator as AbstractActuator,
    Chain as Chain,
    FirstOrderLag as FirstOrderLag,
    Ideal as Ideal,
    NormSaturation as NormSaturation,
    Saturation as Saturation,
)
from ._closed_loop import (
    AbstractClosedLoop as AbstractClosedLoop,
    ClosedLoop as ClosedLoop,
    ClosedLoopState as ClosedLoopState,
    HeldOutputs as HeldOutputs,
)
from ._energy_meter import EnergyMeter as EnergyMeter, EnergyMeterState as EnergyMeterState
from ._loop import (
    AbstractStream as AbstractStream,
    Streamed as Streamed,
    integrate as integrate,
    integrate_streaming as integrate_streaming,
)
from ._performance import (
    NO_LIBRARY_FUSIONS as NO_LIBRARY_FUSIONS,
    SCALARIZE_FROM as SCALARIZE_FROM,
    SCALARIZED_VECTOR_WIDTH as SCALARIZED_VECTOR_WIDTH,
    Performance as Performance,
    samples_at_once as samples_at_once,
)
from ._sampling import (
    AbstractSampling as AbstractSampling,
    Continuous as Continuous,
    ZeroOrderHold as ZeroOrderHold,
)
from ._settings import Simulation as Simulation
from ._simulate import simulate as simulate
from ._solvers import (
    RK4 as RK4,
    AbstractFixedStepSolver as AbstractFixedStepSolver,
    DiffraxSolver as DiffraxSolver,
    Euler as Euler,
)
from ._status import SimulationFailed as SimulationFailed, Status as Status
from ._trajectory import (
    EVENT_CAPACITY as EVENT_CAPACITY,
    EventRecord as EventRecord,
    Trajectory as Trajectory,
)
