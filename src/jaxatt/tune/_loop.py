"""The optax tuning loop: a compiled loss-and-gradient and update, a Python loop with progress,
checkpoints, resume."""

import dataclasses
import math
import os
import pathlib
from collections.abc import Callable, Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
import optax
from jaxtyping import Array, PyTree

from .._validation import (
    check_flag,
    check_positive_int,
    check_tree_finite,
)
from ..simulation import Performance
from ..simulation._compiled import compiled
from ._checkpoint import NoCheckpointError, TuneState, load_checkpoint, save_checkpoint
from ._fingerprint import fingerprint as run_fingerprint
from ._objective import AbstractObjective
from ._parameters import apply, check_parameters, constrained, initial_unconstrained


class NonFiniteLossError(FloatingPointError):
    """Raised by [`tune`][] when a step's loss or gradient is not finite.

    - `step`: the step (1-based) whose loss or gradient was not finite;
    - `loss`: that loss;
    - `nonfinite_gradients`: names of the parameters with a non-finite gradient entry;
    - `gains`: the gains at which it was evaluated (name -> NumPy array);
    - `failed`: `(failed, samples)`, how many samples of the batch failed at that step, when
      the objective's aux says (`aux["successful"]`), else `None`.
    - `checkpoint`: whether the run writes a checkpoint (the message says it holds the last
      good step only then).

    The checkpoint (if any) holds the state after the last good step; nothing of the failing
    step is saved.
    """

    def __init__(
        self,
        step: int,
        loss: float,
        nonfinite_gradients: list[str],
        gains: dict,
        failed: tuple[int, int] | None = None,
        checkpoint: bool = False,
    ):
        self.step = step
        self.loss = loss
        self.nonfinite_gradients = nonfinite_gradients
        self.gains = gains
        self.failed = failed
        self.checkpoint = checkpoint
        what = []
        if not math.isfinite(loss):
            what.append(f"the loss is {loss}")
        if nonfinite_gradients:
            what.append(f"the gradient of {', '.join(nonfinite_gradients)} is not finite")
        shown = {k: np.round(v, 6).tolist() for k, v in gains.items()}
        if failed is None:
            cause = (
                "A sample diverged or failed (its convergence time is infinite), or the gains "
                "left the region where the loop is well posed."
            )
        elif failed[0]:
            cause = (
                f"{failed[0]} of {failed[1]} samples failed (a non-finite state, an invalid "
                "plant or a violated constraint: aux['status'])."
            )
        else:
            cause = (
                f"No sample failed (all {failed[1]} succeeded): a metric or penalty of a "
                "successful sample is not finite (e.g. the last-exit settling time of a "
                "sample that never settled, in a penalty or in `times`), or the gradient left "
                "the region where the loop is well posed."
            )
        kept = "; the checkpoint holds" if checkpoint else " after"
        super().__init__(
            f"tune: at step {step}, {' and '.join(what)} (gains {shown}). {cause} Tuning "
            f"stopped{kept} the last good step ({step - 1}). Lower the "
            "learning rate, bound the gains with tighter transforms, shorten dt, or evaluate "
            "the batch at these gains (tune.evaluate) to see which samples failed "
            "(aux['status'])."
        )


def _failed(aux) -> tuple[int, int] | None:
    """`(failed, samples)` from an objective's aux, if it says which samples succeeded."""
    if not isinstance(aux, Mapping) or "successful" not in aux:
        return None
    successful = np.asarray(aux["successful"]).astype(bool).reshape(-1)
    return int(np.sum(~successful)), int(successful.size)


