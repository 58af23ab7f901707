"""Chen et al. (2022) eqs. (26)-(29): with rho = eta = max(k3, k4) the two-phase power law
is pointwise at least as fast as the double-power law, hence reaches s = 0 no later."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.reaching import DoublePower, TwoPhasePower, odd_ratio


@eqx.filter_jit
def call(law, method, *args):
    return getattr(law, method)(*args)


# Dense in [-100, 100], both sides of |s| = 1, with +-1 and their neighbours exactly.
S_GRID = jnp.asarray(
    np.unique(
        np.concatenate(
            [
                np.linspace(-100, 100, 20001),
                np.geomspace(1e-8, 100, 2000),
                -np.geomspace(1e-8, 100, 2000),
                [-1 - 1e-12, -1, -1 + 1e-12, 1 - 1e-12, 1, 1 + 1e-12, 0],
            ]
        )
    )
)
S0_GRID = jnp.geomspace(1e-6, 1e6, 1201)

CASES = [
    (1.2, 0.8, odd_ratio(31, 11), odd_ratio(5, 9)),  # the paper's M3 gains
    (0.8, 1.2, odd_ratio(31, 11), odd_ratio(5, 9)),  # k4 > k3
    (1.0, 1.0, odd_ratio(3, 1), odd_ratio(1, 3)),
    (0.05, 3.0, 1.05, 0.95),  # exponents close to 1
    (5.0, 0.2, 7.0, 0.1),
]


def _pair(k3, k4, beta, alpha):
    gain = max(k3, k4)
    return (
        TwoPhasePower(rho=gain, eta=gain, beta=beta, alpha=alpha),
        DoublePower(k3=k3, k4=k4, beta=beta, alpha=alpha),
    )


@pytest.mark.parametrize("case", CASES)
def test_two_phase_rate_dominates_double_power(case):
    two_phase, double_power = _pair(*case)
    fast = np.asarray(call(two_phase, "rate", S_GRID))
    slow = np.asarray(call(double_power, "rate", S_GRID))
    s = np.asarray(S_GRID)
    # Both oppose s: (26)-(29) bracket each rate between 0 and the other.
    assert np.all(fast * s <= 0) and np.all(slow * s <= 0)
    # (Equality is attained only at s = 0, and at |s| = 1 when k3 = k4; allow round-off.)
    assert np.all(np.abs(fast) >= np.abs(slow) * (1 - 1e-14))


@pytest.mark.parametrize("case", CASES)
def test_two_phase_reaches_zero_no_later(case):
    two_phase, double_power = _pair(*case)
    t_fast = np.asarray(call(two_phase, "convergence_time", S0_GRID))
    t_slow = np.asarray(call(double_power, "convergence_time", S0_GRID))
    assert np.all(t_fast <= t_slow)
    # The fixed-time bounds are ordered the same way.
    assert call(two_phase, "convergence_time_bound") <= call(
        double_power, "convergence_time_supremum"
    )


def test_paper_numbers():
    """SPEC Seed 000: 1.334 / 1.438 / 1.550 / 1.582 s against 2.449 / 2.572 / 2.699 / 2.733 s."""
    two_phase, double_power = _pair(*CASES[0])
    s0 = jnp.array([1.0895, 1.5, 2.75, 4.0])
    ratio = call(two_phase, "convergence_time", s0) / call(double_power, "convergence_time", s0)
    spec = np.array([1.3340, 1.4381, 1.5497, 1.5819]) / np.array([2.449, 2.572, 2.699, 2.733])
    np.testing.assert_allclose(ratio, spec, rtol=5e-4)
    assert np.all(ratio < 0.58)


def test_premise_matters():
    """With rho = eta = min(k3, k4) the domination fails for large |s| (the test can fail)."""
    k3, k4, beta, alpha = CASES[0]
    two_phase = TwoPhasePower(rho=min(k3, k4), eta=min(k3, k4), beta=beta, alpha=alpha)
    double_power = DoublePower(k3=k3, k4=k4, beta=beta, alpha=alpha)
    fast = np.abs(np.asarray(call(two_phase, "rate", S_GRID)))
    slow = np.abs(np.asarray(call(double_power, "rate", S_GRID)))
    assert np.any(fast < slow)
