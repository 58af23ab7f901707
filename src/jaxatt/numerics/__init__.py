"""Numerical primitives with stated derivatives at their singular points.

Every power, norm, sign, extremum and inverse cosine used by jaxatt's metrics, objectives and
switching functions goes through these helpers, so that gradients through a closed loop are
finite wherever the mathematics allows (STYLE rule 7), and never depend on two copies of a value
rounding alike (`amax`, `maximum`, `clip`: derivatives that follow the chosen element).
"""

from ._atan import (
    vectorized_arccos as vectorized_arccos,
    vectorized_arctan as vectorized_arctan,
    vectorized_arctan2 as vectorized_arctan2,
)
from ._extrema import (
    amax as amax,
    amin as amin,
    clip as clip,
    maximum as maximum,
    minimum as minimum,
)
from ._fractional import (
    FractionalMemory as FractionalMemory,
    caputo as caputo,
    grunwald_letnikov_weights as grunwald_letnikov_weights,
    memory_derivative as memory_derivative,
    memory_init as memory_init,
    memory_push as memory_push,
    riemann_liouville as riemann_liouville,
)
from ._linalg import (
    det3 as det3,
    eigvalsh3 as eigvalsh3,
    inv3 as inv3,
    largest_eigenvalue3 as largest_eigenvalue3,
    solve3 as solve3,
    spectral_norm as spectral_norm,
)
from ._log import vectorized_atanh as vectorized_atanh, vectorized_log as vectorized_log
from ._materialize import materialized as materialized
from ._norm import safe_norm as safe_norm, safe_normalize as safe_normalize
from ._power import abs_pow as abs_pow, sig_pow as sig_pow
from ._sincos import (
    vectorized_cos as vectorized_cos,
    vectorized_sin as vectorized_sin,
    vectorized_sincos as vectorized_sincos,
)
from ._switching import (
    rational_sign as rational_sign,
    sat as sat,
    sign as sign,
    smooth_sign as smooth_sign,
)
from ._trig import safe_arccos as safe_arccos
