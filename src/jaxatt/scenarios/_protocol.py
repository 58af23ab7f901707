"""The typed protocol every application follows: scenarios (`jaxatt reproduce NAME`) and
tuning problems (`jaxatt tune NAME`)."""

import dataclasses
from collections.abc import Callable

from ..simulation import AbstractClosedLoop, Trajectory


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A reproduced paper (or a built-in example).

    - `name`: the CLI name (`jaxatt reproduce NAME`).
    - `title`: one line, shown by `jaxatt list`.
    - `build(**options) -> AbstractClosedLoop`: the closed loop, with the paper's parameters.
    - `reproduce(out_dir, *, short=False, progress=False) -> dict`: simulate, write figures
      and `metrics.json` to `out_dir`, return the metrics. `short=True` is the CI mode.
    - `metrics(traj) -> dict`: the per-trajectory metrics `metrics.json` reports.
    """

    name: str
    title: str
    build: Callable[..., AbstractClosedLoop]
    reproduce: Callable[..., dict]
    metrics: Callable[[Trajectory], dict]


@dataclasses.dataclass(frozen=True)
class TuningProblem:
    """A tuning problem (`jaxatt tune NAME`).

    `run(out_dir, *, samples, steps, validation_samples, resume, progress) -> dict` tunes,
    validates on a held-out batch and writes a report to `out_dir`.
    """

    name: str
    title: str
    run: Callable[..., dict]
