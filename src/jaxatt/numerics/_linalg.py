"""Closed-form 3x3 linear algebra.

XLA:CPU lowers `jnp.linalg.solve` and `jnp.linalg.eigvalsh` on a batch of small matrices to a
LAPACK custom call per matrix; the closed forms below are elementwise arithmetic that fuses with
the rest of a vectorized closed loop (DESIGN.md, performance notes).

`det3`, `solve3` and `inv3` are `jax.jit` functions: traced once per argument shape, with their
derivative and batching rules cached, where inline code is traced again at each call site
(docs/testing.md, "Where a test's time goes").
"""

import math

import jax
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, ArrayLike, Float

from ._atan import vectorized_arccos
from ._extrema import amax
from ._norm import safe_norm, safe_normalize
from ._sincos import vectorized_sincos


def _adjugate3(a: Float[Array, "3 3"]) -> Float[Array, "3 3"]:
    # Columns of the adjugate are cross products of the rows of `a`.
    r0, r1, r2 = a[0], a[1], a[2]
    return jnp.stack([jnp.cross(r1, r2), jnp.cross(r2, r0), jnp.cross(r0, r1)], axis=-1)


@jax.jit
def det3(a: Float[ArrayLike, "3 3"]) -> Float[Array, ""]:
    """Determinant of a 3x3 matrix (scalar triple product of its rows)."""
    a = jnp.asarray(a)
    return jnp.dot(a[0], jnp.cross(a[1], a[2]))