@dataclasses.dataclass(frozen=True)
class TuneResult:
    """Outcome of [`tune`][].

    - `module`: the template with the tuned gains written in (those after the last update).
    - `gains` / `initial_gains`: name -> value (NumPy).
    - `losses`: the loss at each completed step, evaluated before that step's update.
    - `steps`: number of completed steps (including those before a resume).
    - `stopped`: `None` for a run that completed its steps; with `on_nonfinite="stop"`, the
      message of the [`NonFiniteLossError`][] that ended it early (the gains are those of the
      last good step).
    - `gradient_norms`: the global L2 norm of each step's gradient with respect to the
      unconstrained variables (what `optax.clip_by_global_norm` compares). A norm many orders
      above its neighbours says the gradient stopped describing the loss (e.g. a sliding-mode
      loop whose discrete-time chattering amplifies perturbations: its derivative is exact
      but grows like the product of the step Jacobians, while the loss itself moves little).
    - `best_step`, `best_module`, `best_gains`: the step with the lowest loss in `losses`
      (the first such) and the gains it was evaluated at (those after `best_step` updates;
      `best_step == 0` is the starting gains). Selecting on the training loss needs no held-out
      data; the last iterate of a run whose late gradients are uninformative can be worse. The
      gains after the last update (`gains`) are not a candidate, since no step evaluated them:
      compare them with `evaluate` (or run one more step) where they may be the better.
    """

    module: PyTree
    gains: dict[str, np.ndarray]
    initial_gains: dict[str, np.ndarray]
    losses: np.ndarray
    steps: int
    stopped: str | None = None
    gradient_norms: np.ndarray | None = None
    best_step: int | None = None
    best_module: PyTree = None
    best_gains: dict[str, np.ndarray] | None = None


_DEFAULT_OPTIMIZER = optax.adam(0.05)
"""One object, so that runs with the default optimizer share their compiled update."""


MODES = ("reverse", "forward")
"""Differentiation modes of [`loss_and_grad`][] and [`tune`][]."""


def _check_mode(mode, objective) -> str:
    if mode not in MODES:
        raise ValueError(f"tune: `mode` must be 'reverse' or 'forward', got mode={mode!r}.")
    simulation = getattr(objective, "simulation", None)
    if mode == "forward" and getattr(simulation, "checkpoint", None) == "recursive":
        raise ValueError(
            "tune: mode='forward' cannot differentiate an objective with "
            "checkpoint='recursive' (equinox's checkpointed scan is reverse-mode only); "
            "forward mode stores no residuals, so build the objective with checkpoint=True."
        )
    return mode


def loss_and_grad(
    unconstrained: Mapping[str, Array],
    template: PyTree,
    parameters: Mapping,
    objective: Callable,
    inputs: PyTree,
    *,
    mode: str = "reverse",
) -> tuple[tuple[Array, dict[str, Array]], dict[str, Array]]:
    """The loss, its aux and its gradient with respect to the unconstrained parameters:
    `((loss, aux), grads)` for `objective(apply(template, parameters, unconstrained), inputs)`.

    This is the compiled program every [`tune`][] step runs (the optimizer update is a separate,
    small one), so checking its gradient, e.g. against finite differences of
    [`evaluate`][], checks what tuning follows, and calling it before `tune` with the same
    arguments compiles the step once for both (see `tune` on static arguments).

    `mode`: `"reverse"` (default; `eqx.filter_value_and_grad`: one backward sweep whatever the
    number of gains, memory that grows with the horizon) or `"forward"` (`jax.jacfwd`: one
    tangent per scalar gain pushed through the loop with the state, DiffTune-style sensitivity
    propagation: no stored residuals, cost linear in the number of scalar gains). Both give
    the same gradient to rounding.
    """
    _check_mode(mode, objective)
    check_parameters(template, parameters)
    _check_inputs("loss_and_grad", objective, template, inputs)
    fn = _loss_and_grad if mode == "reverse" else _loss_and_grad_forward
    step = _program(fn, objective, (unconstrained, inputs))
    return step(dict(unconstrained), template, parameters, objective, inputs)


