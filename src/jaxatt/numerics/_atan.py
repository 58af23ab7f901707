r"""Arctangent, two-argument arctangent and arccosine as arithmetic a vectorizing compiler keeps
in vector registers.

XLA:CPU lowers a float64 `atan2` or `acos` to a call of the C library's scalar function, once
per element (6-9 ns an element here, against 0.7-0.9 ns for `exp` and 0.5 ns for `sqrt`,
which XLA inlines). Closed loops met them at every stage: the rotation angle of an attitude error
([`jaxatt.rotations.quat_angle`][], the signal a GNC engineer times convergence on), a pointing
angle ([`safe_arccos`][jaxatt.numerics.safe_arccos]), Smith's eigenvalue formula
([`largest_eigenvalue3`][jaxatt.numerics.largest_eigenvalue3] in Zhang 2021's controller,
through `spectral_norm` in Yue 2018 eq. 22; [`eigvalsh3`][jaxatt.numerics.eigvalsh3]). These
are fdlibm's `atan`, `__ieee754_atan2` and `__ieee754_acos` (Sun Microsystems, 1993; FreeBSD's
`s_atan.c`, `e_atan2.c`, `e_acos.c`): their branches become selects, each element computing
one argument reduction and one polynomial or rational approximation (1.1 ns an element for
`atan2`, 1.8 ns for `acos`; benchmarks/README.md, "Arctangents and an arccosine that
vectorize").
"""

import jax
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, ArrayLike, Float

from ._materialize import materialized


# fdlibm's atan(0.5), atan(1), atan(1.5) and atan(inf) = pi/2, each as a double and its tail.
_ATAN_HI = (
    4.63647609000806093515e-01,
    7.85398163397448278999e-01,
    9.82793723247329054082e-01,
    1.57079632679489655800e00,
)
_ATAN_LO = (
    2.26987774529616870924e-17,
    3.06161699786838301793e-17,
    1.39033110312309984516e-17,
    6.12323399573676603587e-17,
)
# atan t ~ t - t (aT0 t^2 + aT1 t^4 + ... + aT10 t^22) on |t| <= 7/16, |error| < 2^-58.
_AT = (
    3.33333333333329318027e-01,
    -1.99999999998764832476e-01,
    1.42857142725034663711e-01,
    -1.11111104054623557880e-01,
    9.09088713343650656196e-02,
    -7.69187620504482999495e-02,
    6.66107313738753120669e-02,
    -5.83357013379057348645e-02,
    4.97687799461593236017e-02,
    -3.65315727442169155270e-02,
    1.62858201153657823623e-02,
)
_PI = 3.1415926535897931160e00
_PI_LO = 1.2246467991473531772e-16
_PIO2_HI = _ATAN_HI[3]
_PIO2_LO = _ATAN_LO[3]
# acos: asin(sqrt(z)) / sqrt(z) ~ 1 + z R(z), R = P/Q, on z in [0, 1/4], |error| < 2^-58.
_PS = (
    1.66666666666666657415e-01,
    -3.25565818622400915405e-01,
    2.01212532134862925881e-01,
    -4.00555345006794114027e-02,
    7.91534994289814532176e-04,
    3.47933107596021167570e-05,
)
_QS = (
    -2.40339491173441421878e00,
    2.02094576023350569471e00,
    -6.88283971605453293030e-01,
    7.70381505559019352791e-02,
)
# Below 2^-27, atan t rounds to t (fdlibm returns it directly; doing the same keeps
# subnormal arguments, which XLA:CPU's arithmetic flushes to zero, exact).
_TINY = 2.0**-27


