"""Generic tests run on every reaching law in `ALL_LAWS`, plus validation."""

import inspect

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
import pytest

import jaxatt.reaching as reaching
from jaxatt.reaching import (
    AbstractFiniteTimeReachingLaw,
    AbstractReachingLaw,
    ConstantRate,
    DoublePower,
    Exponential,
    FastPower,
    Power,
    Saturation,
    Sign,
    Tanh,
    TwoPhasePower,
    odd_ratio,
)


BETA, ALPHA = odd_ratio(31, 11), odd_ratio(5, 9)
PER_AXIS = jnp.array([0.5, 1.2, 2.0])

ALL_LAWS = {
    "ConstantRate": ConstantRate(1.3),
    "Exponential": Exponential(1.2, 0.5),
    "Exponential-tanh": Exponential(1.2, 0.5, Tanh(0.05)),
    "Power": Power(1.1, ALPHA),
    "FastPower": FastPower(1.2, 0.8, 0.6),
    "FastPower-sat": FastPower(1.2, 0.8, 0.6, Saturation(0.05)),
    "DoublePower": DoublePower(1.2, 0.8, BETA, ALPHA),
    "DoublePower-tanh": DoublePower(1.2, 0.8, BETA, ALPHA, Tanh(0.1)),
    "DoublePower-per-axis": DoublePower(
        PER_AXIS, 0.8, jnp.array([1.5, BETA, 3.0]), jnp.array([0.3, ALPHA, 0.9])
    ),
    "TwoPhasePower": TwoPhasePower(1.2, 1.2, BETA, ALPHA),
    "TwoPhasePower-sat": TwoPhasePower(1.2, 1.2, BETA, ALPHA, Saturation(0.1)),
    "TwoPhasePower-per-axis-tanh": TwoPhasePower(
        PER_AXIS, 1.2, 2.0, ALPHA, Tanh(jnp.array([0.1, 0.2, 0.05]))
    ),
}
SIGN_LAWS = {k: v for k, v in ALL_LAWS.items() if isinstance(v.switching, Sign)}
SMOOTH_LAWS = {k: v for k, v in ALL_LAWS.items() if not isinstance(v.switching, Sign)}

all_laws = pytest.mark.parametrize("law", list(ALL_LAWS.values()), ids=list(ALL_LAWS))
sign_laws = pytest.mark.parametrize("law", list(SIGN_LAWS.values()), ids=list(SIGN_LAWS))

# Rows of s (shape (3,) so that per-axis laws apply): generic points, 0, |s| = 1, the layers.
S_ROWS = jnp.array(
    [
        [0.4, -2.0, 1.7],
        [0.0, 0.0, 0.0],
        [1.0, -1.0, 1.0],
        [-0.03, 0.07, 12.0],
        [1 - 1e-9, -1 - 1e-9, 1e-7],
    ]
)


@eqx.filter_jit
def call(law, method, *args):
    """`law.method(*args)` under one JIT (eager dispatch compiles every primitive per shape)."""
    return getattr(law, method)(*args)


def _component(law, i):
    """The scalar law of axis i (per-axis parameters indexed, scalars kept)."""
    return jtu.tree_map(lambda x: x[i] if x.ndim == 1 else x, law)


def _leaves(law):
    return [x for x in jtu.tree_leaves(law) if eqx.is_inexact_array(x)]


def _like(leaf, values):
    """An array of `values` with the shape and weak type of `leaf` (laws built from Python
    floats hold weakly typed scalars; a strong one would be a new signature for the JIT)."""
    if leaf.weak_type:
        return jnp.asarray(float(np.reshape(values, ())))
    return jnp.asarray(np.reshape(values, leaf.shape), dtype=leaf.dtype)


def _replace_leaves(law, new_leaves):
    leaves, treedef = jtu.tree_flatten(law)
    new = iter(new_leaves)
    return jtu.tree_unflatten(
        treedef, [next(new) if eqx.is_inexact_array(x) else x for x in leaves]
    )


def test_registry_covers_every_public_law():
    public = {
        obj
        for obj in vars(reaching).values()
        if inspect.isclass(obj)
        and issubclass(obj, AbstractReachingLaw)
        and not inspect.isabstract(obj)
    }
    assert public == {type(law) for law in ALL_LAWS.values()}
    assert all(isinstance(law, AbstractFiniteTimeReachingLaw) for law in ALL_LAWS.values())


@all_laws
def test_rate_is_elementwise(law):
    for s in S_ROWS:
        vector = call(law, "rate", s)
        assert vector.shape == (3,)
        for i in range(3):
            scalar = call(_component(law, i), "rate", s[i])
            assert scalar.shape == ()
            np.testing.assert_allclose(vector[i], scalar, rtol=1e-15, atol=0)