def _program(fn: Callable, objective: Callable, inputs: PyTree) -> Callable:
    """`fn` compiled (`eqx.filter_jit`, host-checked: `loss_and_grad`, `tune` and `evaluate`
    check parameters and inputs on the host) with the CPU compiler options of a plain loop:
    the objective's `Performance(library_fusions=...)` choice, jaxatt's default (False)
    for an objective without one. A gradient runs the plain program whatever the objective's
    `scalarize` (see `Performance`)."""
    chosen = getattr(getattr(objective, "simulation", None), "performance", None)
    library = chosen.library_fusions if isinstance(chosen, Performance) else False
    return compiled(fn, Performance(scalarize=False, library_fusions=library), inputs)


def _loss_and_grad(unconstrained, template, parameters, objective, inputs):
    def loss_fn(u):
        return objective(apply(template, parameters, u), inputs)

    return eqx.filter_value_and_grad(loss_fn, has_aux=True)(unconstrained)


def _loss_and_grad_forward(unconstrained, template, parameters, objective, inputs):
    def loss_fn(u):
        loss, aux = objective(apply(template, parameters, u), inputs)
        return loss, (loss, aux)

    grads, (loss, aux) = jax.jacfwd(loss_fn, has_aux=True)(unconstrained)
    return (loss, aux), grads


def _update(
    unconstrained, opt_state, grads, loss, template, parameters, objective, inputs, optimizer
):
    """One optimizer update. An `optax.GradientTransformationExtraArgs` (what `optax.chain`,
    `optax.adam` and `optax.lbfgs` build) also receives `value` (the loss at `unconstrained`),
    `grad` and `value_fn` (the loss as a function of the unconstrained gains: the closed loop
    over the training batch), as optax's line searches need; transformations that take no
    extra arguments ignore them, and a program that never calls `value_fn` holds no closed
    loop."""

    def value_fn(u):
        return objective(apply(template, parameters, u), inputs)[0]

    if isinstance(optimizer, optax.GradientTransformationExtraArgs):
        updates, opt_state = optimizer.update(
            grads, opt_state, unconstrained, value=loss, grad=grads, value_fn=value_fn
        )
    else:
        updates, opt_state = optimizer.update(grads, opt_state, unconstrained)
    return optax.apply_updates(unconstrained, updates), opt_state


def _global_norm(tree) -> float:
    """sqrt of the sum of squares of every entry of `tree` (on the host)."""
    return math.sqrt(sum(float(np.sum(np.square(x))) for x in jtu.tree_leaves(tree)))


def _check_inputs(where: str, objective, module, inputs) -> None:
    batch = "the batch" if where == "evaluate" else "the training batch"
    leaves = jtu.tree_leaves(inputs)
    if not leaves:
        raise ValueError(f"{where}: `inputs` ({batch}) is empty.")
    sizes = {np.shape(leaf)[0] if np.ndim(leaf) else None for leaf in leaves}
    if None in sizes or len(sizes) != 1:
        raise ValueError(
            f"{where}: every leaf of `inputs` must have the same leading (batch) axis, got "
            f"sizes {sorted(s for s in sizes if s is not None)}."
        )
    (size,) = sizes
    if size == 0:
        raise ValueError(f"{where}: `inputs` ({batch}) is empty: it has 0 samples.")
    check_tree_finite(where, "inputs", inputs)
    if isinstance(objective, AbstractObjective):
        objective.check(module, inputs)


def _fresh_state(
    template: PyTree, parameters: Mapping, steps: int, optimizer: optax.GradientTransformation
) -> TuneState:
    """Step 0 of a run: the starting gains (unconstrained, also the best so far), the
    optimizer's initial state and NaN loss and gradient-norm histories of length `steps`."""
    unconstrained = initial_unconstrained(template, parameters)
    return TuneState(
        step=jnp.array(0),
        unconstrained=unconstrained,
        opt_state=optimizer.init(unconstrained),
        losses=jnp.full(steps, jnp.nan),
        gradient_norms=jnp.full(steps, jnp.nan),
        best_unconstrained=unconstrained,
    )


