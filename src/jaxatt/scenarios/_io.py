"""The one writer of the scenarios' JSON reports (`metrics.json`, `tuning.json`).

A scenario returns its metrics as computed (an unsettled time is `inf`); the file holds their
JSON-safe form, [`json_safe`][] of the returned dict (`inf` and NaN as `null`)."""

import json
import math
import pathlib

import numpy as np


def json_safe(tree):
    """`tree` with every non-finite float (NaN, inf) replaced by `None` (JSON's `null`) and
    NumPy and JAX scalars and arrays turned into Python values; dicts, lists and tuples
    recursively."""
    if isinstance(tree, dict):
        return {k: json_safe(v) for k, v in tree.items()}
    if isinstance(tree, (list, tuple)):
        return [json_safe(v) for v in tree]
    if not isinstance(tree, (np.ndarray, np.generic, str, bytes)) and hasattr(tree, "__array__"):
        tree = np.asarray(tree)  # a JAX array
    if isinstance(tree, np.ndarray):
        return json_safe(tree.tolist())
    if isinstance(tree, np.generic):
        tree = tree.item()
    if isinstance(tree, float) and not math.isfinite(tree):
        return None
    return tree


def write_json(path: str | pathlib.Path, tree) -> None:
    """Write `tree` to `path` as strict JSON (indent 2): non-finite floats become `null`
    ([`json_safe`][]), and the encoder runs with `allow_nan=False`, so a NaN or infinity that
    reaches it another way raises `ValueError` instead of writing invalid JSON."""
    pathlib.Path(path).write_text(json.dumps(json_safe(tree), indent=2, allow_nan=False))
