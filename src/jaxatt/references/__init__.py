"""Desired attitude trajectories $q_d(t)$, $\\omega_d(t)$, $\\dot\\omega_d(t)$."""

from ._base import AbstractReference as AbstractReference, AttitudeReference as AttitudeReference
from ._constant import ConstantAttitude as ConstantAttitude
from ._integrated import IntegratedReference as IntegratedReference
