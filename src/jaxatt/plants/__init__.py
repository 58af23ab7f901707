"""Plants: vector fields of the controlled systems, their measurements and named signals.

The time signals of `jaxatt.signals` (`Constant`, `Sinusoid`, `Pulse`, `Sum`), used for
disturbances and inertia perturbations, are re-exported here for convenience.
"""

from ..signals import (
    AbstractSignal as AbstractSignal,
    Constant as Constant,
    Pulse as Pulse,
    Sinusoid as Sinusoid,
    Sum as Sum,
)
from ._agents import AgentsState as AgentsState, SingleIntegratorAgents as SingleIntegratorAgents
from ._base import AbstractPlant as AbstractPlant
from ._beam import (
    BeamModes as BeamModes,
    CantileverBeam as CantileverBeam,
    cantilever_modes as cantilever_modes,
    cantilever_roots as cantilever_roots,
    mode_curvature as mode_curvature,
    mode_shape as mode_shape,
)
from ._euler_angles import EulerAngleState as EulerAngleState, RigidBodyEuler as RigidBodyEuler
from ._flexible_slosh import (
    FlexibleSloshSpacecraft as FlexibleSloshSpacecraft,
    FlexibleSloshState as FlexibleSloshState,
    ModalAppendage as ModalAppendage,
    SloshPendulum as SloshPendulum,
)
from ._proximity import Proximity as Proximity, ProximityState as ProximityState
from ._relative_orbit import (
    AbstractRelativeOrbit as AbstractRelativeOrbit,
    ClohessyWiltshire as ClohessyWiltshire,
    RelativeOrbit as RelativeOrbit,
    RelativeOrbitJ2 as RelativeOrbitJ2,
    RelativeOrbitState as RelativeOrbitState,
    TschaunerHempel as TschaunerHempel,
    relative_orbit_state as relative_orbit_state,
)
from ._relative_pose import (
    POSE_GROUPS as POSE_GROUPS,
    CoupledAttitudeOrbit as CoupledAttitudeOrbit,
    RelativePoseModel as RelativePoseModel,
    RelativePoseState as RelativePoseState,
    TargetState as TargetState,
)
from ._rigid_body import (
    MRPState as MRPState,
    QuaternionState as QuaternionState,
    RigidBody as RigidBody,
    RigidBodyMRP as RigidBodyMRP,
    RigidBodyQuaternion as RigidBodyQuaternion,
)
from ._six_dof import SixDof as SixDof, SixDofState as SixDofState