@all_laws
def test_jit_matches_eager(law):
    s = S_ROWS[0]
    np.testing.assert_allclose(law.rate(s), call(law, "rate", s), rtol=1e-15)
    if isinstance(law.switching, Sign):
        np.testing.assert_allclose(
            law.convergence_time(s), call(law, "convergence_time", s), rtol=1e-14
        )


# A batch of shape (40, 3) shared by the batched tests (one compilation per law and method).
_MAGNITUDES = jnp.geomspace(1e-3, 20.0, 20)
BATCH = jnp.broadcast_to(jnp.concatenate([-_MAGNITUDES, _MAGNITUDES])[:, None], (40, 3))
BATCH = (BATCH * jnp.array([[1.0, -0.5, 2.0]])).at[:5].set(S_ROWS)  # with 0 and |s| = 1


_TRACES = []  # one entry per trace of `_vmapped` (for the no-retrace test)


@eqx.filter_jit
def _vmapped(law, method, batch):
    _TRACES.append((type(law).__name__, method))
    return jax.vmap(getattr(law, method))(batch)


def _methods(law):
    return ["rate"] + (["convergence_time"] if isinstance(law.switching, Sign) else [])


@all_laws
def test_vmap_matches_loop(law):
    for method in _methods(law):
        batched = _vmapped(law, method, BATCH)
        looped = jnp.stack([call(law, method, s) for s in BATCH[::4]])
        np.testing.assert_allclose(batched[::4], looped, rtol=1e-14, atol=1e-300)


@all_laws
def test_rate_opposes_s(law):
    rates = _vmapped(law, "rate", BATCH)
    assert bool(jnp.all(rates * BATCH <= 0))
    assert bool(jnp.all((rates == 0) == (BATCH == 0)))


# Rows where the laws are singular (0, |s| = 1) and one generic row (last), where they are
# smooth; `weights` selects rows, so one compilation serves both gradient tests.
GRAD_ROWS = jnp.array([[0.0, 0.0, 0.0], [1.0, -1.0, 1.0], [-1.0, 0.0, 1.0], [0.4, -2.0, 1.7]])
GENERIC_ROW = -1


@eqx.filter_jit
def _grads(law, rows, rate_weights, time_weights):
    """Gradients, in every parameter and in `rows`, of
    sum_i rate_weights_i sum(rate(rows_i)) [+ time_weights_i sum(convergence_time(rows_i))]."""

    def objective(law, rows):
        total = jnp.sum(rate_weights[:, None] * jax.vmap(law.rate)(rows))
        if isinstance(law.switching, Sign):
            total = total + jnp.sum(time_weights[:, None] * jax.vmap(law.convergence_time)(rows))
        return total

    return eqx.filter_grad(objective)(law, rows), jax.grad(objective, argnums=1)(law, rows)


def _all_finite(tree):
    return all(bool(jnp.all(jnp.isfinite(x))) for x in jtu.tree_leaves(tree))


@all_laws
def test_gradients_finite_at_singular_points(law):
    law_grad, rows_grad = _grads(law, GRAD_ROWS, jnp.ones(4), jnp.ones(4))
    assert _all_finite(law_grad) and _all_finite(rows_grad)
    assert len(_leaves(law_grad)) == len(_leaves(law))  # every parameter gets a gradient


def _check_against_central_differences(law, method, rtol):
    weights = jnp.zeros(4).at[GENERIC_ROW].set(1.0)
    zero = jnp.zeros(4)
    if method == "rate":
        law_grad, rows_grad = _grads(law, GRAD_ROWS, weights, zero)
    else:
        law_grad, rows_grad = _grads(law, GRAD_ROWS, zero, weights)
    s = GRAD_ROWS[GENERIC_ROW]

    def value(law, s):
        return float(jnp.sum(call(law, method, s)))

    # Central differences with h = 1e-6: truncation ~1e-12, round-off ~ eps |f| / h ~ 1e-10 |f|,
    # hence the absolute floor.
    floor = 1e-8 * max(1.0, abs(value(law, s)))
    leaves = _leaves(law)
    for index, (leaf, grad) in enumerate(zip(leaves, _leaves(law_grad))):
        flat = np.array(leaf, dtype=float).reshape(-1)
        for j in range(flat.size):
            h = 1e-6 * max(1.0, abs(flat[j]))
            bumped = []
            for sign in (1, -1):
                x = flat.copy()
                x[j] += sign * h
                new = list(leaves)
                new[index] = _like(leaf, x)
                bumped.append(value(_replace_leaves(law, new), s))
            fd = (bumped[0] - bumped[1]) / (2 * h)
            ad = float(np.reshape(grad, -1)[j])
            assert abs(ad - fd) <= rtol * abs(fd) + floor, (index, j, ad, fd)
    for j in range(s.shape[0]):
        h = 1e-6 * max(1.0, abs(float(s[j])))
        fd = (value(law, s.at[j].add(h)) - value(law, s.at[j].add(-h))) / (2 * h)
        ad = float(rows_grad[GENERIC_ROW, j])
        assert abs(ad - fd) <= rtol * abs(fd) + floor, (j, ad, fd)


