"""Checkpoints of a tuning run: the whole optimizer state, written atomically."""

import os
import pathlib

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int, PyTree


class NoCheckpointError(FileNotFoundError):
    """Raised when a run asked to resume (`resume=True`, `jaxatt tune --resume`) and there is
    no checkpoint to resume from, before anything is compiled or written.

    A fresh start would be a different run from the one asked for (its `initial_gains`, loss
    history and step count would not continue anything), so it is never made quietly; start
    afresh with `resume=False`, or resume only where a checkpoint exists with
    `resume=pathlib.Path(checkpoint).exists()`.

    - `paths`: the checkpoint files that were looked for (none exists).
    """

    def __init__(self, message: str, paths):
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

    def __init__(self, message: str, path):
        super().__init__(message)
        self.path = pathlib.Path(path)


class TuneState(eqx.Module):
    """Everything a tuning run needs to continue exactly where it stopped."""

    step: Int[Array, ""]
    unconstrained: dict[str, Array]
    opt_state: PyTree
    losses: Float[Array, " steps"]


def save_checkpoint(
    path: str | os.PathLike, state: TuneState, fingerprint: str | None = None
) -> None:
    """Write `state` with `eqx.tree_serialise_leaves` (to a temporary file, then renamed, so an
    interruption never leaves a half-written checkpoint).

    The file starts with the length of the loss history, so that a run can be resumed with a
    different total number of steps ([`load_checkpoint`][]); it ends with `fingerprint` (when
    given: [`tune`][] writes a digest of its training batch, starting gains and parameters), which
    `load_checkpoint` compares.
    """
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    with open(tmp, "wb") as f:
        eqx.tree_serialise_leaves(f, jnp.array(state.losses.shape[0]))
        eqx.tree_serialise_leaves(f, state)
        if fingerprint is not None:
            np.save(f, np.frombuffer(fingerprint.encode(), np.uint8))
    os.replace(tmp, path)


def load_checkpoint(
    path: str | os.PathLike, like: TuneState, fingerprint: str | None = None
) -> TuneState:
    """Read a checkpoint written by [`save_checkpoint`][] into the structure of `like`.

    The loss history is padded (with NaN) or cut to `like`'s length, so a run stopped after
    `k` steps can continue to any total `steps >= k`. A checkpoint of another problem (other
    parameters, another optimizer) is a [`CheckpointMismatchError`][] (a `ValueError`) naming
    the file; so is, when
    `fingerprint` is given, a checkpoint written with another fingerprint (another training
    batch, other starting gains, parameter names of the same shapes). A checkpoint written
    without one is not compared.
    """
    with open(path, "rb") as f:
        try:
            saved_length = int(eqx.tree_deserialise_leaves(f, jnp.array(0)))
            saved_like = eqx.tree_at(lambda s: s.losses, like, jnp.full(saved_length, jnp.nan))
            state = eqx.tree_deserialise_leaves(f, saved_like)
        except (RuntimeError, ValueError, TypeError) as error:
            raise CheckpointMismatchError(
                f"tune: the checkpoint {str(path)!r} does not belong to this tuning problem "
                f"(other parameters or optimizer?): {error}",
                path,
            ) from None
        try:
            saved = np.load(f, allow_pickle=False).tobytes().decode()
        except (EOFError, ValueError, UnicodeDecodeError):
            saved = None  # written without a fingerprint
    if fingerprint is not None and saved is not None and saved != fingerprint:
        raise CheckpointMismatchError(
            f"tune: the checkpoint {str(path)!r} was written for another tuning problem: its "
            "training batch (`inputs`), starting gains or parameter names differ from this call's. "
            "Resume with the same ones, or start afresh (resume=False or another checkpoint "
            "path).",
            path,
        )
    steps = like.losses.shape[0]
    done = int(state.step)
    if done > steps:
        raise CheckpointMismatchError(
            f"tune: the checkpoint {str(path)!r} has {done} steps done, more than steps={steps}.",
            path,
        )
    losses = jnp.full(steps, jnp.nan, dtype=like.losses.dtype)
    losses = losses.at[:done].set(state.losses[:done])
    return eqx.tree_at(lambda s: s.losses, state, losses)
