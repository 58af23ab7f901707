"""Monte Carlo robustness studies: samplers, the batch runner and its summaries.

- Samplers (explicit keys, a leading batch axis `n`): [`uniform_attitudes`][],
  [`attitudes_within`][], [`mrps_in_ball`][], [`rates_in_box`][], [`rates_in_ball`][],
  [`rates_with_barrier_ratio`][], [`inertia_dispersion`][], [`sinusoid_dispersion`][]; whole
  initial-state sets [`quaternion_states`][], [`mrp_states`][], [`barrier_states`][];
  [`batch_field`][] puts a batch into a closed loop.
- Runs: [`monte_carlo`][] (checked inputs, vmap, `lax.map` chunks, sharding over devices)
  over [`run_batch`][], the one batch runner every batched simulation in jaxatt uses (the
  tuning objectives too; [`check_batch_states`][] is the host check its callers make), with
  [`default_metrics`][] reduced on the fly by default ([`MetricStream`][], nothing stored
  unless `keep_trajectories=True`); it returns a [`MonteCarloResult`][] with `summary()`,
  `table()` and `to_dict()`; [`summary_table`][] compares several batches.
"""

from ._batch import (
    Metrics as Metrics,
    MetricStream as MetricStream,
    batch_field as batch_field,
    check_batch_states as check_batch_states,
    default_metrics as default_metrics,
    evaluate_metrics as evaluate_metrics,
    monte_carlo as monte_carlo,
    run_batch as run_batch,
    streamable as streamable,
)
from ._samplers import (
    attitudes_within as attitudes_within,
    barrier_states as barrier_states,
    inertia_dispersion as inertia_dispersion,
    mrp_states as mrp_states,
    mrps_in_ball as mrps_in_ball,
    quaternion_states as quaternion_states,
    rates_in_ball as rates_in_ball,
    rates_in_box as rates_in_box,
    rates_with_barrier_ratio as rates_with_barrier_ratio,
    sinusoid_dispersion as sinusoid_dispersion,
    uniform_attitudes as uniform_attitudes,
)
from ._summary import MonteCarloResult as MonteCarloResult, summary_table as summary_table
