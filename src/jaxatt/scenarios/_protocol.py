"""The typed protocol every application follows: scenarios (`jaxatt reproduce NAME`) and
tuning problems (`jaxatt tune NAME`)."""

import dataclasses
import pathlib
from collections.abc import Callable, Sequence
from typing import NamedTuple

import optax
from jaxtyping import PyTree

from ..simulation import AbstractClosedLoop, Trajectory
from ..tune import NoCheckpointError, TuneResult


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A reproduced paper (or a built-in example).

    - `name`: the CLI name (`jaxatt reproduce NAME`).
    - `title`: one line, shown by `jaxatt list`.
    - `build(**options) -> AbstractClosedLoop`: the closed loop, with the paper's parameters.
    - `reproduce(out_dir, *, short=False, progress=False) -> dict`: simulate, write figures
      and `metrics.json` to `out_dir`, return the metrics exactly as the file holds them
      (`None` where the file has `null`: a time that never came, or, in a run whose status
      says it failed, a value that is not available; see `scenarios._io`).
      `short=True` is the CI mode.
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

    `run(out_dir, *, samples, steps, validation_samples, resume, progress, optimizer) -> dict`
    tunes, validates on a held-out batch and writes a report to `out_dir`; it returns the
    report as `tuning.json` holds it. `optimizer` is one of
    [`OPTIMIZERS`][jaxatt.scenarios.OPTIMIZERS] (see
    [`select_optimizer`][jaxatt.scenarios.select_optimizer]). `resume=True` continues from the
    checkpoint in `out_dir` and raises [`NoCheckpointError`][jaxatt.tune.NoCheckpointError]
    (before anything is compiled or written) when there is none: never a quiet fresh start.
    A step whose loss is not finite either raises
    [`NonFiniteLossError`][jaxatt.tune.NonFiniteLossError] or ends the run early with the
    reason in the report's `stopped` (the problem's docstring says which); `jaxatt tune`
    exits non-zero on both.
    """

    name: str
    title: str
    run: Callable[..., dict]


def require_checkpoint(where: str, out_dir: str | pathlib.Path, names: Sequence[str]) -> None:
    """For a tuning problem's `run(out_dir, resume=True)`: raise
    [`NoCheckpointError`][jaxatt.tune.NoCheckpointError] naming `resume` and `out_dir` unless
    at least one of the checkpoint files `names` is in `out_dir`. Called first, before the
    folder is made or anything is compiled."""
    out = pathlib.Path(out_dir)
    paths = [out / name for name in names]
    if not any(path.is_file() for path in paths):
        looked = ", ".join(names)
        raise NoCheckpointError(
            f"{where}: `resume=True` (CLI: --resume), but there is no checkpoint to resume from "
            f"in {str(out)!r} (looked for {looked}); nothing was run. Leave resume out (or "
            "pass resume=False) to start afresh.",
            paths,
        )


OPTIMIZERS = ("default", "lbfgs")
"""What `jaxatt tune NAME --optimizer` (a tuning problem's `run(..., optimizer=)`) accepts:
the problem's own optimizer, which its recorded runs used, or `optax.lbfgs()` (L-BFGS with
optax's zoom line search; docs/howto/tuning.md, "Adam or L-BFGS")."""


class ChosenOptimizer(NamedTuple):
    """An optimizer of [`select_optimizer`][jaxatt.scenarios.select_optimizer]: the
    transformation `jaxatt.tune.tune` takes, its description for a report's settings, a short
    name for its prose ("Adam steps"), and `validate_best`: whether a problem that validates
    its last step's gains with its default optimizer (so that its recorded runs repeat)
    validates the best step's instead (`TuneResult.best_module`). True for L-BFGS: optax
    applies a line search's last trial point even where none met the search's condition, so
    its last step can be its worst."""

    transformation: optax.GradientTransformation
    label: str
    name: str
    validate_best: bool

    def validated(self, result: TuneResult) -> tuple[PyTree, dict, int]:
        """`(module, gains, step)` a problem that validates its last step under its default
        optimizer validates: the best step's (`validate_best`) or the last step's, `step`
        the number of updates behind them."""
        if self.validate_best:
            return result.best_module, result.best_gains, result.best_step
        return result.module, result.gains, result.steps


def select_optimizer(
    where: str, choice: str, default: optax.GradientTransformation, default_label: str
) -> ChosenOptimizer:
    """The optimizer a tuning problem's `run` uses for `choice` (one of
    [`OPTIMIZERS`][jaxatt.scenarios.OPTIMIZERS]): `"default"`, the problem's `default` (an Adam,
    described by `default_label`); `"lbfgs"`, `optax.lbfgs()`. Anything else is a `ValueError`
    naming `optimizer`, before anything runs."""
    if choice == "default":
        return ChosenOptimizer(default, default_label, "Adam", False)
    if choice == "lbfgs":
        return ChosenOptimizer(optax.lbfgs(), "optax.lbfgs() (zoom line search)", "L-BFGS", True)
    raise ValueError(f"{where}: `optimizer` must be one of {OPTIMIZERS}, got {choice!r}.")
