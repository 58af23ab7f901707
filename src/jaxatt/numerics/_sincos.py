r"""Sine and cosine as arithmetic a vectorizing compiler keeps in vector registers.

XLA:CPU lowers a float64 `sin` or `cos` to a call of the C library's scalar function, once per
element (7-8 ns an element here, against 0.7-0.8 ns for `exp`, which XLA inlines). A closed loop
whose state holds an angle (a true anomaly, Euler angles) paid it at every stage:
[`vectorized_sincos`][] is fdlibm's `__ieee754_rem_pio2` (its medium-size path) and its
`__kernel_sin`/`__kernel_cos` (Sun Microsystems, 1993; FreeBSD's `k_sin.c`, `k_cos.c`), written
as elementwise operations that fuse and vectorize like the rest of the step.
"""

import jax
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, ArrayLike, Float

from ._materialize import materialized


# fdlibm's pi/2 in 33-bit pieces, so that n * piece is exact for |n| < 2^20, with tails.
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00
_PIO2_1T = 6.07710050650619224932e-11
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_2T = 2.02226624879595063154e-21
_PIO2_3 = 2.02226624871116645580e-21
_PIO2_3T = 8.47842766036889956997e-32
# The reduction is exact for |x| < 2^20 pi/2 (high word 0x413921fb): `REDUCTION_LIMIT`.
REDUCTION_LIMIT = 2.0**20 * _PIO2_1
# fdlibm's minimax coefficients: sin x ~ x + S1 x^3 + ..., |error| < 2^-58 on [-pi/4, pi/4].
_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10
# cos x ~ 1 - x^2/2 + C1 x^4 + ..., |error| < 2^-58 on [-pi/4, pi/4].
_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11
# Below 2^-27, sin x rounds to x and cos x to 1 (fdlibm returns them directly; doing the same
# keeps subnormal arguments exact where the CPU flushes x * x's inputs to zero).
_TINY = 2.0**-27


def _reduce(x: Array) -> tuple[Array, Array, Array]:
    """`x = n pi/2 + y0 + y1` with |y0 + y1| <= pi/4 (about), for |x| < `REDUCTION_LIMIT`.

    fdlibm's medium path: Cody-Waite subtraction of pi/2 in three rounds of 33 bits (151 bits
    in all), each round's rounding error carried into the tail. fdlibm takes the second and
    third rounds only where the first cancelled more than 16 bits (the second more than 49);
    vector code would compute all three and select, so it always takes the third, which is
    as accurate or more: where there is no cancellation, each round's error term is exact
    (Fast2Sum, |t| >= |n pi2_k|).
    """
    n = jnp.round(x * _INV_PIO2)
    r = x - n * _PIO2_1
    # Second round (118 bits of pi/2).
    t = r
    r = t - n * _PIO2_2
    w = n * _PIO2_2T - ((t - r) - n * _PIO2_2)
    # Third round (151 bits).
    t = r
    r = t - n * _PIO2_3
    w = n * _PIO2_3T - ((t - r) - n * _PIO2_3)
    y0 = r - w
    y1 = (r - y0) - w
    return n, y0, y1


def _kernel_sin(x: Array, y: Array) -> Array:
    """sin(x + y) for |x + y| <= pi/4, y the tail of x (FreeBSD `__kernel_sin`, iy = 1)."""
    z = x * x
    w = z * z
    r = _S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)
    v = z * x
    return x - ((z * (0.5 * y - v * r) - y) - v * _S1)