def _horner(z: Array, coefficients: tuple[float, ...]) -> Array:
    result = coefficients[-1]
    for c in coefficients[-2::-1]:
        result = c + z * result
    return result


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _atan_of_ratio(y: Array, x: Array) -> Array:
    """atan(y/x) for y, x >= 0, not both 0 or both infinite (NaN gives NaN), by fdlibm
    `atan`'s reduction with the division folded in: by the interval of y/x,
    t = (y - c x)/(x + c y) with c = 0, 1/2, 1, 3/2 or infinity, then atan(c) + atan(t). One
    division whatever the interval (fdlibm `atan2` divides twice: y/x, then the reduction)."""
    # The interval of y/x: [0, 7/16), [7/16, 11/16), [11/16, 19/16), [19/16, 39/16), beyond
    # (NaN included). Nested selects on the comparisons: an int32 interval index and
    # `jnp.select` compiled to code 3.5x slower (benchmarks/README.md, "Arctangents ...").
    above = [y >= 0.4375 * x, y >= 0.6875 * x, y >= 1.1875 * x, ~(y < 2.4375 * x)]

    def by_interval(values):
        result = values[0]
        for condition, value in zip(above, values[1:]):
            result = jnp.where(condition, value, result)
        return result

    # Exact differences for x = 1 (Sterbenz), as fdlibm's a - c.
    t = by_interval([y, 2.0 * y - x, y - x, y - 1.5 * x, -x]) / by_interval(
        [x, 2.0 * x + y, x + y, x + 1.5 * y, y]
    )
    z = t * t
    w = z * z
    # The sum of aT[i] z^(i+1) split into its odd and even terms, as fdlibm evaluates it.
    s1 = z * _horner(w, _AT[0::2])
    s2 = w * _horner(w, _AT[1::2])
    # atan(c) as head and tail (0 below 7/16, where this is fdlibm's t - t (s1 + s2) exactly).
    hi = by_interval([0.0, *_ATAN_HI])
    lo = by_interval([0.0, *_ATAN_LO])
    return hi - ((t * (s1 + s2) - lo) - t)


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _atan2_float64(y: Array, x: Array) -> Array:
    # A quarter of each (exact, a power of 2), so that x + 1.5 y cannot overflow. Inputs below
    # 4 times the smallest normal number then count as 0, as subnormal ones do in XLA:CPU's
    # arithmetic (it flushes them).
    ay, ax = 0.25 * jnp.abs(y), 0.25 * jnp.abs(x)
    # fdlibm's special cases by quadrant fall out of the general formula once 0/0 is read as 0
    # (atan2(+-0, +-0) = +-0 or +-pi) and inf/inf as 1 (+-pi/4 or +-3pi/4); a NaN stays NaN.
    both_zero = (ay == 0) & (ax == 0)
    both_infinite = jnp.isinf(ay) & jnp.isinf(ax)
    ay = jnp.where(both_infinite, 1.0, ay)
    ax = jnp.where(both_zero | both_infinite, 1.0, ax)
    z = _atan_of_ratio(ay, ax)
    # Beyond 2^60 (x = +-0 included) the angle rounds to pi/2 on either side of the y axis;
    # placing it by the sign of x would round 1 ulp off.
    steep = ay > 2.0**60 * ax
    z = jnp.where(steep, _PIO2_HI, z)
    left = jnp.signbit(x) & ~steep  # x < 0 or x = -0: angles beyond pi/2
    z = jnp.where(left, _PI - (z - _PI_LO), z)
    return jnp.where(jnp.signbit(y), -z, z)


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _acos_float64(x: Array) -> Array:
    a = jnp.abs(x)
    small = a < 0.5
    z = jnp.where(small, x * x, (1.0 - a) * 0.5)
    r = z * _horner(z, _PS) / (1.0 + z * _horner(z, _QS))
    s = jnp.sqrt(z)
    # |x| < 1/2: pi/2 - asin x, asin x = x + x r.
    centre = _PIO2_HI - (x - (_PIO2_LO - x * r))
    # x < -1/2: pi - 2 asin(s), s = sqrt((1 + x)/2).
    left = _PI - 2.0 * (s + (r * s - _PIO2_LO))
    # x > 1/2: 2 asin(s), s = sqrt((1 - x)/2) split as df + c, df its upper 32 bits (exact
    # square), c the correction.
    df = lax.bitcast_convert_type(
        lax.bitcast_convert_type(s, jnp.uint64) & jnp.uint64(0xFFFFFFFF00000000), jnp.float64
    )
    c = (z - df * df) / (s + df)
    right = 2.0 * (df + (r * s + c))
    result = jnp.where(small, centre, jnp.where(x < 0, left, right))
    # acos(1) = 0 and acos(-1) = pi exactly (s + df = 0 above); |x| > 1 is NaN.
    result = jnp.where(x == 1.0, 0.0, jnp.where(x == -1.0, _PI, result))
    return jnp.where(a > 1.0, jnp.nan, result)


def _stored(angle: Array) -> Array:
    # Stored once for all readers (XLA would copy the ~40 cheap operations above into every
    # kernel that reads the angle). The angle itself, finite or NaN, is the batched value
    # that `materialized` needs.
    return materialized(angle, angle)


