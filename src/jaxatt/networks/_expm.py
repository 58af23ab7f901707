r"""A compact matrix exponential for small matrices, cheaper to compile than
`jax.scipy.linalg.expm`: 1.2-2.6x for the value and 1.6-2.8x for its gradient (4 x 4 float64,
lower + compile, `benchmarks/bench_expm_compile.py` with XLA's default flags and with the
suite's, 2026-12-06, the 2-core Xeon shared with other jobs).

Scaling and squaring with the $[13/13]$ Padé approximant (Higham 2005, "The scaling and
squaring method for the matrix exponential revisited", SIAM J. Matrix Anal. Appl. 26(4)):
$s = \max(0, \lceil\log_2(\|A\|_1/\theta_{13})\rceil)$, $\theta_{13} = 5.3719$,
$e^A = r_{13}(2^{-s}A)^{2^s}$. Unlike `jax.scipy.linalg.expm` it has one branch (always the
degree-13 approximant) and squares in a `lax.scan` of fixed length masked by $s$, which
keeps the compiled program small; it is differentiable (the choice of $s$ is piecewise
constant and carries no gradient) and agrees with `jax.scipy.linalg.expm` to ~1e-14
relative (tested). Norms above $\theta_{13}\,2^{40}$ are not supported (clipped $s$).
"""

import jax.lax as lax
import jax.numpy as jnp
from jaxtyping import Array, Float


_PADE13 = (
    64764752532480000.0,
    32382376266240000.0,
    7771770303897600.0,
    1187353796428800.0,
    129060195264000.0,
    10559470521600.0,
    670442572800.0,
    33522128640.0,
    1323241920.0,
    40840800.0,
    960960.0,
    16380.0,
    182.0,
    1.0,
)
_THETA13 = 5.371920351148152
MAX_SQUARINGS = 40


def expm(a: Float[Array, "n n"]) -> Float[Array, "n n"]:
    """$e^A$ by Padé-13 scaling and squaring (see the module docstring)."""
    b = _PADE13
    eye = jnp.eye(a.shape[0], dtype=a.dtype)
    norm = jnp.max(jnp.sum(jnp.abs(a), axis=0))
    s = jnp.clip(jnp.ceil(jnp.log2(norm / _THETA13)), 0, MAX_SQUARINGS)
    s = lax.stop_gradient(jnp.where(jnp.isfinite(s), s, 0.0))
    x = a * 2.0 ** (-s)
    x2 = x @ x
    x4 = x2 @ x2
    x6 = x4 @ x2
    u = x @ (
        x6 @ (b[13] * x6 + b[11] * x4 + b[9] * x2) + b[7] * x6 + b[5] * x4 + b[3] * x2 + b[1] * eye
    )
    v = x6 @ (b[12] * x6 + b[10] * x4 + b[8] * x2) + b[6] * x6 + b[4] * x4 + b[2] * x2 + b[0] * eye
    r = jnp.linalg.solve(v - u, v + u)

    def square(r, i):
        return jnp.where(i < s, r @ r, r), None

    r, _ = lax.scan(square, r, jnp.arange(MAX_SQUARINGS))
    return r
