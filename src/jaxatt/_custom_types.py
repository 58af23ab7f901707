"""The jaxtyping vocabulary used across jaxatt's public signatures."""

from collections.abc import Sequence
from typing import TypeAlias

import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int


RealScalarLike: TypeAlias = float | int | np.floating | np.integer | Float[ArrayLike, ""]
Vector3Like: TypeAlias = Float[ArrayLike, "3"] | Sequence[RealScalarLike]
"""A 3-vector as users write one: an array of shape (3,), or a list or tuple of three numbers."""
Scalar: TypeAlias = Float[Array, ""]
BoolScalar: TypeAlias = Bool[Array, ""]
IntScalar: TypeAlias = Int[Array, ""]
Vec3: TypeAlias = Float[Array, "3"]
Mat33: TypeAlias = Float[Array, "3 3"]
Quaternion: TypeAlias = Float[Array, "4"]
"""Scalar-first Hamilton quaternion `[q0, q1, q2, q3]`."""
MRP: TypeAlias = Float[Array, "3"]
"""Modified Rodrigues parameters `sigma = e tan(phi / 4)`."""