def check_checkpoint(
    template: PyTree,
    parameters: Mapping,
    inputs: PyTree,
    checkpoint: str | os.PathLike,
    *,
    steps: int,
    optimizer: optax.GradientTransformation | None = None,
    objective: Callable | None = None,
) -> int:
    """Check, without compiling or running the closed loop (only the optimizer's initial state
    and the checkpoint's arrays are built), that `checkpoint` can resume
    `tune(template, parameters, objective, inputs, steps=steps, optimizer=optimizer,
    checkpoint=checkpoint, resume=True)`; return the number of steps it has done. The
    objective is compared when it is given.

    For a script that runs several tuning problems in a row and resumes them all: checking
    every checkpoint first finds a wrong one before the earlier runs spend their time (each
    `tune` call checks only its own, when it starts).

    **Raises** [`NoCheckpointError`][] when `checkpoint` does not exist, and
    [`CheckpointMismatchError`][] when it belongs to another run (other parameters or
    optimizer, another training batch or starting gains, another closed loop, objective or
    optimizer state, more steps done than `steps`), the same errors `tune(..., resume=True)`
    raises.
    """
    steps = check_positive_int("check_checkpoint", "steps", steps)
    if not pathlib.Path(checkpoint).is_file():
        raise NoCheckpointError(
            f"check_checkpoint: there is no checkpoint {str(checkpoint)!r} to resume from.",
            [checkpoint],
        )
    check_parameters(template, parameters)
    state = _fresh_state(
        template, parameters, steps, _DEFAULT_OPTIMIZER if optimizer is None else optimizer
    )
    fingerprint = run_fingerprint(template, parameters, inputs, objective, state.opt_state)
    state = load_checkpoint(checkpoint, state, fingerprint)
    return int(state.step)


