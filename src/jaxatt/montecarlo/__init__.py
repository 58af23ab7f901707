"""Monte Carlo robustness studies: samplers, batched runs and their summaries.

- Samplers (explicit keys, a leading batch axis `n`): [`uniform_attitudes`][],
  [`attitudes_within`][], [`rates_in_box`][], [`rates_in_ball`][], [`inertia_dispersion`][],
  [`sinusoid_dispersion`][]; [`batch_field`][] puts a batch into a closed loop.
- Runs: [`monte_carlo`][] (vmap, `lax.map` chunks, sharding over devices) with
  [`default_metrics`][], returning a [`MonteCarloResult`][] with `summary()`, `table()` and
  `to_dict()`; [`summary_table`][] compares several batches.
"""

from ._batch import (
    SCALARIZE_FROM as SCALARIZE_FROM,
    batch_field as batch_field,
    default_metrics as default_metrics,
    default_scalarize as default_scalarize,
    monte_carlo as monte_carlo,
)
from ._samplers import (
    attitudes_within as attitudes_within,
    inertia_dispersion as inertia_dispersion,
    rates_in_ball as rates_in_ball,
    rates_in_box as rates_in_box,
    sinusoid_dispersion as sinusoid_dispersion,
    uniform_attitudes as uniform_attitudes,
)
from ._summary import MonteCarloResult as MonteCarloResult, summary_table as summary_table
