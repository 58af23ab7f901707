"""What a resumed tuning run must share with the run that wrote its checkpoint, as digests.

A checkpoint stores only the optimizer's state, so a run resumed with another training batch,
other starting gains, another closed loop or another objective would continue silently and
publish a result that mixes two problems. [`tune`][jaxatt.tune.tune] writes these digests
into the checkpoint and compares them when it resumes, part by part, so the error names what
differs.
"""

import hashlib
import re
from collections.abc import Callable, Mapping

import equinox as eqx
import jax.tree_util as jtu
import numpy as np
from jaxtyping import PyTree


#: What each part of a fingerprint covers, as the mismatch error words it.
PARTS = {
    "run": "its training batch (`inputs`), starting gains or parameter names",
    "closed_loop": (
        "its closed loop (a plant, controller, reference, observer or actuator value, or their "
        "structure, other than the tuned gains' starting values)"
    ),
    "objective": (
        "its objective (its simulation horizon or step, tolerances, weights, penalties or "
        "aggregate)"
    ),
    "optimizer": (
        "its optimizer's initial state (e.g. a hyperparameter held in it with "
        "optax.inject_hyperparams)"
    ),
}

_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")


def _update_with_array(digest, leaf) -> None:
    """Feed an array-like leaf's dtype, shape and bytes to `digest`."""
    value = np.ascontiguousarray(np.asarray(leaf))
    digest.update(f"{value.dtype}{value.shape}".encode())
    digest.update(value.tobytes())


def _update_with_leaves(digest, tree: PyTree, skip: frozenset = frozenset()) -> None:
    """Feed `tree`'s structure and every leaf to `digest`: an array by its path, dtype, shape
    and bytes; a function by its name; another object by its `repr`; a leaf whose `id` is in
    `skip` by its path only. Object addresses are dropped from the text, so that the digest is
    the same in every process."""
    leaves, treedef = jtu.tree_flatten_with_path(tree)
    digest.update(_ADDRESS.sub("", str(treedef)).encode())
    for path, leaf in leaves:
        digest.update(f"|{jtu.keystr(path)}:".encode())
        if id(leaf) in skip:
            continue
        if eqx.is_array_like(leaf):
            _update_with_array(digest, leaf)
        elif hasattr(leaf, "__qualname__"):  # a function or a class: by its name
            digest.update(f"{getattr(leaf, '__module__', '')}.{leaf.__qualname__}".encode())
        else:  # e.g. a string
            digest.update(f"{type(leaf).__qualname__}:{_ADDRESS.sub('', repr(leaf))}".encode())


def run_digest(template: PyTree, parameters: Mapping, inputs: PyTree) -> str:
    """The training batch, the starting gains and the parameters' names and paths (a
    checkpoint stores only values, so a renamed or swapped parameter of the same shape would
    load). The digest checkpoints have held since they were first compared."""
    digest = hashlib.sha256()
    for name in sorted(parameters):
        digest.update(f"{name}={parameters[name].path};".encode())
    gains = [parameters[name].where(template) for name in sorted(parameters)]
    for leaves in (gains, jtu.tree_leaves(inputs)):
        digest.update(b"|")
        for leaf in leaves:
            _update_with_array(digest, leaf)
    return digest.hexdigest()


def closed_loop_digest(template: PyTree, parameters: Mapping) -> str:
    """Everything of `template` but the tuned gains' values (those are in the run's part)."""
    gains = frozenset(id(parameters[name].where(template)) for name in parameters)
    digest = hashlib.sha256()
    _update_with_leaves(digest, template, gains)
    return digest.hexdigest()


def tree_digest(tree: PyTree) -> str:
    """Every value and the structure of `tree` (e.g. an objective such as `SettlingObjective`,
    or an optimizer's initial state); a plain function by its name (its closure is not
    seen)."""
    digest = hashlib.sha256()
    _update_with_leaves(digest, tree)
    return digest.hexdigest()


def fingerprint(
    template: PyTree,
    parameters: Mapping,
    inputs: PyTree,
    objective: Callable | None = None,
    optimizer_state: PyTree | None = None,
) -> dict[str, str]:
    """What a tuning run is, as digests (SHA-256, hex) by part: the fingerprint
    [`tune`][jaxatt.tune.tune] writes into its checkpoint and compares, part by part, when it
    resumes; for a script that writes its own checkpoints with
    [`save_checkpoint`][jaxatt.tune.save_checkpoint].

    - `"run"`: the training batch `inputs`, the tuned gains' starting values in `template`
      and the parameters' names and paths;
    - `"closed_loop"`: every other value of `template` (its array and number leaves, by path)
      and its structure, static fields included (object addresses left out);
    - `"objective"` (when `objective` is given): its values and structure (a plain function
      by its name: its closure is not seen);
    - `"optimizer"` (when `optimizer_state` is given): the optimizer's initial state
      (`optimizer.init(...)`), so a hyperparameter held in it (`optax.inject_hyperparams`) is
      compared; another learning rate of a plain `optax.adam` has the same state.

    The digests are the same in every process and on every run of the same problem with the
    same software on the same kind of machine (tested across processes). Values are compared
    bit for bit: a template or batch computed on another CPU may differ in its last bits
    (a transcendental function's rounding), and a resume there is refused, naming the part.
    """
    parts = {
        "run": run_digest(template, parameters, inputs),
        "closed_loop": closed_loop_digest(template, parameters),
    }
    if objective is not None:
        parts["objective"] = tree_digest(objective)
    if optimizer_state is not None:
        parts["optimizer"] = tree_digest(optimizer_state)
    return parts
