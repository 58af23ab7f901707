"""Exponents written as ratios of odd integers, as in the papers."""

import numpy as np


def odd_ratio(p: int | np.integer, q: int | np.integer) -> float:
    r"""The exponent $p/q$ for positive odd integers $p$, $q$.

    Papers write fractional exponents as ratios of odd integers (e.g. Chen et al. 2022 eq. (16):
    $p_1/q_1 = 31/11$, $q_2/p_2 = 5/9$) so that $s^{p/q}$ is real and odd for negative $s$.
    jaxatt's laws always use $|s|^a\operatorname{sgn}(s)$, which is defined for any real
    exponent, so they accept any value in the admissible range (what gradient-based tuning
    needs); this helper only checks and documents a paper's choice.

    **Arguments:**
    - `p`, `q`: positive odd integers (Python `int`s).

    **Returns:** `p / q` as a Python float.

    !!! example
        ```python
        DoublePower(k3=1.2, k4=0.8, beta=odd_ratio(31, 11), alpha=odd_ratio(5, 9))
        ```
    """
    for name, value in (("p", p), ("q", q)):
        integer = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        if not integer or value <= 0 or value % 2 == 0:
            raise ValueError(
                f"odd_ratio: `{name}` must be a positive odd integer, got {name}={value!r}."
            )
    return int(p) / int(q)
