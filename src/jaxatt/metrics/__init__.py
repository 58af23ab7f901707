"""Performance metrics of sampled closed-loop signals: functions of arrays, and metric objects.

Every metric is a pure function of arrays with time as the leading axis (`traj.ts` and the
recorded signals of a `Trajectory`), so it works under `jit`, `vmap` (the caller adds the batch
axis) and `grad`. Samples need not be uniformly spaced; integrals use the trapezoid rule.

- Convergence: [`settling_time`][] (last exit from a tolerance band, interpolated, with a useful
  gradient), [`time_outside`][] and [`convergence_time`][] (continuous in the data, the
  tuning objective's time), [`settled`][], [`soft_settling_time`][] (smooth surrogate),
  [`itae`][], [`iae`][].
- Transient: [`overshoot`][].
- Control: [`control_effort`][], [`chattering`][], [`peak`][], [`peak_per_axis`][].
- Filtering: [`moving_average`][].
- Constraints: [`constraint_margin`][], [`constraint_violated`][], [`max_abs`][].

**Metric objects** ([`SettlingTime`][], [`ConvergenceTime`][], [`TimeOutside`][], [`Peak`][],
[`Final`][], [`Effort`][], [`Chattering`][]) name the trajectory signal they read and a norm
([`Euclidean`][], [`MaxAbs`][], [`Absolute`][]) that reduces it: `monte_carlo` and the tuning
objectives take them, and a failed sample reports their `failure_value` (`inf` for times).
"""

from ._averages import moving_average as moving_average
from ._chattering import chattering as chattering
from ._constraints import (
    constraint_margin as constraint_margin,
    constraint_violated as constraint_violated,
    max_abs as max_abs,
)
from ._effort import (
    control_effort as control_effort,
    peak as peak,
    peak_per_axis as peak_per_axis,
)
from ._objects import (
    Absolute as Absolute,
    AbstractMetric as AbstractMetric,
    AbstractNorm as AbstractNorm,
    Chattering as Chattering,
    ConvergenceTime as ConvergenceTime,
    Effort as Effort,
    Euclidean as Euclidean,
    Final as Final,
    MaxAbs as MaxAbs,
    Peak as Peak,
    SettlingTime as SettlingTime,
    TimeOutside as TimeOutside,
)
from ._overshoot import overshoot as overshoot
from ._settling import (
    convergence_time as convergence_time,
    iae as iae,
    itae as itae,
    settled as settled,
    settling_time as settling_time,
    soft_settling_time as soft_settling_time,
    time_outside as time_outside,
)
