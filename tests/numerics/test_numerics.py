"""Safe primitives: values, derivatives at singular points, batching, dtypes."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.numerics import (
    abs_pow,
    det3,
    inv3,
    rational_sign,
    safe_arccos,
    safe_norm,
    safe_normalize,
    sat,
    sig_pow,
    sign,
    smooth_sign,
    solve3,
)


def central_difference(f, x, h=1e-6):
    return (f(x + h) - f(x - h)) / (2 * h)


@pytest.mark.parametrize("x", [-2.3, -0.3, 0.3, 0.9, 1.0, 4.0])
@pytest.mark.parametrize("a", [5 / 9, 0.7, 1.0, 31 / 11])
def test_sig_pow_value_and_gradients_match_closed_form_and_fd(x, a):
    assert np.isclose(sig_pow(x, a), np.sign(x) * abs(x) ** a, rtol=1e-14)
    dx, da = jax.grad(sig_pow, argnums=(0, 1))(x, a)
    assert np.isclose(dx, a * abs(x) ** (a - 1), rtol=1e-12)
    assert np.isclose(da, np.sign(x) * abs(x) ** a * np.log(abs(x)), rtol=1e-12, atol=1e-15)
    assert np.isclose(dx, central_difference(lambda v: sig_pow(v, a), x), rtol=1e-7)
    assert np.isclose(da, central_difference(lambda b: sig_pow(x, b), a), rtol=1e-7, atol=1e-9)


def test_sig_pow_grad_at_zero_is_finite():
    eps = jnp.finfo(jnp.float64).eps
    for a in (0.3, 5 / 9, 0.99):
        dx, da = jax.grad(sig_pow, argnums=(0, 1))(0.0, a)
        assert np.isfinite(dx) and np.isfinite(da)
        # The documented slope cap: a * sqrt(eps)^(a - 1).
        assert np.isclose(dx, a * np.sqrt(eps) ** (a - 1), rtol=1e-12)
        assert da == 0.0
    assert jax.grad(sig_pow)(0.0, 2.0) == 0.0  # exact for a >= 1
    assert jax.grad(sig_pow)(0.0, 1.0) == 1.0
    assert sig_pow(0.0, 0.5) == 0.0  # sign(0) = 0


def test_sig_pow_is_exp_log_and_matches_jnp_power_to_a_few_ulps():
    # exp(a log|x|) (1.6x cheaper than pow on XLA:CPU) has a relative error of about
    # (1 + |a ln|x||) eps; checked against jnp.power over 12 decades and both phases' exponents.
    x = np.geomspace(1e-8, 1e4, 20001)
    x = np.concatenate([-x, x])
    eps = np.finfo(np.float64).eps
    for a in (5 / 9, 31 / 11, 0.3, 1.0, 2.0):
        value = np.asarray(jax.jit(sig_pow)(x, a))
        expected = np.sign(x) * np.asarray(jnp.power(jnp.abs(x), a))
        relative = np.abs(value - expected) / np.abs(expected)
        assert np.all(relative <= 2 * (1 + np.abs(a * np.log(np.abs(x)))) * eps), a
        assert np.max(relative[(np.abs(x) >= 0.1) & (np.abs(x) <= 3)]) < 1.5e-15, a
    # Exactly 0 at 0, both signed and absolute.
    assert jax.jit(sig_pow)(0.0, 5 / 9) == 0.0 and jax.jit(abs_pow)(0.0, 31 / 11) == 0.0
    # Batched gradients at 0 stay finite (the double where keeps log 0 out of the graph).
    grads = jax.vmap(jax.grad(sig_pow, argnums=(0, 1)))(jnp.zeros(3), jnp.array([0.3, 1.0, 2.0]))
    assert all(np.all(np.isfinite(g)) for g in grads)


def test_sig_pow_second_derivative_finite_at_zero():
    d2 = jax.grad(jax.grad(sig_pow))(0.0, 0.6)
    assert np.isfinite(d2)


def test_sig_pow_elementwise_broadcast_vmap_and_dtype():
    x = jnp.array([-1.5, 0.0, 0.2])
    a = jnp.array([0.5, 0.5, 2.0])
    np.testing.assert_allclose(sig_pow(x, a), [-(1.5**0.5), 0.0, 0.04], rtol=1e-14)
    np.testing.assert_allclose(jax.vmap(sig_pow)(x, a), sig_pow(x, a))
    np.testing.assert_allclose(jax.jit(sig_pow)(x, a), sig_pow(x, a))
    x32 = x.astype(jnp.float32)
    assert sig_pow(x32, jnp.float32(0.5)).dtype == jnp.float32
    assert jax.grad(lambda v: jnp.sum(sig_pow(v, jnp.float32(0.5))))(x32).dtype == jnp.float32


def test_abs_pow_matches_and_has_odd_derivative():
    for x in (-0.7, 0.4):
        assert np.isclose(abs_pow(x, 1.5), abs(x) ** 1.5)
        assert np.isclose(jax.grad(abs_pow)(x, 1.5), 1.5 * abs(x) ** 0.5 * np.sign(x))
    assert np.isfinite(jax.grad(abs_pow)(0.0, 0.5))


@pytest.mark.parametrize("a", [0.5, 1.0, 1.5])
def test_abs_pow_derivative_at_zero_is_zero(a):
    # |x|^a is even: its documented derivative a|x|^(a-1) sign(x) is 0 at x = 0. jnp.abs's
    # derivative (1 at 0) used to give the one-sided slope there (4096 for a = 1/2).
    value, (dx, da) = jax.jit(jax.value_and_grad(abs_pow, argnums=(0, 1)))(0.0, a)
    assert value == 0.0 and dx == 0.0 and da == 0.0


def test_safe_norm_zero_rows_have_zero_gradient_and_others_exact():
    x = jnp.array([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0]])
    np.testing.assert_allclose(safe_norm(x), [0.0, 5.0])
    g = jax.grad(lambda v: jnp.sum(safe_norm(v)))(x)
    np.testing.assert_allclose(g, [[0, 0, 0], [0.6, 0.8, 0]])
    np.testing.assert_allclose(safe_normalize(x), [[0, 0, 0], [0.6, 0.8, 0]])
    assert np.all(np.isfinite(jax.jacobian(safe_normalize)(jnp.zeros(3))))
    assert safe_norm(x, keepdims=True).shape == (2, 1)


def test_switching_functions():
    x = jnp.array([-2.0, -0.05, 0.0, 0.05, 2.0])
    np.testing.assert_array_equal(sign(x), [-1, -1, 0, 1, 1])
    np.testing.assert_allclose(sat(x, 0.1), [-1, -0.5, 0, 0.5, 1])
    np.testing.assert_allclose(smooth_sign(x, 0.1), np.tanh(np.asarray(x) / 0.1))
    np.testing.assert_allclose(rational_sign(x, 0.1), np.asarray(x) / (np.abs(x) + 0.1))
    assert jax.grad(sign)(0.3) == 0.0  # documented: no gradient through sign
    assert np.isclose(jax.grad(smooth_sign)(0.0, 0.1), 10.0)
    assert np.isclose(jax.grad(sat)(0.0, 0.1), 10.0)


def test_safe_arccos_gradient_finite_at_ends():
    for x in (-1.0, 1.0):
        assert np.isfinite(jax.grad(safe_arccos)(x))
    assert np.isclose(jax.grad(safe_arccos)(0.3), -1 / np.sqrt(1 - 0.09))
    assert np.isclose(safe_arccos(1.0 + 1e-12), 0.0)


def test_closed_form_3x3_linear_algebra_matches_numpy():
    rng = np.random.default_rng(1)
    for _ in range(5):
        m = rng.normal(size=(3, 3))
        a = m @ m.T + 3 * np.eye(3)
        b = rng.normal(size=3)
        np.testing.assert_allclose(solve3(a, b), np.linalg.solve(a, b), rtol=1e-12)
        np.testing.assert_allclose(inv3(a), np.linalg.inv(a), rtol=1e-12, atol=1e-15)
        assert np.isclose(det3(a), np.linalg.det(a), rtol=1e-12)
    g = jax.grad(lambda a: jnp.sum(solve3(a, jnp.ones(3))))(jnp.asarray(a))
    g_ref = -np.outer(np.linalg.solve(a.T, np.ones(3)), np.linalg.solve(a, np.ones(3)))
    np.testing.assert_allclose(g, g_ref, rtol=1e-10)


def test_nonfinite_input_is_never_hidden_as_zero():
    # Regression: safe_norm returned 0 for a vector holding a NaN (its mask `squared > 0` is
    # False for NaN), so a diverged state looked settled; the same pattern hid NaN in the
    # quaternion angle and inverse, the MRP shadow, the overshoot and the soft settling time.
    from jaxatt.metrics import overshoot, soft_settling_time
    from jaxatt.rotations import mrp_shadow, quat_angle, quat_inverse

    nan3 = jnp.array([jnp.nan, 1.0, 2.0])
    assert np.isnan(safe_norm(nan3))
    assert np.isinf(safe_norm(jnp.array([jnp.inf, 1.0, 0.0])))
    assert float(safe_norm(jnp.zeros(3))) == 0.0
    np.testing.assert_array_equal(jax.grad(safe_norm)(jnp.zeros(3)), [0.0, 0.0, 0.0])
    assert np.all(np.isnan(safe_normalize(nan3))[:1])
    assert np.isnan(quat_angle(jnp.array([jnp.nan, 0.0, 0.0, 0.0])))
    assert np.all(np.isnan(quat_inverse(jnp.array([jnp.nan, 0.1, 0.0, 0.0]))))
    assert np.all(np.isnan(mrp_shadow(nan3)))
    assert np.isnan(overshoot(jnp.array([[jnp.nan], [0.5]]))[0])
    ts = jnp.linspace(0.0, 1.0, 11)
    assert np.isnan(soft_settling_time(ts, jnp.full(11, jnp.nan), 1e-2))


def test_spectral_norm_matches_the_svd_and_has_finite_gradients():
    import jax

    from jaxatt.numerics import spectral_norm

    rng = np.random.default_rng(3)
    for shape in ((6, 6), (3, 5), (5, 3)):
        a = jnp.asarray(rng.normal(size=shape))
        np.testing.assert_allclose(spectral_norm(a), np.linalg.norm(np.asarray(a), 2), rtol=1e-13)
        u, s, vh = np.linalg.svd(np.asarray(a))
        np.testing.assert_allclose(jax.grad(spectral_norm)(a), np.outer(u[:, 0], vh[0]), atol=1e-12)
    # blkdiag(I/m, J^-1) has a repeated singular value (1/m, three times): finite gradient
    c_inv = jnp.diag(jnp.array([0.01, 0.01, 0.01, 1 / 14, 1 / 15, 1 / 17]))
    grad = jax.grad(spectral_norm)(c_inv)
    assert np.all(np.isfinite(grad)) and grad[3, 3] == pytest.approx(1.0)
    assert float(spectral_norm(jnp.zeros((3, 3)))) == 0.0
    assert np.all(jax.grad(spectral_norm)(jnp.zeros((3, 3))) == 0.0)


def _spectra_cases():
    """Symmetric 3x3 matrices Q diag(spectrum) Q^T with random rotations Q: generic, exactly
    and nearly repeated eigenvalues (top pair, bottom pair, all three), a large offset against a
    small spread, extreme scales, and mixed signs."""
    rng = np.random.default_rng(11)
    spectra = {
        "random": None,
        "top pair": [1.0, 2.0, 2.0],
        "bottom pair": [1.0, 1.0, 2.0],
        "all three": [3.0, 3.0, 3.0],
        "nearly top pair": [1.0, 2.0, 2.0 + 1e-9],
        "nearly bottom pair": [1.0, 1.0 + 1e-9, 2.0],
        "offset": [1e6, 1e6 + 1, 1e6 + 2],
        "tiny": [1e-200, 2e-200, 3e-200],
        "huge": [1e150, 2e150, 2e150],
        "mixed signs": [-3.0, 0.0, 5.0],
    }
    cases = {}
    for name, spectrum in spectra.items():
        if spectrum is None:
            a = rng.normal(size=(200, 3, 3))
            cases[name] = a + a.transpose(0, 2, 1)
        else:
            q, _ = np.linalg.qr(rng.normal(size=(200, 3, 3)))
            cases[name] = np.einsum("nij,j,nkj->nik", q, np.asarray(spectrum), q)
    return cases


@pytest.fixture(scope="module")
def spectra_cases():
    return _spectra_cases()


def test_eigvalsh3_equals_lapack_to_a_few_ulps_of_the_norm_repeated_eigenvalues_included(
    spectra_cases,
):
    from jaxatt.numerics import eigvalsh3

    closed_form = jax.jit(jax.vmap(eigvalsh3))
    for name, matrices in spectra_cases.items():
        got = np.asarray(closed_form(jnp.asarray(matrices)))
        expected = np.linalg.eigvalsh(matrices)
        size = np.max(np.abs(expected), axis=1, keepdims=True)
        # measured: at most 9.3 eps ||M|| over these cases; Smith's formula alone reaches
        # 2e7 eps next to a repeated largest eigenvalue
        assert np.all(np.abs(got - expected) <= 32 * np.finfo(float).eps * size), name


def test_largest_eigenvalue3_is_exact_except_next_to_a_repeated_largest(spectra_cases):
    from jaxatt.numerics import largest_eigenvalue3

    closed_form = jax.jit(jax.vmap(largest_eigenvalue3))
    for name, matrices in spectra_cases.items():
        error = np.abs(
            np.asarray(closed_form(jnp.asarray(matrices))) - np.linalg.eigvalsh(matrices)[:, -1]
        )
        size = np.max(np.abs(np.linalg.eigvalsh(matrices)), axis=1)
        # its docstring's bounds: 5e-9 ||M|| (measured 5.0e-9) next to a repeated largest
        # eigenvalue, a few eps ||M|| elsewhere
        bound = (
            1e-8 if name in ("top pair", "nearly top pair", "huge") else 32 * np.finfo(float).eps
        )
        assert np.all(error <= bound * size), name


def test_eigvalsh3_gradients_are_the_eigenvector_projections_and_finite_where_repeated(
    spectra_cases,
):
    from jaxatt.numerics import eigvalsh3, largest_eigenvalue3

    generic = jnp.asarray(spectra_cases["random"][:50])
    jacobians = np.asarray(jax.jit(jax.vmap(jax.jacfwd(eigvalsh3)))(generic))
    _, vectors = np.linalg.eigh(np.asarray(generic))
    np.testing.assert_allclose(jacobians, np.einsum("nik,njk->nkij", vectors, vectors), atol=1e-12)
    largest_grad = np.asarray(jax.jit(jax.vmap(jax.grad(largest_eigenvalue3)))(generic))
    np.testing.assert_allclose(largest_grad, jacobians[:, -1], atol=1e-12)
    for name in ("top pair", "bottom pair", "all three"):
        for f in (lambda m: eigvalsh3(m)[-1], lambda m: eigvalsh3(m)[0], largest_eigenvalue3):
            grads = jax.jit(jax.vmap(jax.grad(f)))(jnp.asarray(spectra_cases[name][:20]))
            assert np.all(np.isfinite(np.asarray(grads))), name
    # at M = qI every eigenvalue moves with the trace: the mean of the three, I/3 (the two
    # below the largest used to move with diag(0, 1/2, 1/2), their sum's with diag(1, 4, 4)/3)
    at_multiples = jax.jit(jax.vmap(jax.jacfwd(eigvalsh3)))(jnp.stack([0 * jnp.eye(3), jnp.eye(3)]))
    np.testing.assert_allclose(at_multiples, np.broadcast_to(np.eye(3) / 3, (2, 3, 3, 3)))


def test_eigvalsh3_never_hides_nan():
    from jaxatt.numerics import eigvalsh3, largest_eigenvalue3, spectral_norm

    m = jnp.diag(jnp.array([jnp.nan, 1.0, 2.0]))
    assert np.all(np.isnan(eigvalsh3(m)))
    assert np.isnan(largest_eigenvalue3(m))
    # nor does the spectral norm built on them (Yue 2018's law (22) reads it; its former
    # jnp.linalg.norm(M, 2) gave NaN too), in closed form and through LAPACK
    assert np.isnan(spectral_norm(m))
    assert np.isnan(spectral_norm(jnp.eye(6).at[0, 0].set(jnp.nan)))
