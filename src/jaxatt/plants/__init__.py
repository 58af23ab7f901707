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
from ._base import AbstractPlant as AbstractPlant
from ._proximity import Proximity as Proximity, ProximityState as ProximityState
from ._relative_orbit import (
    AbstractRelativeOrbit as AbstractRelativeOrbit,
    ClohessyWiltshire as ClohessyWiltshire,
    RelativeOrbit as RelativeOrbit,
    RelativeOrbitState as RelativeOrbitState,
    TschaunerHempel as TschaunerHempel,
    relative_orbit_state as relative_orbit_state,
)
from ._rigid_body import (
    MRPState as MRPState,
    QuaternionState as QuaternionState,
    RigidBody as RigidBody,
    RigidBodyMRP as RigidBodyMRP,
    RigidBodyQuaternion as RigidBodyQuaternion,
)
from ._six_dof import SixDof as SixDof, SixDofState as SixDofState
