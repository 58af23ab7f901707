"""`vectorized_log`: within 1 ulp of NumPy's log over all of float64, IEEE special values,
derivatives, and the powers that use it; `vectorized_atanh` within 2 ulps."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.numerics import abs_pow, sig_pow, vectorized_atanh, vectorized_log
from jaxatt.simulation._scalarize import pack, scalarize, split

from ..helpers import primitives, ulps


@pytest.fixture(scope="module")
def samples() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    near_one = [1 + rng.uniform(-0.3, 0.5, 20_000), 1 + rng.uniform(-1e-9, 1e-9, 5_000)]
    return {
        # log-uniform over the normal range: every exponent k
        "normal": 10.0 ** rng.uniform(-307.6, 308.2, 50_000),
        # both of fdlibm's assemblies (f*f/2 split off for x in (0.69, 0.71) and (1.38, 1.42)),
        # f ~ 0
        "near one": np.concatenate(near_one),
        # subnormals: integer mantissas 1 .. 2^52 - 1 reinterpreted as float64
        "subnormal": rng.integers(1, 2**52, 20_000).view(np.float64),
        "edges": np.array(
            [
                5e-324,
                2.2250738585072014e-308,  # smallest normal
                np.nextafter(2.2250738585072014e-308, 0),  # largest subnormal
                1.7976931348623157e308,
                np.nextafter(1.0, 2.0),
                np.nextafter(1.0, 0.0),
                np.sqrt(0.5),
                np.sqrt(2.0),
                0.5,
                2.0,
                np.e,
            ]
        ),
    }


@pytest.mark.parametrize("region", ["normal", "near one", "subnormal", "edges"])
def test_within_one_ulp_of_numpy(samples, region):
    x = samples[region]
    value = np.asarray(jax.jit(vectorized_log)(x))
    reference = np.log(x)
    assert value.dtype == np.float64
    assert np.max(ulps(value, reference)) <= 1.0


def test_exact_values():
    x = jnp.array([1.0, 2.0**-1074, 2.0**1000])
    value = jax.jit(vectorized_log)(x)
    assert value[0] == 0.0
    # k ln 2 with ln 2 split in fdlibm's hi/lo parts: the rounding of the exact product
    np.testing.assert_allclose(value[1:], np.array([-1074, 1000]) * np.log(2.0), rtol=2e-16)


def test_ieee_special_values_match_numpy():
    x = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, -np.nan, -1.0, -5e-324])
    with np.errstate(divide="ignore", invalid="ignore"):
        reference = np.log(x)
    np.testing.assert_array_equal(np.asarray(jax.jit(vectorized_log)(x)), reference)


def test_derivatives_are_those_of_log():
    assert jax.grad(vectorized_log)(2.0) == 0.5
    assert jax.jacfwd(jax.grad(vectorized_log))(2.0) == -0.25
    x = jnp.array([0.3, 4.0, 1e-200])
    np.testing.assert_allclose(jax.vmap(jax.grad(vectorized_log))(x), 1 / x, rtol=1e-15)


def test_float32_is_jnp_log():
    x = jnp.array([0.3, 4.0, 1e-30], dtype=jnp.float32)
    value = vectorized_log(x)
    assert value.dtype == jnp.float32
    np.testing.assert_array_equal(value, jnp.log(x))


def test_scalarized_powers_call_no_library_log_and_plain_ones_keep_xlas():
    """XLA:CPU's float64 `log` is a scalar C-library call per element, which keeps a loop over
    `(batch,)` arrays from vectorizing: the scalarizer replaces it by `vectorized_log`. In the
    plain (vmapped) layout XLA's `log` is the faster one (Chen M1's plain Monte Carlo of 256
    samples ran 1.24x slower with `vectorized_log`), so the powers write `jnp.log`."""
    x, a = jnp.array([0.3, -2.0, 0.0]), jnp.array([5 / 9, 31 / 11, 0.5])

    def powers(x, a):
        return jnp.sum(sig_pow(x, a) + abs_pow(x, a))

    def scalarized(x, a):
        return pack(scalarize(powers)(split(x), split(a)), x.dtype)

    assert "log" in primitives(jax.make_jaxpr(powers)(x, a))
    program = primitives(jax.make_jaxpr(scalarized)(x, a))
    assert "log" not in program
    assert "bitcast_convert_type" in program  # vectorized_log's bit arithmetic
    np.testing.assert_allclose(scalarized(x, a), powers(x, a), rtol=1e-15)
    # float32's `log` XLA vectorizes itself: left as it is.
    x32, a32 = x.astype(jnp.float32), a.astype(jnp.float32)
    assert "log" in primitives(jax.make_jaxpr(scalarized)(x32, a32))


def test_vectorized_atanh_within_two_ulps_of_numpy():
    rng = np.random.default_rng(1)
    z = np.concatenate(
        [
            rng.uniform(-1, 1, 50_000),
            10.0 ** rng.uniform(-300, -1, 10_000),  # the series
            rng.uniform(0.29, 0.31, 10_000),  # where the series hands over to the logarithm
            1 - 10.0 ** rng.uniform(-16, -1, 10_000),  # near the pole
            -(1 - 10.0 ** rng.uniform(-16, -1, 10_000)),
        ]
    )
    value = np.asarray(jax.jit(vectorized_atanh)(z))
    assert np.max(ulps(value, np.arctanh(z))) <= 2.0


def test_vectorized_atanh_special_values_and_derivative():
    x = np.array([0.0, -0.0, 1.0, -1.0, 1.5, -2.0, np.nan])
    with np.errstate(divide="ignore", invalid="ignore"):
        reference = np.arctanh(x)
    value = np.asarray(jax.jit(vectorized_atanh)(x))
    np.testing.assert_array_equal(value, reference)
    assert np.signbit(value[1])
    assert jax.grad(vectorized_atanh)(0.5) == 1 / 0.75
    x32 = jnp.array([0.3, -0.9], dtype=jnp.float32)
    np.testing.assert_array_equal(vectorized_atanh(x32), jnp.arctanh(x32))
