"""Checkpoints of a tuning run: the whole optimizer state, written atomically."""

import os
import pathlib

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float, Int, PyTree


class TuneState(eqx.Module):
    """Everything a tuning run needs to continue exactly where it stopped."""

    step: Int[Array, ""]
    unconstrained: dict[str, Array]
    opt_state: PyTree
    losses: Float[Array, " steps"]


def save_checkpoint(path: str | os.PathLike, state: TuneState) -> None:
    """Write `state` with `eqx.tree_serialise_leaves` (to a temporary file, then renamed, so an
    interruption never leaves a half-written checkpoint).

    The file starts with the length of the loss history, so that a run can be resumed with a
    different total number of steps ([`load_checkpoint`][]).
    """
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    with open(tmp, "wb") as f:
        eqx.tree_serialise_leaves(f, jnp.array(state.losses.shape[0]))
        eqx.tree_serialise_leaves(f, state)
    os.replace(tmp, path)


def load_checkpoint(path: str | os.PathLike, like: TuneState) -> TuneState:
    """Read a checkpoint written by [`save_checkpoint`][] into the structure of `like`.

    The loss history is padded (with NaN) or cut to `like`'s length, so a run stopped after
    `k` steps can continue to any total `steps >= k`. A checkpoint of another problem (other
    parameters, another optimizer) is a `ValueError` naming the file.
    """
    with open(path, "rb") as f:
        try:
            saved_length = int(eqx.tree_deserialise_leaves(f, jnp.array(0)))
            saved_like = eqx.tree_at(lambda s: s.losses, like, jnp.full(saved_length, jnp.nan))
            state = eqx.tree_deserialise_leaves(f, saved_like)
        except (RuntimeError, ValueError, TypeError) as error:
            raise ValueError(
                f"tune: the checkpoint {str(path)!r} does not belong to this tuning problem "
                f"(other parameters or optimizer?): {error}"
            ) from None
    steps = like.losses.shape[0]
    done = int(state.step)
    if done > steps:
        raise ValueError(
            f"tune: the checkpoint {str(path)!r} has {done} steps done, more than steps={steps}."
        )
    losses = jnp.full(steps, jnp.nan, dtype=like.losses.dtype)
    losses = losses.at[:done].set(state.losses[:done])
    return eqx.tree_at(lambda s: s.losses, state, losses)