def tune(
    template: PyTree,
    parameters: Mapping,
    objective: Callable,
    inputs: PyTree,
    *,
    steps: int,
    optimizer: optax.GradientTransformation | None = None,
    checkpoint: str | os.PathLike | None = None,
    checkpoint_every: int = 1,
    resume: bool = False,
    progress: bool = True,
    callback: Callable[[int, float, dict], None] | None = None,
    on_nonfinite: str = "raise",
    mode: str = "reverse",
) -> TuneResult:
    """Tune the `parameters` of `template` by gradient descent on `objective(module, inputs)`.

    **Arguments:**
    - `template`: the module holding the initial gains (e.g. a `ClosedLoop`).
    - `parameters`: name -> [`Parameter`][] (`where` selector + transform).
    - `objective`: `(module, inputs) -> (loss, aux)`, e.g. a [`SettlingObjective`][].
    - `inputs`: the training batch (e.g. stacked initial states), fixed for the whole run.
    - `steps`: total number of optimizer steps (a resumed run continues up to it).
    - `optimizer`: an optax transformation; default `optax.adam(0.05)`. Transformations that
      take extra arguments get `value` (the step's loss), `grad` and `value_fn` (the loss as a
      function of the unconstrained gains), so optax's line searches work as they do in a
      hand-written optax loop: `optax.lbfgs()` (zoom line search, strong Wolfe conditions),
      `optax.lbfgs(linesearch=optax.scale_by_backtracking_linesearch(max_backtracking_steps=15))`
      (Armijo, values only), or any `optax.chain(..., optax.scale_by_backtracking_linesearch(
      max_backtracking_steps=15))`. The training batch is fixed, so the loss is a
      deterministic function of the gains, which is what a line search needs. When a line
      search fails (no trial step meets its condition) optax still applies its last trial
      step, which can raise the loss; `best_step` keeps the best gains either way
      (docs/howto/tuning.md measures both optimizers).
    - `checkpoint`: file for `eqx.tree_serialise_leaves` checkpoints, written every
      `checkpoint_every` steps, at the end, and when interrupted (Ctrl-C).
    - `resume`: continue from `checkpoint`, which must exist: a missing file is a
      [`NoCheckpointError`][] (a `FileNotFoundError`) raised before anything compiles, never
      a quiet fresh start (to resume only where a checkpoint exists, pass
      `resume=pathlib.Path(checkpoint).exists()`). A resumed run ends bit-identical to an
      uninterrupted one (same inputs, same optimizer; XLA:CPU is deterministic). A
      checkpoint written for another training batch, other starting gains or parameter
      names, another closed loop (any value or structure of `template` other than the tuned
      gains) or another objective (its values and structure; a plain function by its name) is
      a [`CheckpointMismatchError`][] (a `ValueError`) that names what differs. The
      optimizer is compared by its initial state (structure and values): another optax
      transformation of the same state (e.g. `optax.adam` with another learning rate) is not
      seen, unless its hyperparameters are in its state (`optax.inject_hyperparams`).
    - `progress`: tqdm progress bar with the current loss.
    - `callback`: called as `callback(step, loss, aux)` after every step.
    - `on_nonfinite`: `"raise"` (default) raises [`NonFiniteLossError`][] when a step's loss or
      gradient is not finite; `"stop"` ends the run there and returns the last good step's
      result with the error's message in `TuneResult.stopped` (for a batch script that must
      report what it reached, e.g. when a step would push a sample across a constraint).
    - `mode`: `"reverse"` (default) or `"forward"` sensitivities (see [`loss_and_grad`][]):
      forward mode wins for a handful of scalar gains on long horizons, where reverse mode's
      stored trajectory dominates memory (measured in `benchmarks/README.md`). `mode` is how
      the step's gradient is computed; optax's zoom line search (`optax.lbfgs()`'s default)
      differentiates `value_fn` at its trial points itself, in reverse mode, whatever `mode`
      (its backtracking line search evaluates values only).

    **Returns:** a [`TuneResult`][].

    **Raises** [`NonFiniteLossError`][] when a step's loss or gradient is not finite (e.g. a
    sample diverged at the current gains): tuning stops at once, naming the step, and the
    checkpoint keeps the last good step. A run never ends with NaN gains.
    [`NoCheckpointError`][] when `resume=True` and `checkpoint` does not exist.

    The configuration is validated before anything is compiled: parameter paths, initial
    values finite and inside their transforms' ranges, a non-empty, finite batch of valid
    initial states, `steps > 0`, a checkpoint to resume from.

    Each step runs two compiled programs: [`loss_and_grad`][] (the closed loop and its reverse
    pass, nearly all the compile time) and the optimizer update (small; with a line search it
    holds the closed loop too, run once per trial step, and the zoom line search's gradient of
    it: about as long to compile as the first). Parameters are
    identified by their paths (strings), so equal tuning problems share the first program
    whatever objects describe them; the optimizer is a static argument of the second,
    compared by identity (optax transformations are closures): reuse one object across runs
    to share the update too (it costs well under a second to compile).
    """
    from tqdm import tqdm

    steps = check_positive_int("tune", "steps", steps)
    checkpoint_every = check_positive_int("tune", "checkpoint_every", checkpoint_every)
    resume = check_flag("tune", "resume", resume)
    progress = check_flag("tune", "progress", progress)
    if optimizer is not None and not all(
        callable(getattr(optimizer, method, None)) for method in ("init", "update")
    ):
        raise ValueError(
            "tune: `optimizer` must be an optax.GradientTransformation (e.g. optax.adam(0.05), "
            f"not optax.adam), got {optimizer!r}."
        )
    if callback is not None and not callable(callback):
        raise ValueError(
            "tune: `callback` must be callable as callback(step, loss, aux), got "
            f"{type(callback).__name__}."
        )
    if resume and checkpoint is None:
        raise ValueError("tune: `resume=True` needs a `checkpoint` path.")
    if resume and not pathlib.Path(checkpoint).is_file():
        raise NoCheckpointError(
            f"tune: `resume=True`, but there is no checkpoint {str(checkpoint)!r} to resume "
            "from (nothing was run). Pass resume=False to start afresh, or "
            "resume=pathlib.Path(checkpoint).exists() to resume only where one exists.",
            [checkpoint],
        )
    if on_nonfinite not in ("raise", "stop"):
        raise ValueError(f"tune: `on_nonfinite` must be 'raise' or 'stop', got {on_nonfinite!r}.")
    _check_mode(mode, objective)
    check_parameters(template, parameters)
    _check_inputs("tune", objective, template, inputs)
    step = _program(
        _loss_and_grad if mode == "reverse" else _loss_and_grad_forward, objective, inputs
    )
    if optimizer is None:
        optimizer = _DEFAULT_OPTIMIZER
    update = _program(_update, objective, inputs)

    state = _fresh_state(template, parameters, steps, optimizer)

    def gains(unconstrained):
        return {k: np.asarray(v) for k, v in constrained(unconstrained, parameters).items()}

    initial_gains = gains(state.unconstrained)
    fingerprint = (
        None
        if checkpoint is None
        else run_fingerprint(template, parameters, inputs, objective, state.opt_state)
    )
    if resume:
        state = load_checkpoint(checkpoint, state, fingerprint)

    def write(state):
        if checkpoint is not None:
            save_checkpoint(checkpoint, state, fingerprint)

    start = int(state.step)
    stopped = None
    bar = tqdm(total=steps, initial=start, desc="tune", disable=not progress)
    try:
        for k in range(start, steps):
            (loss, aux), grads = step(state.unconstrained, template, parameters, objective, inputs)
            loss_value = float(loss)
            bad = [name for name, g in grads.items() if not np.all(np.isfinite(np.asarray(g)))]
            if not math.isfinite(loss_value) or bad:
                write(state)  # the last good step, never the failing one
                gains_now = constrained(state.unconstrained, parameters)
                error = NonFiniteLossError(
                    k + 1,
                    loss_value,
                    bad,
                    {n: np.asarray(v) for n, v in gains_now.items()},
                    _failed(aux),
                    checkpoint is not None,
                )
                if on_nonfinite == "raise":
                    raise error
                stopped = str(error)
                break
            improved = k == 0 or loss_value < np.min(np.asarray(state.losses[:k]))
            u, opt_state = update(
                state.unconstrained,
                state.opt_state,
                grads,
                loss,
                template,
                parameters,
                objective,
                inputs,
                optimizer,
            )
            state = TuneState(
                step=jnp.array(k + 1),
                unconstrained=u,
                opt_state=opt_state,
                losses=state.losses.at[k].set(loss),
                gradient_norms=state.gradient_norms.at[k].set(_global_norm(grads)),
                best_unconstrained=state.unconstrained if improved else state.best_unconstrained,
            )
            bar.update()
            bar.set_postfix(loss=f"{loss_value:.4g}")
            if (k + 1) % checkpoint_every == 0:
                write(state)
            if callback is not None:
                callback(k + 1, loss_value, aux)
    except KeyboardInterrupt:
        write(state)
        raise
    finally:
        bar.close()
    write(state)
    done = int(state.step)
    losses = np.asarray(state.losses[:done])
    return TuneResult(
        module=apply(template, parameters, state.unconstrained),
        gains=gains(state.unconstrained),
        initial_gains=initial_gains,
        losses=losses,
        steps=done,
        stopped=stopped,
        gradient_norms=np.asarray(state.gradient_norms[:done]),
        best_step=int(np.argmin(losses)) if done else 0,
        best_module=apply(template, parameters, state.best_unconstrained),
        best_gains=gains(state.best_unconstrained),
    )


def evaluate(module: PyTree, objective: Callable, inputs: PyTree) -> tuple[Array, dict[str, Array]]:
    """`objective(module, inputs)` compiled once (for validation on a held-out batch).

    The inputs are checked first, as by [`tune`][]. A failed sample shows in the aux
    (`aux["status"]`, `inf` times) and makes the loss `inf`.
    """
    _check_inputs("evaluate", objective, module, inputs)
    return _program(_evaluate, objective, inputs)(module, objective, inputs)


def _evaluate(module, objective, inputs):
    return objective(module, inputs)
