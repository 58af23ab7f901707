"""Control laws. Paper variants are instances of these classes, never copies."""

from ._base import AbstractController as AbstractController
from ._open_loop import OpenLoop as OpenLoop
from ._pd import MRPPD as MRPPD, QuaternionPD as QuaternionPD