@all_laws
def test_rate_gradient_matches_finite_differences(law):
    # At the generic row: away from 0, from |s| = 1 and from the layer edges.
    _check_against_central_differences(law, "rate", rtol=1e-6)


@sign_laws
def test_convergence_time_gradient_matches_finite_differences(law):
    _check_against_central_differences(law, "convergence_time", rtol=1e-6)


@sign_laws
@pytest.mark.parametrize("switching_type", [Saturation, Tanh])
def test_smooth_switching_converges_to_sign(law, switching_type):
    exact = _vmapped(law, "rate", BATCH)
    outside = jnp.abs(BATCH) >= 1e-3  # compare where every layer below is thin
    errors = []
    for width in (1e-1, 1e-2, 1e-4, 1e-8):
        smooth = eqx.tree_at(lambda m: m.switching, law, switching_type(width))
        difference = jnp.where(outside, _vmapped(smooth, "rate", BATCH) - exact, 0)
        errors.append(float(jnp.max(jnp.abs(difference))))
    assert errors[0] > 0
    # The error shrinks with the width until it is round-off (under XLA's default settings
    # the exponential law's is 2.2e-16 at both 1e-4 and 1e-8: equal, not smaller).
    roundoff = 1e-14 * float(jnp.max(jnp.abs(exact)))
    assert all(b < a for a, b in zip(errors, errors[1:]) if a > roundoff)
    # |s| >= 1e-3 is outside a layer of width 1e-8: equal up to round-off (sig_pow vs
    # abs_pow * switching, fused differently).
    assert errors[-1] <= roundoff


@pytest.mark.parametrize("law", list(ALL_LAWS.values()), ids=list(ALL_LAWS))
def test_smooth_switching_is_lipschitz_at_zero(law):
    """Difference quotients of the rate across s = 0 stay bounded for the smooth variants and
    blow up for the discontinuous / non-Lipschitz Sign laws."""
    h = jnp.broadcast_to(jnp.geomspace(1e-12, 1e-3, 40)[:, None], (40, 3))
    quotient = (_vmapped(law, "rate", h) - _vmapped(law, "rate", -h)) / (2 * h)
    gains = sum(float(jnp.max(x)) for x in _leaves(law))
    if isinstance(law.switching, Sign):
        assert float(jnp.max(jnp.abs(quotient))) > 1e4
    else:
        width = float(jnp.min(law.switching.width))
        assert float(jnp.max(jnp.abs(quotient))) <= gains * (1 + 1 / width)


@all_laws
def test_float32_in_float32_out(law):
    s64 = S_ROWS[0]
    s32 = s64.astype(jnp.float32)
    methods = ["rate"] + (["convergence_time"] if isinstance(law.switching, Sign) else [])
    for method in methods:
        out32 = call(law, method, s32)
        assert out32.dtype == jnp.float32
        np.testing.assert_allclose(out32, call(law, method, s64), rtol=1e-5)


@all_laws
def test_no_retrace_when_gains_change(law):
    # Scale every parameter by 1.01 (exponents stay in range for this registry).
    other = _replace_leaves(law, [x * 1.01 for x in _leaves(law)])
    for method in _methods(law):
        first = _vmapped(law, method, BATCH)  # traced here or by an earlier test
        traces = len(_TRACES)
        second = _vmapped(other, method, BATCH)
        assert len(_TRACES) == traces, "changing only gain values re-traced"
        assert not np.allclose(first, second)


