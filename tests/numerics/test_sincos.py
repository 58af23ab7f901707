"""`vectorized_sincos`: within 1 ulp of NumPy's sin and cos over its domain (the doubles
nearest multiples of pi/2 included), NaN outside it, special values, derivatives, and no
C-library `sin`/`cos` in float64 programs."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.numerics import vectorized_cos, vectorized_sin, vectorized_sincos
from jaxatt.numerics._sincos import REDUCTION_LIMIT

from ..helpers import primitives, ulps


def _near_multiples_of_half_pi(count: int) -> np.ndarray:
    # The doubles nearest k pi/2 and their neighbours: there the first Cody-Waite round cancels
    # more than 16 bits and the second more than 49 (fdlibm's tests for its later rounds), so
    # the result is only as precise as the later rounds make it.
    centre = np.arange(1, count + 1) * (np.pi / 2)
    below = np.nextafter(centre, 0)
    above = np.nextafter(centre, np.inf)
    x = np.concatenate([centre, below, above, np.nextafter(below, 0)])
    return np.concatenate([x, -x])


@pytest.fixture(scope="module")
def samples() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    sign = rng.choice([-1.0, 1.0], 50_000)
    return {
        "one turn": rng.uniform(-7, 7, 50_000),
        "log-uniform": sign * 10.0 ** rng.uniform(-300, np.log10(REDUCTION_LIMIT), 50_000),
        "whole domain": rng.uniform(-REDUCTION_LIMIT, REDUCTION_LIMIT, 50_000),
        "near k pi/2": _near_multiples_of_half_pi(20_000),
        "far k pi/2": _near_multiples_of_half_pi(2**20 - 1)[-40_000:],
        "edges": np.array(
            [
                np.pi / 4,
                np.nextafter(np.pi / 4, 0),
                np.nextafter(np.pi / 4, 1),
                2.0**-27,
                np.nextafter(2.0**-27, 0),
                1e-8,
                np.nextafter(REDUCTION_LIMIT, 0),
                -np.nextafter(REDUCTION_LIMIT, 0),
            ]
        ),
    }


@pytest.mark.parametrize(
    "region", ["one turn", "log-uniform", "whole domain", "near k pi/2", "far k pi/2", "edges"]
)
def test_within_one_ulp_of_numpy(samples, region):
    x = samples[region]
    sin_x, cos_x = map(np.asarray, jax.jit(vectorized_sincos)(x))
    assert sin_x.dtype == cos_x.dtype == np.float64
    assert np.max(ulps(sin_x, np.sin(x))) <= 1.0
    assert np.max(ulps(cos_x, np.cos(x))) <= 1.0


def test_exact_and_tiny_values():
    x = jnp.array([0.0, -0.0, 5e-324, -2.5e-310, 1e-20])
    sin_x, cos_x = jax.jit(vectorized_sincos)(x)
    np.testing.assert_array_equal(sin_x, np.asarray(x))  # sin x = x below 2^-27, subnormals too
    assert np.signbit(sin_x[1])
    np.testing.assert_array_equal(cos_x, np.ones(5))


def test_nan_outside_the_domain_never_a_number():
    x = np.array([REDUCTION_LIMIT, -REDUCTION_LIMIT, 1e7, 1e300, np.inf, -np.inf, np.nan])
    sin_x, cos_x = jax.jit(vectorized_sincos)(x)
    assert np.all(np.isnan(sin_x)) and np.all(np.isnan(cos_x))


def test_sin_and_cos_are_the_pair():
    x = jnp.linspace(-20.0, 20.0, 101)
    sin_x, cos_x = vectorized_sincos(x)
    np.testing.assert_array_equal(vectorized_sin(x), sin_x)
    np.testing.assert_array_equal(vectorized_cos(x), cos_x)


def test_derivatives_are_those_of_sin_and_cos():
    x = jnp.array([0.3, -2.0, 0.0, 1e5])
    np.testing.assert_allclose(jax.vmap(jax.grad(vectorized_sin))(x), np.cos(x), rtol=1e-15)
    np.testing.assert_allclose(jax.vmap(jax.grad(vectorized_cos))(x), -np.sin(x), atol=1e-16)
    second = jax.vmap(jax.grad(jax.grad(vectorized_sin)))(x)
    np.testing.assert_allclose(second, -np.sin(x), atol=1e-16)
    _, tangents = jax.jvp(vectorized_sincos, (x,), (2 * jnp.ones_like(x),))
    np.testing.assert_allclose(tangents[0], 2 * np.cos(x), rtol=1e-15)


def test_float32_is_jnp_sin_and_cos():
    x = jnp.array([0.3, 4.0, 1e7], dtype=jnp.float32)
    sin_x, cos_x = vectorized_sincos(x)
    assert sin_x.dtype == cos_x.dtype == jnp.float32
    np.testing.assert_array_equal(sin_x, jnp.sin(x))
    np.testing.assert_array_equal(cos_x, jnp.cos(x))


def test_float64_programs_and_their_derivatives_call_no_library_sin_or_cos():
    # XLA:CPU's float64 `sin`/`cos` are scalar C-library calls per element.
    x = jnp.array([0.3, -2.0, 7.0])

    def f(x):
        sin_x, cos_x = vectorized_sincos(x)
        return jnp.sum(sin_x * cos_x)

    for program in (jax.make_jaxpr(f)(x), jax.make_jaxpr(jax.grad(f))(x)):
        assert not {"sin", "cos"} & primitives(program)
    assert {"sin", "cos"} <= primitives(jax.make_jaxpr(lambda x: jnp.sin(x) + jnp.cos(x))(x))
