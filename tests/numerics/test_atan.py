"""`vectorized_arctan`, `vectorized_arctan2`, `vectorized_arccos`: within 1 ulp of NumPy (the
boundaries of fdlibm's reduction intervals included), C's special values, derivatives, and no
C-library `atan`/`atan2`/`acos` in float64 programs."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.numerics import vectorized_arccos, vectorized_arctan, vectorized_arctan2

from ..helpers import primitives, ulps


# fdlibm's reduction switches at |x| = 7/16, 11/16, 19/16 and 39/16.
_BOUNDARIES = np.array([0.4375, 0.6875, 1.1875, 2.4375])


def _around(points: np.ndarray, count: int, rng) -> np.ndarray:
    spread = points[:, None] * (1 + rng.uniform(-1e-6, 1e-6, (len(points), count)))
    exact = np.concatenate([points, np.nextafter(points, 0), np.nextafter(points, 9)])
    return np.concatenate([spread.ravel(), exact])


@pytest.fixture(scope="module")
def samples() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    n = 40_000
    sign = rng.choice([-1.0, 1.0], n)
    return {
        "unit": rng.uniform(-1, 1, n),
        "wide": rng.uniform(-5, 5, n),
        "log-uniform": sign * 10.0 ** rng.uniform(-300, 300, n),
        "interval edges": np.concatenate([b := _around(_BOUNDARIES, 2000, rng), -b]),
        "next to 1": 1 - 10.0 ** rng.uniform(-16, 0, n),
        "next to -1": -1 + 10.0 ** rng.uniform(-16, 0, n),
    }


@jax.jit
def _all(y, x):
    return vectorized_arctan(y), vectorized_arctan2(y, x), vectorized_arccos(jnp.clip(y, -1, 1))


@pytest.mark.parametrize(
    "region", ["unit", "wide", "log-uniform", "interval edges", "next to 1", "next to -1"]
)
def test_within_one_ulp_of_numpy(samples, region):
    y = samples[region]
    # x spans every quadrant and every ratio y/x, the interval edges included.
    x = np.random.default_rng(1).permutation(samples["log-uniform"][: len(y)])
    x = np.resize(x, y.shape)
    arctan, arctan2, arccos = map(np.asarray, _all(y, x))
    assert np.max(ulps(arctan, np.arctan(y))) <= 1.0
    assert np.max(ulps(arctan2, np.arctan2(y, x))) <= 1.0
    assert np.max(ulps(arccos, np.arccos(np.clip(y, -1, 1)))) <= 1.0
    # y/x at the interval edges, in all four quadrants.
    ratios = _BOUNDARIES[np.arange(len(y)) % 4] * (1 + np.clip(y, -1, 1) * 1e-12)
    x_edge = np.where(np.arange(len(y)) % 3 == 0, -1.0, 1.0) * np.abs(x)
    y_edge = np.where(np.arange(len(y)) % 5 == 0, -1.0, 1.0) * ratios * np.abs(x)
    finite = np.isfinite(y_edge) & (np.abs(y_edge) > 1e-300)
    edge = np.asarray(_all(y_edge[finite], x_edge[finite])[1])
    assert np.max(ulps(edge, np.arctan2(y_edge[finite], x_edge[finite]))) <= 1.0


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return bool(np.all((a == b) & (np.signbit(a) == np.signbit(b)) | (np.isnan(a) & np.isnan(b))))


def test_special_values_are_those_of_c():
    values = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 1.0, -1.0, 3.0, 1.7e308, -1e-300])
    y, x = (a.ravel() for a in np.meshgrid(values, values))
    arctan, arctan2, _ = _all(y, x)
    # Signed zeros (atan2(+-0, -0) = +-pi), infinities (atan2(+-inf, -inf) = +-3 pi/4) and
    # NaN exactly as C's; the finite pairs within 1 ulp.
    special = ~np.isfinite(y) | ~np.isfinite(x) | (y == 0) | (x == 0)
    assert _same(np.asarray(arctan2)[special], np.arctan2(y, x)[special])
    assert np.max(ulps(np.asarray(arctan2)[~special], np.arctan2(y, x)[~special])) <= 1.0
    assert _same(arctan, np.arctan(y))
    arccos = vectorized_arccos(np.array([1.0, -1.0, 0.0, -0.0, 1.0 + 2**-52, -2.0, np.nan]))
    np.testing.assert_array_equal(arccos[:2], [0.0, np.pi])  # exact at the ends
    np.testing.assert_array_equal(arccos[2:4], [np.pi / 2, np.pi / 2])
    assert np.all(np.isnan(arccos[4:]))  # outside [-1, 1]: NaN, never a clipped angle


def test_tiny_and_subnormal_inputs():
    tiny = np.array([1e-20, -1e-20, 5e-324, -2.5e-310])
    np.testing.assert_array_equal(vectorized_arctan(tiny), tiny)  # atan x = x, subnormals too
    # atan2 counts subnormal magnitudes as 0, as XLA:CPU's arithmetic flushes them (and as
    # `jnp.arctan2` does here, whose library call runs under the same flags).
    np.testing.assert_array_equal(vectorized_arctan2(1e-320, 1.0), 0.0)
    np.testing.assert_array_equal(vectorized_arctan2(1e-320, -1.0), np.pi)
    np.testing.assert_array_equal(jnp.arctan2(1e-320, 1.0), 0.0)


def test_derivatives():
    y = jnp.array([0.3, -2.0, 0.0, 1e5, -0.7])
    x = jnp.array([1.0, -0.5, 2.0, -3.0, -1e-3])
    np.testing.assert_allclose(
        jax.vmap(jax.grad(vectorized_arctan))(y), 1 / (1 + np.asarray(y) ** 2), rtol=1e-15
    )
    for argnum in (0, 1):
        np.testing.assert_allclose(
            jax.vmap(jax.grad(vectorized_arctan2, argnum))(y, x),
            jax.vmap(jax.grad(jnp.arctan2, argnum))(y, x),
            rtol=1e-15,
        )
    u = jnp.array([0.3, -0.9, 0.0, 0.999999])
    np.testing.assert_allclose(
        jax.vmap(jax.grad(vectorized_arccos))(u), -1 / np.sqrt(1 - np.asarray(u) ** 2), rtol=1e-9
    )
    second = jax.vmap(jax.grad(jax.grad(vectorized_arctan)))(y)
    np.testing.assert_allclose(second, jax.vmap(jax.grad(jax.grad(jnp.arctan)))(y), rtol=1e-14)


def test_float32_is_jnp():
    y = jnp.array([0.3, 4.0, -1e7], dtype=jnp.float32)
    x = jnp.array([-1.0, 0.5, 2.0], dtype=jnp.float32)
    u = jnp.array([0.3, -0.9, 1.0], dtype=jnp.float32)
    for ours, theirs in (
        (vectorized_arctan(y), jnp.arctan(y)),
        (vectorized_arctan2(y, x), jnp.arctan2(y, x)),
        (vectorized_arccos(u), jnp.arccos(u)),
    ):
        assert ours.dtype == jnp.float32
        np.testing.assert_array_equal(ours, theirs)


def test_broadcasts_like_jnp_arctan2():
    y = jnp.linspace(-1.0, 1.0, 6).reshape(2, 3)
    np.testing.assert_allclose(vectorized_arctan2(y, -0.5), jnp.arctan2(y, -0.5), rtol=3e-16)
    assert vectorized_arctan2(y, jnp.ones(3)).shape == (2, 3)


def test_float64_programs_and_their_derivatives_call_no_library_function():
    # XLA:CPU's float64 `atan`, `atan2` and `acos` are scalar C-library calls per element.
    y = jnp.array([0.3, -2.0, 7.0])

    def f(y):
        return jnp.sum(vectorized_arctan(y) + vectorized_arctan2(y, 2.0 - y))

    def g(u):
        return jnp.sum(vectorized_arccos(u / 8))

    library = {"atan", "atan2", "acos"}
    for program in (jax.make_jaxpr(f)(y), jax.make_jaxpr(jax.grad(f))(y)):
        assert not library & primitives(program)
    for program in (jax.make_jaxpr(g)(y), jax.make_jaxpr(jax.grad(g))(y)):
        assert not library & primitives(program)
    assert library <= primitives(
        jax.make_jaxpr(lambda y: jnp.arctan(y) + jnp.arctan2(y, 1.0) + jnp.arccos(y))(y)
    )