@jax.custom_jvp
def vectorized_arctan(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    r"""$\arctan x \in [-\pi/2, \pi/2]$, elementwise, as vectorizable arithmetic.

    For float64 it is fdlibm's `atan`: $|x|$ reduced to $|t| \le 7/16$ by
    $\arctan x = \arctan c + \arctan\frac{x - c}{1 + c x}$ with $c \in \{0, 1/2, 1, 3/2,
    \infty\}$ chosen by the interval of $|x|$, then a degree-23 odd minimax polynomial in $t$.
    Within 1 ulp of NumPy (`tests/numerics/test_atan.py`). NaN gives NaN,
    $\pm\infty$ gives $\pm\pi/2$. Other dtypes go to `jnp.arctan`.

    **Derivative:** $\dot x / (1 + x^2)$.
    """
    x = jnp.asarray(x)
    if x.dtype != jnp.float64:
        return jnp.arctan(x)
    a = jnp.abs(x)
    z = _atan_of_ratio(a, jnp.ones_like(a))
    z = _stored(jnp.where(jnp.signbit(x), -z, z))
    return jnp.where(a < _TINY, x, z)  # after the store, whose division flushes subnormals


@vectorized_arctan.defjvp
def _vectorized_arctan_jvp(primals, tangents):
    (x,), (x_dot,) = primals, tangents
    x = jnp.asarray(x)
    return vectorized_arctan(x), jnp.asarray(x_dot) / (1 + x * x)


@jax.custom_jvp
def vectorized_arctan2(
    y: Float[ArrayLike, "*#shape"], x: Float[ArrayLike, "*#shape"]
) -> Float[Array, "*#shape"]:
    r"""$\mathrm{atan2}(y, x) \in [-\pi, \pi]$, the angle of the point $(x, y)$, elementwise, as
    vectorizable arithmetic (`jnp.arctan2`'s arguments and broadcasting).

    For float64 it is fdlibm's `__ieee754_atan2`: $\arctan(|y|/|x|)$ from
    [`vectorized_arctan`][jaxatt.numerics.vectorized_arctan]'s reduction with the division
    folded in ($t = (|y| - c|x|)/(|x| + c|y|)$, one rounding where fdlibm divides twice), then
    placed in its quadrant by the signs of $x$ and $y$ ($\pi - z$ with $\pi$'s tail carried).
    Within 1 ulp of NumPy (`tests/numerics/test_atan.py`). C's special values: signed zeros
    (atan2(+-0, -0) = +-pi), infinities (atan2(+-inf, -inf) = +-3pi/4), NaN in, NaN out. Like
    all of XLA:CPU's arithmetic it treats subnormal numbers as zero (inputs below 4 times the
    smallest normal number too: both are scaled by 1/4 so that nothing overflows).

    The result is [`materialized`][jaxatt.numerics.materialized] (computed once and stored
    for every reader, as [`vectorized_sincos`][jaxatt.numerics.vectorized_sincos]'s).
    Other dtypes go to `jnp.arctan2`.

    **Derivative:** $(x\,\dot y - y\,\dot x)/(x^2 + y^2)$ (NaN at the origin, as
    `jnp.arctan2`'s).
    """
    y, x = jnp.broadcast_arrays(jnp.asarray(y), jnp.asarray(x))
    dtype = jnp.result_type(y, x)
    if dtype != jnp.float64:
        return jnp.arctan2(y, x)
    return _stored(_atan2_float64(y.astype(dtype), x.astype(dtype)))


@vectorized_arctan2.defjvp
def _vectorized_arctan2_jvp(primals, tangents):
    (y, x), (y_dot, x_dot) = primals, tangents
    y, x = jnp.broadcast_arrays(jnp.asarray(y), jnp.asarray(x))
    angle = vectorized_arctan2(y, x)
    return angle, (x * jnp.asarray(y_dot) - y * jnp.asarray(x_dot)) / (x * x + y * y)


@jax.custom_jvp
def vectorized_arccos(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    r"""$\arccos x \in [0, \pi]$, elementwise, as vectorizable arithmetic.

    For float64 it is fdlibm's `__ieee754_acos`: with $\arcsin$'s rational minimax
    approximation $\arcsin u \approx u + u\,R(u^2)$ on $|u| \le 1/2$,
    $\arccos x = \pi/2 - \arcsin x$ for $|x| < 1/2$, $\pi - 2\arcsin\sqrt{(1+x)/2}$ below
    $-1/2$ and $2\arcsin\sqrt{(1-x)/2}$ above $1/2$ (the square root split into a head with
    an exact square and a correction, so no accuracy is lost next to $x = 1$). Within 1 ulp
    of NumPy (`tests/numerics/test_atan.py`); $\arccos(\pm 1)$ exact; NaN for $|x| > 1$ and
    NaN. The result is [`materialized`][jaxatt.numerics.materialized]. Other dtypes go to
    `jnp.arccos`.

    **Derivative:** $-\dot x/\sqrt{(1 - x)(1 + x)}$ (infinite at $\pm 1$; see
    [`safe_arccos`][jaxatt.numerics.safe_arccos] for a finite one).
    """
    x = jnp.asarray(x)
    if x.dtype != jnp.float64:
        return jnp.arccos(x)
    return _stored(_acos_float64(x))


@vectorized_arccos.defjvp
def _vectorized_arccos_jvp(primals, tangents):
    (x,), (x_dot,) = primals, tangents
    x = jnp.asarray(x)
    return vectorized_arccos(x), -jnp.asarray(x_dot) / jnp.sqrt((1 - x) * (1 + x))
