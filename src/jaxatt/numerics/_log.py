r"""The natural logarithm as arithmetic a vectorizing compiler keeps in vector registers.

XLA:CPU lowers a float64 `log` to a call of the C library's scalar `log`, once per element:
the call cannot be vectorized, and in a batched closed loop whose powers are
$|x|^a = \exp(a \ln|x|)$ it took 8.9 % of the run time (Chen 2022 M1, batch 10^4;
benchmarks/README.md). `exp` has no such problem: XLA inlines its own vectorizable
approximation. [`vectorized_log`][] is fdlibm's `__ieee754_log` (Sun Microsystems, 1993; still
FreeBSD's `log`) written as elementwise integer and float operations, which fuse and vectorize
like the rest of the step.
"""

import jax
import jax.numpy as jnp
from jax import lax
from jaxtyping import Array, ArrayLike, Float


# ln 2 split so that k * _LN2_HI is exact for |k| < 2^11 (fdlibm).
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
# fdlibm's minimax coefficients of R(z) ~ (log(1+f) - 2s)/s, s = f/(2+f), z = s^2
# (|error| < 2^-58.45).
_LG1 = 6.666666666666735130e-01
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01

_ABS_MASK = 0x7FFF_FFFF_FFFF_FFFF
_SMALLEST_NORMAL_BITS = 0x0010_0000_0000_0000
_INF_BITS = 0x7FF0_0000_0000_0000


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _log_float64(x: Array) -> Array:
    bits = lax.bitcast_convert_type(x, jnp.int64)
    negative = bits < 0  # the sign bit
    magnitude = bits & _ABS_MASK
    # A subnormal is its integer mantissa times 2^-1074: take the log of that integer (a normal
    # float, exact below 2^53) and subtract 1074 ln 2. Integer tests, so that a CPU treating
    # subnormal inputs as zero (XLA:CPU does) still gets the right value.
    subnormal = magnitude < _SMALLEST_NORMAL_BITS
    integer_mantissa = lax.bitcast_convert_type(
        lax.convert_element_type(magnitude, jnp.float64), jnp.int64
    )
    bits = jnp.where(subnormal, integer_mantissa, magnitude)
    high = bits >> 32
    k = (high >> 20) - jnp.where(subnormal, 1023 + 1074, 1023)
    high = high & 0x000F_FFFF
    # The significand m in [1, 2) is halved when m >= sqrt(2) (`halve` is then 2^20 and carries
    # into k), so that m in [sqrt(2)/2, sqrt(2)).
    halve = (high + 0x95F64) & 0x10_0000
    k = k + (halve >> 20)
    m_bits = ((high | (halve ^ 0x3FF0_0000)) << 32) | (bits & 0xFFFF_FFFF)
    f = lax.bitcast_convert_type(m_bits, jnp.float64) - 1.0
    # log(1 + f) = 2s + s R(s^2), s = f / (2 + f), |s| < 0.1716.
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    r = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7))) + w * (_LG2 + w * (_LG4 + w * _LG6))
    dk = lax.convert_element_type(k, jnp.float64)
    half_f_squared = 0.5 * f * f
    # fdlibm's two assemblies of the same sum: f*f/2 split off where |f| is largest (significands
    # in (1.38, 1.42) before the halving, f in (0.38, 0.414) or (-0.293, -0.29)), else not.
    largest_f = ((high - 0x6147A) | (0x6B851 - high)) > 0
    log_largest_f = dk * _LN2_HI - (
        (half_f_squared - (s * (half_f_squared + r) + dk * _LN2_LO)) - f
    )
    log_other_f = dk * _LN2_HI - ((s * (f - r) - dk * _LN2_LO) - f)
    value = jnp.where(largest_f, log_largest_f, log_other_f)
    # IEEE special values: log(+inf) = +inf, log(nan) = nan, log(x < 0) = nan, log(+-0) = -inf.
    value = jnp.where(magnitude >= _INF_BITS, x, value)
    value = jnp.where(negative & (magnitude != 0), jnp.nan, value)
    return jnp.where(magnitude == 0, -jnp.inf, value)


