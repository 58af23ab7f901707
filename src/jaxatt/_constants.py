"""Values known when a program is traced: NumPy constants, not arrays of the program."""

import numpy as np


def is_known_zero(x) -> bool:
    """Whether `x` is a NumPy constant whose entries are all zero: a value the traced program
    holds as a constant (e.g. [`jaxatt.references.ConstantAttitude`][]'s rates), so that a
    product with it can be left out exactly where XLA would compute it (XLA keeps $x \\cdot 0$,
    which is NaN for an infinite $x$)."""
    return isinstance(x, np.ndarray | np.generic) and not np.any(x)
