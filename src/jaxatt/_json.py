"""JSON-safe values: what the reports and summaries write (`null` for a non-finite number)."""

import math

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
