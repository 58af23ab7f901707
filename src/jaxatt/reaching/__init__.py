r"""Sliding-mode reaching laws $\dot s = r(s)$ with closed-form convergence times.

Every law is an `eqx.Module` whose gains and exponents are array fields (traced,
differentiable, vmappable). `rate(s)` acts elementwise on a scalar or a vector `s`; laws that
reach $s = 0$ in finite time subclass [`AbstractFiniteTimeReachingLaw`][] and give
`convergence_time(s0)`. The switching function is an option object: `Sign()` (the papers'
discontinuous law, the default), `Saturation(width)` or `Tanh(width)` (boundary layer).
"""

from ._base import (
    AbstractFiniteTimeReachingLaw as AbstractFiniteTimeReachingLaw,
    AbstractReachingLaw as AbstractReachingLaw,
)
from ._constant_rate import ConstantRate as ConstantRate
from ._double_power import DoublePower as DoublePower
from ._exponential import Exponential as Exponential
from ._fast_power import FastPower as FastPower
from ._odd_ratio import odd_ratio as odd_ratio
from ._power import Power as Power
from ._switching import (
    AbstractSwitching as AbstractSwitching,
    Saturation as Saturation,
    Sign as Sign,
    Tanh as Tanh,
)
from ._two_phase_power import TwoPhasePower as TwoPhasePower
