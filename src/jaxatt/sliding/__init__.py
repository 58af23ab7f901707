"""Sliding surfaces $s(e, e_\\omega)$ composed into sliding-mode controllers."""

from ._base import AbstractSlidingSurface as AbstractSlidingSurface
from ._global import (
    AbstractDecay as AbstractDecay,
    ExponentialDecay as ExponentialDecay,
    GlobalSurface as GlobalSurface,
    GlobalSurfaceState as GlobalSurfaceState,
    PolynomialDecay as PolynomialDecay,
)
from ._linear import LinearSurface as LinearSurface
from ._vector import (
    FractionalSurface as FractionalSurface,
    FractionalSurfaceState as FractionalSurfaceState,
    PDSurface as PDSurface,
    TerminalSurface as TerminalSurface,
)
