"""Notebook 02's tuning problem as the benchmarks that rerun it build it.

`notebooks/02_tuning.ipynb` tunes `jaxatt.scenarios.chen2022_tuning`'s problem on training and
held-out batches drawn from `jr.split(jr.key(0))`; `bench_tuning_path.py` and
`bench_tuning_optimizers.py` rerun it. jaxatt is imported on the call, so a worker process
that put another version of the library first on its path builds the problem with that one.
"""

import argparse
from typing import NamedTuple


class Notebook02(NamedTuple):
    problem: object  # the jaxatt.scenarios.chen2022_tuning module
    template: object
    parameters: dict
    objective: object
    train: object
    held_out: object


def add_batch_arguments(parser: argparse.ArgumentParser) -> None:
    """`--samples` and `--held-out`, the notebook's batch sizes by default."""
    parser.add_argument("--samples", type=int, default=256, help="training samples (notebook: 256)")
    parser.add_argument(
        "--held-out", type=int, default=256, help="held-out samples (notebook: 256)"
    )


def notebook02(samples: int, held_out: int) -> Notebook02:
    """The problem (float64, the notebook's keys) with `samples` training and `held_out`
    held-out initial states."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.random as jr

    from jaxatt.scenarios import chen2022_tuning as problem, chen2022_two_phase_power as chen

    train_key, held_out_key = jr.split(jr.key(0))
    return Notebook02(
        problem,
        chen.build("M1"),
        problem.parameters(),
        problem.objective(),
        problem.initial_states(train_key, samples),
        problem.initial_states(held_out_key, held_out),
    )