def _kernel_cos(x: Array, y: Array) -> Array:
    """cos(x + y) for |x + y| <= pi/4, y the tail of x (FreeBSD `__kernel_cos`)."""
    z = x * x
    w = z * z
    r = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    half_z = 0.5 * z
    w = 1.0 - half_z
    return w + (((1.0 - w) - half_z) + (z * r - x * y))


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _sincos_float64(x: Array) -> tuple[Array, Array]:
    n, y0, y1 = _reduce(x)
    sin_y = _kernel_sin(y0, y1)
    cos_y = _kernel_cos(y0, y1)
    # sin(n pi/2 + y), cos(n pi/2 + y) by the quadrant n mod 4.
    quadrant = lax.convert_element_type(n, jnp.int64) & 3
    swap = (quadrant & 1) == 1
    sin_x = jnp.where(swap, cos_y, sin_y)
    cos_x = jnp.where(swap, sin_y, cos_y)
    sin_x = jnp.where(quadrant >= 2, -sin_x, sin_x)
    cos_x = jnp.where((quadrant == 1) | (quadrant == 2), -cos_x, cos_x)
    # Stored once for all readers: XLA would copy the ~75 operations above into every kernel
    # that reads a sine (it never copies the library call, which it counts as expensive).
    sin_x, cos_x = materialized((sin_x, cos_x), x)
    magnitude = jnp.abs(x)
    tiny = magnitude < _TINY
    sin_x = jnp.where(tiny, x, sin_x)
    cos_x = jnp.where(tiny, 1.0, cos_x)
    # Beyond the reduction's exact range (and for inf and nan): nan, never a wrong number.
    outside = ~(magnitude < REDUCTION_LIMIT)
    return jnp.where(outside, jnp.nan, sin_x), jnp.where(outside, jnp.nan, cos_x)


@jax.custom_jvp
def vectorized_sincos(
    x: Float[ArrayLike, "*shape"],
) -> tuple[Float[Array, "*shape"], Float[Array, "*shape"]]:
    r"""$(\sin x, \cos x)$, elementwise, as vectorizable arithmetic.

    For float64 it is fdlibm's algorithm: $x = n\pi/2 + y$ with $|y| \lesssim \pi/4$ by
    Cody-Waite subtraction of $\pi/2$ in three 33-bit pieces (151 bits, so that the doubles
    nearest multiples of $\pi/2$ keep their precision), then degree-13 and degree-14 minimax
    polynomials in $y$ and the quadrant $n \bmod 4$. Error below 1 ulp
    (`tests/numerics/test_sincos.py` measures it against NumPy, including the doubles
    nearest multiples of $\pi/2$).

    **Domain:** the reduction is exact for $|x| < 2^{20}\pi/2 \approx 1.65 \times 10^6$ rad
    (`REDUCTION_LIMIT`, about 262 000 turns). Beyond it, and for $\pm\infty$ and NaN, both
    results are NaN, never a plausible wrong number: a closed loop whose angle leaves that
    range reports a non-finite state. (Larger arguments need Payne-Hanek reduction, a table
    lookup per element; a `jnp.where` fallback to `jnp.sin` would cost every element the
    library call this function exists to avoid.)

    The results are [`materialized`][jaxatt.numerics.materialized] (computed once per
    argument and stored): without that, XLA's loop fusion copied the reduction and both
    polynomials into every kernel reading a sine, and Wu 2018's Monte Carlo ran 0.92x as fast
    as with the library calls instead of 1.45-1.51x (benchmarks/README.md, "Sines and cosines that
    vectorize").

    Other dtypes go to `jnp.sin` and `jnp.cos` (XLA vectorizes float32's itself).

    **Derivative:** $(\cos x\,\dot x, -\sin x\,\dot x)$ (a `jax.custom_jvp`).
    """
    x = jnp.asarray(x)
    if x.dtype != jnp.float64:
        return jnp.sin(x), jnp.cos(x)
    return _sincos_float64(x)


@vectorized_sincos.defjvp
def _vectorized_sincos_jvp(primals, tangents):
    (x,), (x_dot,) = primals, tangents
    sin_x, cos_x = vectorized_sincos(x)
    x_dot = jnp.asarray(x_dot)
    return (sin_x, cos_x), (cos_x * x_dot, -sin_x * x_dot)


def vectorized_sin(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    r"""$\sin x$ from [`vectorized_sincos`][] (same algorithm, domain and derivative)."""
    return vectorized_sincos(x)[0]


def vectorized_cos(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    r"""$\cos x$ from [`vectorized_sincos`][] (same algorithm, domain and derivative)."""
    return vectorized_sincos(x)[1]
