"""Checkpoints of a tuning run: the whole optimizer state, written atomically."""

import os
import pathlib
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int, PyTree

from ._fingerprint import PARTS


class NoCheckpointError(FileNotFoundError):
    """Raised when a run asked to resume (`resume=True`, `jaxatt tune --resume`) and there is
    no checkpoint to resume from, before anything is compiled or written.

    A fresh start would be a different run from the one asked for (its `initial_gains`, loss
    history and step count would not continue anything), so it is never made quietly; start
    afresh with `resume=False`, or resume only where a checkpoint exists with
    `resume=pathlib.Path(checkpoint).exists()`.

    - `paths`: the checkpoint files that were looked for (none exists).
    """

    def __init__(self, message: str, paths: Sequence[str | os.PathLike]):
        super().__init__(message)
        self.paths = [pathlib.Path(p) for p in paths]


class CheckpointMismatchError(ValueError):
    """Raised when a run asked to resume from a checkpoint that belongs to another run: other
    parameters or optimizer (the saved state has another structure), another training batch,
    starting gains or parameter names (the fingerprint differs), or more steps done than the
    run asks for. Raised before anything is compiled or written, and the checkpoint is left as
    it was.

    A `ValueError`, so code that caught one before keeps working; `jaxatt tune --resume` turns
    it into exit status 2 (a bad command: nothing was run), not a traceback.

    - `path`: the checkpoint that does not match.
    """

    def __init__(self, message: str, path: str | os.PathLike):
        super().__init__(message)
        self.path = pathlib.Path(path)


class TuneState(eqx.Module):
    """Everything a tuning run needs to continue exactly where it stopped.

    - `step`: steps done; `unconstrained`: the current variables; `opt_state`: the optimizer's.
    - `losses` / `gradient_norms`: per step (NaN for steps not done), the loss and the global
      L2 norm of its gradient with respect to the unconstrained variables.
    - `best_unconstrained`: the variables at which the lowest loss so far was evaluated (the
      starting ones before any step).
    """

    step: Int[Array, ""]
    unconstrained: dict[str, Array]
    opt_state: PyTree
    losses: Float[Array, " steps"]
    gradient_norms: Float[Array, " steps"]
    best_unconstrained: dict[str, Array]


class _TuneStateBefore(eqx.Module):
    """The layout of checkpoints written before `gradient_norms` and `best_unconstrained`
    (recognised only to say so)."""

    step: Int[Array, ""]
    unconstrained: dict[str, Array]
    opt_state: PyTree
    losses: Float[Array, " steps"]


Fingerprint = str | Mapping[str, str]


def _parts(fingerprint: Fingerprint) -> dict[str, str]:
    """A fingerprint's named parts; a plain string is the part named "run" (what checkpoints
    held before the closed loop and the objective were compared)."""
    if isinstance(fingerprint, str):
        return {"run": fingerprint}
    return dict(fingerprint)


def _encode(fingerprint: Fingerprint) -> str:
    parts = _parts(fingerprint)
    for name, value in parts.items():
        if not name.isidentifier() or "\n" in value:
            raise ValueError(
                "save_checkpoint: `fingerprint`'s part names must be identifiers and its values "
                f"one line each, got {name!r}: {value!r}."
            )
    return "\n".join(f"{name}={value}" for name, value in parts.items())


def _decode(text: str) -> dict[str, str]:
    if "=" not in text:  # a plain string: written before fingerprints had parts
        return {"run": text}
    return dict(line.split("=", 1) for line in text.split("\n"))


def save_checkpoint(
    path: str | os.PathLike, state: TuneState, fingerprint: Fingerprint | None = None
) -> None:
    """Write `state` with `eqx.tree_serialise_leaves` (to a temporary file, then renamed, so an
    interruption never leaves a half-written checkpoint).

    The file starts with the length of the loss history, so that a run can be resumed with a
    different total number of steps ([`load_checkpoint`][]); it ends with `fingerprint` (when
    given), which `load_checkpoint` compares: a string, or named parts (`{name: digest}`) that
    are compared one by one. [`tune`][] writes the parts of [`fingerprint`][]: digests of its
    training batch, starting gains and parameter names (`"run"`), of the rest of its closed
    loop (`"closed_loop"`), of its objective (`"objective"`) and of its optimizer's initial
    state (`"optimizer"`).
    """
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    text = None if fingerprint is None else _encode(fingerprint)
    with open(tmp, "wb") as f:
        eqx.tree_serialise_leaves(f, jnp.array(state.losses.shape[0]))
        eqx.tree_serialise_leaves(f, state)
        if text is not None:
            np.save(f, np.frombuffer(text.encode(), np.uint8))
    os.replace(tmp, path)


