"""Gradient-based gain tuning: parameter transforms, objectives, an optax loop with checkpoints.

!!! example
    ```python
    from jaxatt import tune
    params = {
        "rho": tune.Parameter("controller.reaching_law.rho", tune.Positive()),
        "alpha": tune.Parameter("controller.reaching_law.alpha", tune.Interval(0, 1)),
    }
    objective = tune.SettlingObjective(t1=10.0, dt=5e-3, tolerance=1e-3)
    result = tune.tune(loop, params, objective, x0s, steps=30, checkpoint="run.eqx")
    ```
"""

from ._checkpoint import (
    CheckpointMismatchError as CheckpointMismatchError,
    NoCheckpointError as NoCheckpointError,
    TuneState as TuneState,
    load_checkpoint as load_checkpoint,
    save_checkpoint as save_checkpoint,
)
from ._fingerprint import fingerprint as fingerprint
from ._loop import (
    NonFiniteLossError as NonFiniteLossError,
    TuneResult as TuneResult,
    check_checkpoint as check_checkpoint,
    evaluate as evaluate,
    loss_and_grad as loss_and_grad,
    tune as tune,
)
from ._objective import (
    PENALIZED_METRICS as PENALIZED_METRICS,
    SAMPLE_METRICS as SAMPLE_METRICS,
    AbstractAggregate as AbstractAggregate,
    AbstractObjective as AbstractObjective,
    CVaR as CVaR,
    Mean as Mean,
    MetricObjective as MetricObjective,
    Penalty as Penalty,
    Quantile as Quantile,
    SettlingObjective as SettlingObjective,
    WorstCase as WorstCase,
)
from ._parameters import (
    Parameter as Parameter,
    apply as apply,
    check_parameters as check_parameters,
    constrained as constrained,
    initial_unconstrained as initial_unconstrained,
    with_gains as with_gains,
)
from ._transforms import (
    AbstractTransform as AbstractTransform,
    GreaterThan as GreaterThan,
    Identity as Identity,
    Interval as Interval,
    Positive as Positive,
    nearest_odd_ratio as nearest_odd_ratio,
)