@jax.custom_jvp
def vectorized_log(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    r"""Natural logarithm $\ln x$, elementwise, as vectorizable arithmetic.

    For float64 it is fdlibm's algorithm: $x = 2^k m$ with $m \in [\sqrt2/2, \sqrt2)$,
    $\ln x = k \ln 2 + \ln(1 + f)$ with $f = m - 1$, and $\ln(1 + f)$ from $s = f/(2 + f)$ by a
    degree-14 minimax polynomial. Error below 1 ulp (`tests/numerics/test_log.py` measures it
    against NumPy over the whole float64 range, subnormals included). IEEE special values as
    `jnp.log`: `log(0) = -inf`, `log(inf) = inf`, `nan` for negative or `nan` input. Subnormal
    inputs get their true logarithm, where XLA:CPU's `jnp.log` treats them as zero.

    Other dtypes go to `jnp.log` (XLA vectorizes float32's itself).

    Components write `jnp.log`: the scalarized program
    ([`Performance`][jaxatt.simulation.Performance]`(scalarize=...)`, the batched Monte Carlo's
    default from 1000 samples) has every float64 `log` replaced by this function, where it is the
    faster one; in a plain vmapped program XLA's `log` is (benchmarks/README.md).

    **Derivative:** $1/x$ (a `jax.custom_jvp`; the bit manipulation has no derivative of its own).
    """
    x = jnp.asarray(x)
    if x.dtype != jnp.float64:
        return jnp.log(x)
    return _log_float64(x)


@vectorized_log.defjvp
def _vectorized_log_jvp(primals, tangents):
    (x,), (x_dot,) = primals, tangents
    x = jnp.asarray(x)
    return vectorized_log(x), jnp.asarray(x_dot) / x


# atanh z = z sum_n z^(2n) / (2n + 1): 16 terms reach 6e-19 relative for |z| < 0.3.
_ATANH_SERIES = tuple(1.0 / (2 * n + 1) for n in range(16))
_ATANH_SERIES_LIMIT = 0.3


@jax.custom_jvp
def vectorized_atanh(x: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    r"""Inverse hyperbolic tangent, elementwise, as vectorizable arithmetic.

    For float64 and $|x| \ge 0.3$: $\operatorname{atanh} x = \tfrac12
    \ln\frac{1 + x}{1 - x}$, the logarithm from [`vectorized_log`][]; below, where that
    quotient's rounding would cost relative accuracy, the series
    $x \sum_{n < 16} x^{2n}/(2n + 1)$ (truncated at $6 \times 10^{-19}$ relative). Within a
    few ulps of NumPy over $(-1, 1)$ (`tests/numerics/test_log.py`); $\pm\infty$ at $\pm 1$,
    NaN beyond and for NaN. XLA:CPU compiles `jnp.arctanh` to a C-library `log` call per
    element. Other dtypes go to `jnp.arctanh`.

    (Goldberg's $\ln(1 + y) = \ln(u)\,y/(u - 1)$, $u = 1 + y$, does not survive XLA: its
    algebraic simplifier rewrites $(1 + y) - 1$ as $y$.)

    **Derivative:** $1/(1 - x^2)$.
    """
    x = jnp.asarray(x)
    if x.dtype != jnp.float64:
        return jnp.arctanh(x)
    return _atanh_float64(x)


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _atanh_float64(x: Array) -> Array:
    magnitude = jnp.abs(x)
    w = x * x
    series = _ATANH_SERIES[-1]
    for coefficient in reversed(_ATANH_SERIES[:-1]):
        series = coefficient + w * series
    half_log = 0.5 * vectorized_log((1.0 + magnitude) / (1.0 - magnitude))
    return jnp.where(
        magnitude < _ATANH_SERIES_LIMIT, x * series, jnp.where(x < 0, -half_log, half_log)
    )


@vectorized_atanh.defjvp
def _vectorized_atanh_jvp(primals, tangents):
    (x,), (x_dot,) = primals, tangents
    x = jnp.asarray(x)
    return vectorized_atanh(x), jnp.asarray(x_dot) / (1.0 - x * x)