def load_checkpoint(
    path: str | os.PathLike, like: TuneState, fingerprint: Fingerprint | None = None
) -> TuneState:
    """Read a checkpoint written by [`save_checkpoint`][] into the structure of `like`.

    The loss and gradient-norm histories are padded (with NaN) or cut to `like`'s length, so a run
    stopped after `k` steps can continue to any total `steps >= k`. A checkpoint of another problem
    (other parameters, another optimizer) is a [`CheckpointMismatchError`][] (a `ValueError`) naming
    the file, as is one written by a jaxatt from before the gradient norms and the best step were
    kept; so is, when `fingerprint` is given, a checkpoint written with another fingerprint: every
    part that both fingerprints have is compared (for [`tune`][]'s: another training batch, other
    starting gains or parameter names of the same shapes; another closed loop, objective or
    optimizer state), and the error names the parts that differ. A checkpoint written without a
    fingerprint is not compared.
    """
    with open(path, "rb") as f:
        start = None
        try:
            saved_length = int(eqx.tree_deserialise_leaves(f, jnp.array(0)))
            start = f.tell()
            history = jnp.full(saved_length, jnp.nan)
            saved_like = eqx.tree_at(
                lambda s: (s.losses, s.gradient_norms), like, (history, history)
            )
            state = eqx.tree_deserialise_leaves(f, saved_like)
        except (RuntimeError, ValueError, TypeError) as error:
            if start is not None and _written_before_best(f, start, like, history):
                raise CheckpointMismatchError(
                    f"tune: the checkpoint {str(path)!r} was written by an earlier jaxatt, "
                    "before checkpoints kept the gradient norms and the best step; it cannot "
                    "be resumed exactly. Start afresh (resume=False or another checkpoint "
                    "path).",
                    path,
                ) from None
            raise CheckpointMismatchError(
                f"tune: the checkpoint {str(path)!r} does not belong to this tuning problem "
                f"(other parameters or optimizer?): {error}",
                path,
            ) from None
        try:
            saved = _decode(np.load(f, allow_pickle=False).tobytes().decode())
        except (EOFError, ValueError, UnicodeDecodeError):
            saved = None  # written without a fingerprint
    if fingerprint is not None and saved is not None:
        expected = _parts(fingerprint)
        differ = [name for name in expected if name in saved and saved[name] != expected[name]]
        if differ:
            what = "; ".join(PARTS.get(name, f"its {name!r}") for name in differ)
            raise CheckpointMismatchError(
                f"tune: the checkpoint {str(path)!r} was written for another tuning problem; "
                f"what differs from this call's: {what}. Resume with the same ones, or start "
                "afresh (resume=False or another checkpoint path).",
                path,
            )
    steps = like.losses.shape[0]
    done = int(state.step)
    if done > steps:
        raise CheckpointMismatchError(
            f"tune: the checkpoint {str(path)!r} has {done} steps done, more than steps={steps}.",
            path,
        )

    def fit(saved, template):
        return jnp.full(steps, jnp.nan, dtype=template.dtype).at[:done].set(saved[:done])

    return eqx.tree_at(
        lambda s: (s.losses, s.gradient_norms),
        state,
        (fit(state.losses, like.losses), fit(state.gradient_norms, like.gradient_norms)),
    )


def _written_before_best(f, start: int, like: TuneState, history) -> bool:
    """Whether the file's state (from offset `start`) has the layout of checkpoints written
    before `TuneState` had `gradient_norms` and `best_unconstrained`."""
    before = _TuneStateBefore(like.step, like.unconstrained, like.opt_state, history)
    f.seek(start)
    try:
        eqx.tree_deserialise_leaves(f, before)
    except (RuntimeError, ValueError, TypeError):
        return False
    return True
