"""Checkpoints of a tuning run: the whole optimizer state, written atomically."""

import os
import pathlib

import equinox as eqx
from jaxtyping import Array, Float, Int, PyTree


class TuneState(eqx.Module):
    """Everything a tuning run needs to continue exactly where it stopped."""

    step: Int[Array, ""]
    unconstrained: dict[str, Array]
    opt_state: PyTree
    losses: Float[Array, " steps"]


def save_checkpoint(path: str | os.PathLike, state: TuneState) -> None:
    """Write `state` with `eqx.tree_serialise_leaves` (to a temporary file, then renamed, so an
    interruption never leaves a half-written checkpoint)."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    eqx.tree_serialise_leaves(tmp, state)
    os.replace(tmp, path)


def load_checkpoint(path: str | os.PathLike, like: TuneState) -> TuneState:
    """Read a checkpoint written by [`save_checkpoint`][] into the structure of `like`."""
    return eqx.tree_deserialise_leaves(path, like)