# --- validation ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "build, name, rule",
    [
        (lambda: ConstantRate(0.0), "k", "positive"),
        (lambda: ConstantRate(-1.0), "k", "positive"),
        (lambda: Exponential(1.0, -0.1), "k2", "positive"),
        (lambda: Exponential(float("nan"), 1.0), "k1", "positive"),
        (lambda: Power(1.0, 1.0), "alpha", "(0.0, 1.0)"),
        (lambda: Power(1.0, 0.0), "alpha", "(0.0, 1.0)"),
        (lambda: FastPower(1.0, 1.0, 1.5), "alpha", "(0.0, 1.0)"),
        (lambda: FastPower(1.0, 0.0, 0.5), "k2", "positive"),
        (lambda: DoublePower(1.0, 1.0, 1.0, 0.5), "beta", "greater than 1"),
        (lambda: DoublePower(1.0, jnp.array([1.0, -1.0]), 2.0, 0.5), "k4", "positive"),
        (lambda: TwoPhasePower(1.2, 1.2, 0.5, ALPHA), "beta", "greater than 1"),
        (lambda: TwoPhasePower(1.2, 1.2, BETA, 1.2), "alpha", "(0.0, 1.0)"),
        (lambda: TwoPhasePower(0.0, 1.2, BETA, ALPHA), "rho", "positive"),
        (lambda: Saturation(0.0), "width", "positive"),
        (lambda: Tanh(-1.0), "width", "positive"),
    ],
)
def test_invalid_parameters_raise(build, name, rule):
    with pytest.raises(ValueError, match=rf"`{name}`.*{__import__('re').escape(rule)}"):
        build()


def test_two_phase_beta_message():
    with pytest.raises(ValueError) as info:
        TwoPhasePower(rho=1.2, eta=1.2, beta=0.5, alpha=5 / 9)
    message = str(info.value)
    assert "TwoPhasePower" in message and "`beta`" in message
    assert "greater than 1" in message and "0.5" in message


def test_traced_invalid_gain_fails_at_run_time():
    build = eqx.filter_jit(lambda k: Power(k, 0.5).rate(jnp.asarray(1.0)))
    assert float(build(jnp.asarray(2.0))) == -2.0
    with pytest.raises(Exception, match="must be positive"):
        build(jnp.asarray(-2.0))


def test_convergence_time_gradient_at_zero_is_zero():
    # T(s0) grows like |s0|^(1-alpha): both one-sided slopes at 0 are infinite, and the
    # docstrings choose 0 (T is even; DoublePower's already gave 0). Power, FastPower and
    # TwoPhasePower gave the right-sided capped slope (2.0e4, 6.2e4, 1.9e4) through abs_pow's
    # derivative at 0. One compilation for the three laws.
    laws = tuple(ALL_LAWS[k] for k in ("Power", "FastPower", "TwoPhasePower"))
    slopes = eqx.filter_jit(lambda laws, s0: [jax.grad(law.convergence_time)(s0) for law in laws])(
        laws, jnp.asarray(0.0)
    )
    np.testing.assert_array_equal(slopes, 0.0)


@pytest.mark.parametrize("law", list(SMOOTH_LAWS.values()), ids=list(SMOOTH_LAWS))
def test_convergence_time_requires_sign(law):
    with pytest.raises(ValueError, match=rf"{type(law).__name__}\.convergence_time.*Sign\(\)"):
        law.convergence_time(jnp.asarray(1.0))
    for method in ("convergence_time_bound", "convergence_time_supremum"):
        if hasattr(law, method):
            with pytest.raises(ValueError, match=method):
                getattr(law, method)()


def test_per_axis_shape_mismatch_raises():
    law = DoublePower(PER_AXIS, 0.8, BETA, ALPHA)
    with pytest.raises(ValueError, match="`k3` of shape \\(3,\\)"):
        law.rate(jnp.asarray(1.0))
    with pytest.raises(ValueError, match="`k3`"):
        law.rate(jnp.ones(2))


def test_odd_ratio():
    assert odd_ratio(31, 11) == 31 / 11
    assert odd_ratio(np.int64(5), 9) == 5 / 9
    for p, q, name in [(2, 3, "p"), (3, 0, "q"), (-3, 1, "p"), (True, 1, "p")]:
        with pytest.raises(ValueError, match=f"`{name}` must be a positive odd integer"):
            odd_ratio(p, q)
    # A float is rejected too: by the annotation's checker under pytest ...
    with pytest.raises(TypeError, match="typechecking parameter 'p'"):
        odd_ratio(3.0, 1)


def test_odd_ratio_refuses_a_float_without_the_type_checker(no_jaxtyping):
    # ... and by odd_ratio itself, which is what users meet (3.0 == 3 is odd, so only the
    # integer-type test refuses it).
    for p, q, name in [(3.0, 1, "p"), (3, 1.0, "q")]:
        with pytest.raises(ValueError, match=f"`{name}` must be a positive odd integer"):
            odd_ratio(p, q)
