"""Plants: vector fields of the controlled systems, with their uncertainty and disturbance
signals."""

from ._base import AbstractPlant as AbstractPlant
from ._rigid_body import (
    MRPState as MRPState,
    QuaternionState as QuaternionState,
    RigidBody as RigidBody,
    RigidBodyMRP as RigidBodyMRP,
    RigidBodyQuaternion as RigidBodyQuaternion,
)
from ._signals import (
    AbstractSignal as AbstractSignal,
    Constant as Constant,
    Pulse as Pulse,
    Sinusoid as Sinusoid,
    Sum as Sum,
)
