"""Performance metrics of sampled closed-loop signals.

Every metric is a pure function of arrays with time as the leading axis (`traj.ts` and the
recorded signals of a `Trajectory`), so it works under `jit`, `vmap` (the caller adds the batch
axis) and `grad`. Samples need not be uniformly spaced; integrals use the trapezoid rule.

- Convergence: [`settling_time`][] (last exit from a tolerance band, interpolated, with a useful
  gradient), [`settled`][], [`soft_settling_time`][] (smooth surrogate), [`itae`][], [`iae`][].
- Transient: [`overshoot`][].
- Control: [`control_effort`][], [`chattering`][], [`peak`][], [`peak_per_axis`][].
- Constraints: [`constraint_margin`][], [`constraint_violated`][], [`max_abs`][].
"""

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
from ._overshoot import overshoot as overshoot
from ._settling import (
    iae as iae,
    itae as itae,
    settled as settled,
    settling_time as settling_time,
    soft_settling_time as soft_settling_time,
)
