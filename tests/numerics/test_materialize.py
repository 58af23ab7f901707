"""`materialized`: the same values and derivatives, and a value XLA stores once."""

import jax
import jax.numpy as jnp
import numpy as np

from jaxatt.numerics import materialized


SPECIAL = {  # the last value: about the smallest normal number
    np.float64: [1.5, -2.25e300, 0.0, -0.0, np.inf, -np.inf, np.nan, 2.3e-308],
    np.float32: [1.5, -2.25e30, 0.0, -0.0, np.inf, -np.inf, np.nan, 1.2e-38],
}


def test_values_are_returned_bit_for_bit():
    for dtype, values in SPECIAL.items():
        x = np.asarray(values, dtype=dtype)
        for t in (0.0, 7.3, -2.0):  # eagerly and compiled, any finite time
            for y in (materialized(x, t), jax.jit(materialized)(x, t)):
                assert y.dtype == dtype
                np.testing.assert_array_equal(np.asarray(y).view(np.uint8), x.view(np.uint8))
    tree = {"count": jnp.arange(3), "ok": jnp.array([True, False]), "x": jnp.ones(2)}
    out = materialized(tree, 1.0)
    assert out["count"].dtype == jnp.arange(3).dtype and out["ok"].dtype == jnp.bool_


def test_derivative_is_the_identity():
    x = jnp.array([0.3, -1.2, 4.0])
    grad = jax.grad(lambda x, t: jnp.sum(materialized(x, t) ** 2), argnums=(0, 1))(x, 2.0)
    np.testing.assert_array_equal(grad[0], 2 * x)
    assert grad[1] == 0.0  # the divisor is held constant
    tangent = jax.jvp(lambda x: materialized(x, 2.0), (x,), (jnp.ones(3),))[1]
    np.testing.assert_array_equal(tangent, jnp.ones(3))


def test_xla_stores_the_value_instead_of_copying_it_into_each_reader():
    # A value read by two outputs of a vmapped program with a time per sample (as in the
    # batch runner): XLA copies its arithmetic into both kernels, unless the value ends in a
    # division (which XLA does not duplicate).
    def two_readers(x, t, mark):
        y = jnp.sin(x) * x + 1.0
        y = mark(y, t)
        return y * 2.0, y * 3.0

    def kernels(mark):
        batch = jax.vmap(lambda x, t: two_readers(x, t, mark))
        text = jax.jit(batch).lower(jnp.ones(1000), jnp.zeros(1000)).compile().as_text()
        return text.count("sine(")

    assert kernels(lambda y, t: y) == 2  # copied into each reader
    assert kernels(lambda y, t: jax.lax.optimization_barrier(y)) == 2  # a barrier does not help
    assert kernels(materialized) == 1  # computed once
