"""Type aliases of the networks package."""

from collections.abc import Sequence
from typing import TypeAlias

import numpy as np
from jaxtyping import ArrayLike


MatrixLike: TypeAlias = ArrayLike | Sequence
"""An array, or nested lists/tuples of numbers (converted with `jnp.asarray`)."""


def as_float(value: MatrixLike, name: str, where: str):
    """`as_float_array` that also accepts nested lists/tuples."""
    from .._validation import as_float_array

    if isinstance(value, (list, tuple)):
        value = np.asarray(value, dtype=float)
    return as_float_array(value, name, where)