@jax.jit
def solve3(a: Float[ArrayLike, "3 3"], b: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
    r"""Solve $a x = b$ (non-singular 3x3 `a`) by Cramer's rule, $x = \mathrm{adj}(a) b / \det a$.

    Exact up to rounding for well-conditioned `a` (an inertia matrix, condition number
    $\lesssim 10^3$); differentiable in `a` and `b`. Singular `a` gives inf/NaN: callers pass
    matrices already validated as positive definite.
    """
    a = jnp.asarray(a)
    b = jnp.asarray(b)
    return (_adjugate3(a) @ b) / det3(a)


@jax.jit
def inv3(a: Float[ArrayLike, "3 3"]) -> Float[Array, "3 3"]:
    """Inverse of a non-singular 3x3 matrix by the adjugate formula (see [`solve3`][])."""
    a = jnp.asarray(a)
    return _adjugate3(a) / det3(a)


def _eigvalsh2(
    a: Float[Array, ""], b: Float[Array, ""], c: Float[Array, ""]
) -> tuple[Float[Array, ""], Float[Array, ""]]:
    """Eigenvalues (smaller, larger) of [[a, b], [b, c]]: the mean -/+ hypot((a - c)/2, b), which
    has no cancellation; gradient of the radius 0 where the two are equal."""
    mean = 0.5 * (a + c)
    radius = safe_norm(jnp.stack([0.5 * (a - c), b]))
    return mean - radius, mean + radius


def eigvalsh3(m: Float[ArrayLike, "3 3"]) -> Float[Array, "3"]:
    r"""Eigenvalues of the symmetric part of a 3x3 matrix, ascending (as
    `jnp.linalg.eigvalsh`), in closed form.

    With $q = \mathrm{tr}(M)/3$, $p = \sqrt{\mathrm{tr}((M - qI)^2)/6}$ and
    $r = \det((M - qI)/p)/2 \in [-1, 1]$, the eigenvalues are
    $q + 2p\cos(\varphi + 2\pi k/3)$, $\varphi = \arccos(r)/3$ (Smith 1961). That formula
    alone loses accuracy to $\sqrt{\varepsilon}$ next to a repeated eigenvalue, so only the
    eigenvalue that is separated from the other two by at least $\sqrt{3}\,p$ is taken from
    it (the largest when $r \ge 0$, the smallest when $r < 0$); the other two are those of the
    2x2 matrix $W^\top M W$ on the plane orthogonal to its eigenvector (a cross product of two
    rows of $M - \lambda I$), $\bar m \mp \mathrm{hypot}((a - c)/2, b)$. Every eigenvalue is
    then accurate to a few $\varepsilon\,\|M\|$, like LAPACK's, repeated ones included.

    Elementwise arithmetic, so a `vmap`ped batch fuses with the rest of a closed loop instead of
    calling LAPACK once per matrix (`jnp.linalg.eigvalsh` on XLA:CPU).
    **Gradient:** $u_k^\top\,dM\,u_k$ for a simple eigenvalue $\lambda_k$ with unit
    eigenvector $u_k$; finite where eigenvalues repeat (the mean of the repeated ones' there),
    including $M = qI$. A NaN entry gives NaN eigenvalues.
    """
    return _scaled(_eigvalsh3_unscaled, m)


def largest_eigenvalue3(m: Float[ArrayLike, "3 3"]) -> Float[Array, ""]:
    r"""The largest eigenvalue of the symmetric part of a 3x3 matrix from Smith's formula
    alone, $q + 2p\cos(\arccos(r)/3)$ (see [`eigvalsh3`][]).

    About half the arithmetic of [`eigvalsh3`][] (no eigenvector): in Zhang 2021's pose
    controller 7.8 against 9.7 s of compile time at 16 samples and 2.27 against 3.29 us per
    state-step at 1000 (benchmarks/README.md, "No LAPACK call in the step").
    **Accuracy:** a few $\varepsilon\|M\|$, except next to a repeated largest eigenvalue,
    where it degrades towards $\sqrt{\varepsilon}\,\|M\|$ (measured: up to
    $5\times10^{-9}\|M\|$ for an exactly repeated one, against $10^{-15}$ elsewhere). For a
    gain that bounds a disturbance (Zhang 2021's robust term) that is immaterial; where the
    value itself is a result, use [`eigvalsh3`][].
    **Gradient:** that of [`eigvalsh3`][]'s largest eigenvalue; finite everywhere.
    """
    return _scaled(lambda unit: _smith(unit)[1], m)


def _scaled(f, m: Float[ArrayLike, "3 3"]):
    """`f` of the symmetric part of `m`, computed on the matrix scaled to entries of at most 1
    (no overflow or underflow in p^2). Eigenvalues are homogeneous of degree 1 in M, so with
    the scale held constant the gradient is exact."""
    m = jnp.asarray(m)
    m = 0.5 * (m + m.T)
    scale = lax.stop_gradient(amax(jnp.abs(m)))
    scale = jnp.where(scale > 0, scale, 1)
    return scale * f(m / scale)


def _smith(m: Float[Array, "3 3"]):
    """(r, largest, smallest) of Smith's formula for a symmetric 3x3 matrix."""
    q = jnp.trace(m) / 3
    deviation = m - q * jnp.eye(3, dtype=m.dtype)
    p2 = jnp.sum(deviation * deviation) / 6
    spread = p2 > 0  # False for M = qI, and for NaN (which then flows through q)
    p = jnp.where(spread, jnp.sqrt(jnp.where(spread, p2, 1)), p2)
    r = det3(deviation / jnp.where(spread, p, 1)) / 2
    inside = jnp.abs(r) < 1
    angle = vectorized_arccos(jnp.where(inside, r, 0))
    phi = jnp.where(inside, angle, jnp.where(r >= 1, 0, math.pi)) / 3
    sin_phi, cos_phi = vectorized_sincos(phi)
    largest = q + 2 * p * cos_phi
    # 2 cos(phi + 2 pi/3) = -(cos phi + sqrt(3) sin phi): one reduction for both, and no
    # cancellation (phi in [0, pi/3], both terms >= 0).
    smallest = q - p * (cos_phi + math.sqrt(3) * sin_phi)
    return r, largest, smallest


def _eigvalsh3_unscaled(m: Float[Array, "3 3"]) -> Float[Array, "3"]:
    eye = jnp.eye(3, dtype=m.dtype)
    r, largest, smallest = _smith(m)
    pair_on_top = r < 0  # then the largest two may be close, the smallest is separated
    separated = jnp.where(pair_on_top, smallest, largest)
    # its eigenvector: the longest cross product of two rows of M - lambda I (rank 2)
    rows = m - separated * eye
    crosses = [
        jnp.cross(rows[0], rows[1]),
        jnp.cross(rows[0], rows[2]),
        jnp.cross(rows[1], rows[2]),
    ]
    lengths = [jnp.sum(c * c) for c in crosses]
    best, best_length = crosses[0], lengths[0]
    for cross, length in zip(crosses[1:], lengths[1:]):
        longer = length > best_length
        best = jnp.where(longer, cross, best)
        best_length = jnp.where(longer, length, best_length)
    u = safe_normalize(best)
    u = jnp.where(best_length > 0, u, eye[0])  # M = qI: any unit vector
    # an orthonormal basis (w1, w2) of the plane orthogonal to u
    helper = jnp.where(
        (jnp.abs(u[0]) <= jnp.abs(u[1])) & (jnp.abs(u[0]) <= jnp.abs(u[2])),
        eye[0],
        jnp.where(jnp.abs(u[1]) <= jnp.abs(u[2]), eye[1], eye[2]),
    )
    w1 = safe_normalize(jnp.cross(u, helper))
    w2 = jnp.cross(u, w1)
    low, high = _eigvalsh2(w1 @ m @ w1, w1 @ m @ w2, w2 @ m @ w2)
    ordered = jnp.where(
        pair_on_top, jnp.stack([separated, low, high]), jnp.stack([low, high, separated])
    )
    # M = qI (no cross product left): every eigenvalue is Smith's, q, with derivative I/3. The
    # pair from the arbitrary plane orthogonal to e_1 would move with that plane's projection
    # (diag(0, 1/2, 1/2)), and the three derivatives would not sum to the trace's I.
    return jnp.where(best_length > 0, ordered, separated)


def _largest_eigenvalue(gram: Float[Array, "n n"]) -> Float[Array, ""]:
    """The largest eigenvalue of a symmetric matrix: closed forms up to 3x3, LAPACK above."""
    n = gram.shape[0]
    if n == 1:
        return gram[0, 0]
    if n == 2:
        return _eigvalsh2(gram[0, 0], 0.5 * (gram[0, 1] + gram[1, 0]), gram[1, 1])[1]
    if n == 3:
        return eigvalsh3(gram)[-1]
    return jnp.linalg.eigvalsh(gram)[-1]


def spectral_norm(a: Float[ArrayLike, "m n"]) -> Float[Array, ""]:
    r"""$\|A\|_2 = \sigma_{\max}(A) = \sqrt{\lambda_{\max}(AA^\top)}$ (the larger Gram matrix is
    never formed: $A^\top A$ when $A$ is tall).

    Computed from the symmetric eigenvalue problem rather than an SVD: the same value, and in a
    closed loop about half the compile time of `jnp.linalg.norm(a, 2)` (measured on the Zhang
    2021 pose controller: forward 8 s against 17 s, with reverse mode 43 s against 70 s). When
    $\min(m, n) \le 3$ the eigenvalue is taken in closed form ([`eigvalsh3`][]): elementwise
    code, no LAPACK call per matrix of a batch; above that, `jnp.linalg.eigvalsh`.
    **Gradient:** $u_1^\top\,dA\,v_1$ where $\sigma_{\max}$ is simple; finite at a repeated
    $\sigma_{\max}$ (up to 3x3 the mean of the repeated ones' derivatives, above that JAX's
    one-sided eigenvalue derivative). At $A = 0$ the gradient is 0 (guarded square root).
    A NaN entry gives NaN.
    """
    a = jnp.asarray(a)
    gram = a.T @ a if a.shape[0] > a.shape[1] else a @ a.T
    largest = _largest_eigenvalue(gram)
    positive = largest > 0
    # 0 where the Gram matrix is 0 (or rounds below it); NaN stays NaN
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, largest, 1.0)), 0 * largest)
