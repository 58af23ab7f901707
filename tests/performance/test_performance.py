"""Prescribed-performance envelopes against closed forms and numerical integration of their
defining ODEs; the guarded error transformation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from jaxatt.performance import (
    CothPerformance,
    ExponentialPerformance,
    FiniteTimePerformance,
    envelope_margin,
    transform_error,
)


RHO0 = jnp.array([40.0, 1.5, 1.0, 0.05])
RHO_INF = jnp.array([0.008, 0.003, 0.008, 0.007])
ALPHA = jnp.array([0.8, 0.7, 0.7, 0.5])
ENVELOPES = {
    "exponential": ExponentialPerformance(RHO0, 0.01, 0.01),
    "coth": CothPerformance(0.02, jnp.array([0.3, 0.5, 0.7, 0.9]), 0.01),
    "finite_time": FiniteTimePerformance(RHO0, RHO_INF, 300.0, ALPHA),
}


@pytest.mark.parametrize("name", sorted(ENVELOPES))
def test_derivative_is_the_time_derivative_of_the_value(name):
    envelope = ENVELOPES[name]
    for t in (0.0, 17.3, 150.0, 299.0, 450.0):
        np.testing.assert_allclose(
            envelope.derivative(t), jax.jacfwd(envelope.value)(t), rtol=1e-12, atol=1e-15
        )
    np.testing.assert_allclose(envelope.value(0.0), envelope.initial, rtol=1e-14)


@pytest.mark.parametrize("t", [4e4, np.inf])
@pytest.mark.parametrize("name", sorted(ENVELOPES))
def test_gradients_are_finite_long_after_the_transient(name, t):
    # coth: l1 t + l2 = 800 at t = 4e4 s, where sinh overflows; its derivative's gradients in
    # t, l1 and l2 were NaN there (0 inf) although the envelope is flat at rho_inf. The
    # exponential's gradient in its rate was -t e^{-rate t} = -inf * 0 = NaN at t = inf.
    def total(envelope, t):
        return jnp.sum(envelope.value(t) + envelope.derivative(t))

    envelope = ENVELOPES[name]
    d_envelope, d_t = jax.jit(jax.grad(total, argnums=(0, 1)))(envelope, t)
    assert np.isfinite(d_t) and all(np.all(np.isfinite(g)) for g in jax.tree.leaves(d_envelope))
    np.testing.assert_allclose(envelope.value(t), envelope.final, rtol=1e-12)


def test_finite_time_envelope_reaches_rho_inf_exactly_at_T():
    envelope = ENVELOPES["finite_time"]
    np.testing.assert_array_equal(envelope.value(300.0), RHO_INF)  # to rounding: exactly
    np.testing.assert_array_equal(envelope.value(1000.0), RHO_INF)
    assert np.all(np.asarray(envelope.value(299.9)) > np.asarray(RHO_INF))
    # C^1 at T: the derivative tends to 0 from the left, and is 0 after.
    np.testing.assert_allclose(envelope.derivative(300.0 - 1e-9), 0.0, atol=1e-9)
    np.testing.assert_array_equal(envelope.derivative(300.0 + 1e-9), 0.0)


def test_finite_time_closed_form_solves_eq_36():
    # rho' = -q0 (rho - rho_inf)^alpha, integrated numerically from rho0 up to 0.999 T.
    envelope = ENVELOPES["finite_time"]
    q0 = np.asarray(envelope.gain)
    a, rho_inf = np.asarray(ALPHA), np.asarray(RHO_INF)

    def ode(t, rho):
        return -q0 * np.maximum(rho - rho_inf, 0.0) ** a

    t_end = 0.999 * 300.0
    sol = solve_ivp(ode, (0, t_end), np.asarray(RHO0), rtol=1e-12, atol=1e-14, dense_output=True)
    for t in (50.0, 150.0, 250.0, t_end):
        np.testing.assert_allclose(envelope.value(t), sol.sol(t), rtol=1e-8, atol=1e-12)


def test_finite_time_gains_match_spec_and_the_swapped_reading():
    # SPEC 003.4: q_i = (rho0 - rho_inf)^(1 - alpha) / ((1 - alpha) T), T = 300 s, printed
    # alpha; the closed form in float64 NumPy from the constants (rtol 1e-12: a few roundings).
    r0, ri, a = (np.asarray(v, dtype=np.float64) for v in (RHO0, RHO_INF, ALPHA))
    exact = (r0 - ri) ** (1 - a) / ((1 - a) * 300.0)
    np.testing.assert_allclose(ENVELOPES["finite_time"].gain, exact, rtol=1e-12)
    # SPEC's printed values (5 significant digits): q2..q4 are the closed form rounded; q1 =
    # 0.034855 is an arithmetic slip, 1.7 units of its last digit from 0.0348533.
    printed = np.array([0.034855, 0.012541, 0.011084, 0.0013824])
    units = np.abs(exact - printed) / 10.0 ** (np.floor(np.log10(printed)) - 4)
    assert np.all(units[1:] <= 0.5) and 1.5 < units[0] < 2.0, units
    # alpha3, alpha4 swapped gives exactly the printed q3 = 0.0066, q4 = 0.0043 (4 digits).
    swapped = FiniteTimePerformance(RHO0, RHO_INF, 300.0, jnp.array([0.8, 0.7, 0.5, 0.7]))
    np.testing.assert_allclose(swapped.gain[2:], [0.0066, 0.0043], atol=5e-5)


def test_finite_time_gradients_are_finite_after_T():
    def loss(params, t):
        horizon, exponent = params
        return jnp.sum(FiniteTimePerformance(RHO0, RHO_INF, horizon, exponent).value(t))

    for t in (100.0, 300.0, 400.0):
        grads = jax.grad(loss)((jnp.array(300.0), ALPHA), t)
        assert all(np.all(np.isfinite(g)) for g in grads)
    # after T the envelope is rho_inf whatever T and alpha: zero gradient, not NaN
    grads = jax.grad(loss)((jnp.array(300.0), ALPHA), 400.0)
    np.testing.assert_array_equal(grads[0], 0.0)


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: ExponentialPerformance(1.0, 2.0, 0.1), "must shrink"),
        (lambda: ExponentialPerformance(1.0, 1.0, 0.1), "must shrink"),
        (lambda: ExponentialPerformance(1.0, 0.1, -0.1), "`rate` must be positive"),
        (lambda: FiniteTimePerformance(1.0, 0.1, 0.0, 0.5), "`horizon` must be positive"),
        (lambda: FiniteTimePerformance(1.0, 0.1, -5.0, 0.5), "`horizon` must be positive"),
        (
            lambda: FiniteTimePerformance(1.0, 0.1, 300.0, 1.0),
            r"`exponent` must lie in \(0.0, 1.0\)",
        ),
        (
            lambda: FiniteTimePerformance(1.0, 0.1, 300.0, 0.0),
            r"`exponent` must lie in \(0.0, 1.0\)",
        ),
        (lambda: CothPerformance(0.1, -1.0, 0.01), "`l2` must be positive"),
    ],
)
def test_bad_envelopes_are_refused(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_transform_matches_autodiff_and_never_returns_nan():
    e, e_dot = jnp.array([0.3, -0.9, 0.0]), jnp.array([0.1, 0.2, -0.3])
    rho, rho_dot = jnp.array([1.0, 1.0, 0.5]), jnp.array([-0.1, -0.2, -0.05])
    out = transform_error(e, e_dot, rho, rho_dot)
    np.testing.assert_allclose(out.kappa, jnp.arctanh(e / rho), rtol=1e-14)
    np.testing.assert_allclose(out.beta, jnp.diag(jax.jacfwd(lambda e: jnp.arctanh(e / rho))(e)))
    # kappa_dot is the total derivative along e(t) = e + e_dot t, rho(t) = rho + rho_dot t
    along = jax.jacfwd(lambda t: jnp.arctanh((e + e_dot * t) / (rho + rho_dot * t)))(0.0)
    np.testing.assert_allclose(out.kappa_dot, along, rtol=1e-12)
    # outside the envelope: finite values, unclipped z, negative margin
    out = transform_error(jnp.array([1.2, -1.0]), jnp.zeros(2), jnp.ones(2), jnp.zeros(2))
    assert np.all(np.isfinite(out.kappa)) and np.all(np.isfinite(out.beta))
    np.testing.assert_allclose(out.z, [1.2, -1.0])
    assert np.all(np.asarray(envelope_margin(jnp.array([1.2, -1.0]), jnp.ones(2))) <= 0)


@pytest.mark.parametrize("rho", [0.0, -0.5, np.nan, np.inf])
def test_transform_refuses_an_envelope_that_is_not_positive(rho):
    """rho <= 0 has no transformed error; clipping z would hide it as a plausible kappa."""
    with pytest.raises(ValueError, match=r"transform_error: `rho` must be positive and finite"):
        transform_error(jnp.array([0.1, 0.2]), jnp.zeros(2), jnp.array([1.0, rho]), jnp.zeros(2))


def test_transform_under_jit_is_not_checked_on_the_host():
    """A traced rho is the closed loop's (checked where the envelope is built): no host check."""
    out = jax.jit(transform_error)(jnp.array([0.5]), jnp.zeros(1), jnp.array([1.0]), jnp.zeros(1))
    np.testing.assert_allclose(out.kappa, np.arctanh(0.5), rtol=1e-14)
