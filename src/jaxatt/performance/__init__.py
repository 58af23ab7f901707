r"""Prescribed performance: envelopes $\rho(t)$ an error must stay inside, and the error
transformation that turns the constrained error into an unconstrained one.

An **envelope** ([`AbstractPerformance`][]) is a decreasing function $\rho(t) > 0$ with
$\rho(0) = \rho_0$ and $\rho(t) \to \rho_\infty$; every one gives its value and its time
derivative in closed form (`value`, `derivative`, `__call__ -> (rho, rho_dot)`), elementwise over
its parameter arrays (one envelope per error component or group):

- [`ExponentialPerformance`][] $\rho = (\rho_0 - \rho_\infty)e^{-\alpha t} + \rho_\infty$
  (Zhang et al. 2021 eq. 20);
- [`CothPerformance`][] $\rho = \coth(l_1 t + l_2) - 1 + \rho_\infty$ (eq. 19);
- [`FiniteTimePerformance`][] $\dot\rho = -q_0(\rho - \rho_\infty)^\alpha$, which reaches
  $\rho_\infty$ exactly at $t = T$ (eq. 36, in SPEC 003.4's closed form).

The **transformation** ([`transform_error`][]) with $\delta = 1$ and $F = \tanh$
(eqs. 22-30): $z = e/\rho$, $\kappa = \operatorname{atanh} z$,
$\beta = \partial\kappa/\partial e = 1/(\rho(1 - z^2))$ and
$\dot\kappa = \beta(\dot e - e\dot\rho/\rho)$. It is finite only for $|e| < \rho$; outside,
[`transform_error`][] saturates $|z|$ just below 1 (never NaN) and the controller reports the
sample's status as `constraint_violated` ([`envelope_margin`][] $\rho - |e|$ is the signal,
[`MinimumMargin`][] the metric; the violation time is the trajectory's `failure_time`).
"""

from ._base import AbstractPerformance as AbstractPerformance
from ._functions import (
    CothPerformance as CothPerformance,
    ExponentialPerformance as ExponentialPerformance,
    FiniteTimePerformance as FiniteTimePerformance,
)
from ._transform import (
    MinimumMargin as MinimumMargin,
    TransformedError as TransformedError,
    envelope_margin as envelope_margin,
    transform_error as transform_error,
)
