"""Fractional operators against closed forms, at their theoretical (first) order in h."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.special import gamma

from jaxatt.numerics import (
    caputo,
    grunwald_letnikov_weights,
    memory_derivative,
    memory_init,
    memory_push,
    riemann_liouville,
)


STEPS = (1 / 64, 1 / 128, 1 / 256)


def observed_orders(errors):
    errors = np.asarray(errors)
    return np.log2(errors[:-1] / errors[1:])


@pytest.mark.parametrize("q", [0.3, 0.8])
def test_riemann_liouville_of_a_power_converges_at_first_order(q):
    # D^q t^p = Gamma(p+1)/Gamma(p+1-q) t^(p-q)  (Podlubny eq. 2.117)
    p = 2.0
    errors = []
    for h in STEPS:
        t = np.arange(int(round(1 / h)) + 1) * h
        d = riemann_liouville(t**p, h, q)
        errors.append(abs(float(d[-1]) - gamma(p + 1) / gamma(p + 1 - q)))
    np.testing.assert_allclose(observed_orders(errors), 1.0, atol=0.08)
    assert errors[-1] < 0.02


@pytest.mark.parametrize("q", [0.5, 0.8])
def test_caputo_of_exp_converges_at_first_order(q):
    # Caputo D^q e^t = t^(1-q) E_{1,2-q}(t) = sum_k t^(k+1-q) / Gamma(k+2-q)
    exact = sum(1.0 / gamma(k + 2 - q) for k in range(40))  # at t = 1
    errors = []
    for h in STEPS:
        t = np.arange(int(round(1 / h)) + 1) * h
        errors.append(abs(float(caputo(np.exp(t), h, q)[-1]) - exact))
    np.testing.assert_allclose(observed_orders(errors), 1.0, atol=0.08)
    # Caputo of a constant is 0; Riemann-Liouville of it is not.
    ones = np.ones(65)
    np.testing.assert_allclose(caputo(ones, 1 / 64, q), 0.0, atol=1e-15)
    assert float(riemann_liouville(ones, 1 / 64, q)[-1]) > 0.1


def mittag_leffler(alpha, z, terms=80):
    return sum(z**k / gamma(alpha * k + 1) for k in range(terms))


@pytest.mark.parametrize("q", [0.6, 0.9])
def test_mittag_leffler_relaxation_through_the_running_memory(q):
    """Caputo D^q y = -y, y(0) = 1 has y = E_q(-t^q). Solved by the implicit GL scheme on
    the ring-buffer memory (the controllers' operator): first-order convergence."""
    errors = []
    for h in STEPS:
        n = int(round(1 / h))

        @jax.jit
        def solve(q):
            def step(carry, _):
                mem, y = carry
                # h^-q [ (y_k - 1) + sum_{j>=1} w_j (y_{k-j} - 1) ] = -y_k; the history part
                # is the memory's sum with a zero pushed in the newest slot.
                history = memory_derivative(memory_push(mem, 0.0), h, q) * h**q
                y = (h**-q * (1.0 - history)) / (h**-q + 1.0)
                return (memory_push(mem, y - 1.0), y), None

            (_, y), _ = jax.lax.scan(step, (memory_init(n + 1, 0.0), 1.0), None, length=n)
            return y

        y = float(solve(q))
        errors.append(abs(y - mittag_leffler(q, -1.0)))
    np.testing.assert_allclose(observed_orders(errors), 1.0, atol=0.1)


def test_running_memory_equals_the_batch_sum_and_truncates():
    rng = np.random.default_rng(0)
    f = rng.normal(size=(50, 3))
    h, q = 0.1, 0.7
    full = riemann_liouville(f, h, q)
    for capacity, exact_until in ((50, 50), (20, 20)):
        mem = memory_init(capacity, f[0])
        got = [memory_derivative(mem, h, q)]
        for k in range(1, 50):
            mem = memory_push(mem, f[k])
            got.append(memory_derivative(mem, h, q))
        got = np.asarray(got)
        np.testing.assert_allclose(got[:exact_until], full[:exact_until], rtol=1e-12, atol=1e-12)
        w = np.asarray(grunwald_letnikov_weights(q, capacity))
        short = [
            h**-q * sum(w[j] * f[k - j] for j in range(min(k + 1, capacity))) for k in range(50)
        ]
        np.testing.assert_allclose(got, short, rtol=1e-12, atol=1e-12)


def test_short_memory_bias_matches_the_stated_bound():
    # D^q of a constant 1 with L samples at t = k h: the dropped terms sum to
    # ((L h)^-q - t^-q) / Gamma(1 - q) (partial GL sums ~ n^-q / Gamma(1 - q)), below the
    # bound (L h)^-q / Gamma(1 - q) stated in the module.
    h, q, length = 0.01, 0.8, 1000
    mem = memory_init(length, 1.0)
    mem = jax.lax.fori_loop(0, 3 * length, lambda i, m: memory_push(m, 1.0), mem)
    truncated = float(memory_derivative(mem, h, q))
    full = float(riemann_liouville(np.ones(3 * length + 1), h, q)[-1])
    t = 3 * length * h
    predicted = ((length * h) ** -q - t**-q) / gamma(1 - q)
    np.testing.assert_allclose(truncated - full, predicted, rtol=0.01)
    assert truncated - full < (length * h) ** -q / gamma(1 - q)


def test_gradient_in_the_order_matches_finite_differences():
    t = np.arange(101) * 0.01
    f = np.sin(3 * t)

    @jax.jit
    def value(q):
        return caputo(f, 0.01, q)[-1]

    g = jax.jit(jax.grad(value))(0.7)
    fd = (value(0.7 + 1e-6) - value(0.7 - 1e-6)) / 2e-6
    assert np.isfinite(g)
    np.testing.assert_allclose(g, fd, rtol=1e-6)
    assert jnp.isfinite(jax.grad(lambda q: grunwald_letnikov_weights(q, 10).sum())(0.5))
