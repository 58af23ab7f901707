"""The scalarizer evaluates programs entry by entry with unchanged values and derivatives."""

import re

import diffrax as dfx
import equinox as eqx
import jax
import jax.lax as lax
import jax.numpy as jnp
import jax.random as jr
import jax.tree_util as jtu
import numpy as np
import pytest

from jaxatt.numerics import sig_pow, solve3, vectorized_log
from jaxatt.plants import MRPState
from jaxatt.rotations import mrp_kinematics, mrp_to_dcm, quat_from_axis_angle, quat_multiply
from jaxatt.scenarios import chen2022_two_phase_power as chen
from jaxatt.simulation import Euler, Performance, ZeroOrderHold, simulate
from jaxatt.simulation._scalarize import DEFAULT_LIMITS, Limits, pack, scalarize, split, split_tree


FAST = Performance(scalarize=True)


def _is_object_array(x):
    return isinstance(x, np.ndarray) and x.dtype == object


def run_scalarized(f, *args):
    out = scalarize(f)(*split_tree(args))
    return jtu.tree_map(lambda o, r: pack(o, r.dtype), out, f(*args), is_leaf=_is_object_array)


def assert_trees_close(a, b, rtol=1e-14, atol=1e-15):
    for x, y in zip(jtu.tree_leaves(a), jtu.tree_leaves(b)):
        np.testing.assert_allclose(np.asarray(x), np.asarray(y), rtol=rtol, atol=atol)


Q = quat_from_axis_angle(jnp.array([0.3, -0.5, 0.8]), 1.1)
P = quat_from_axis_angle(jnp.array([-0.2, 0.1, 0.4]), 2.5)
SIGMA = jnp.array([0.1, 0.2, -0.3])
OMEGA = jnp.array([0.4, -0.1, 0.2])
J = jnp.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])


@pytest.mark.parametrize(
    "f, args",
    [
        (quat_multiply, (P, Q)),
        (mrp_kinematics, (SIGMA, OMEGA)),
        (mrp_to_dcm, (SIGMA,)),
        (solve3, (J, OMEGA)),
        (lambda a, b: jnp.einsum("ij,jk->ik", a, b), (J, J.T)),  # dot_general
        (lambda a: jnp.einsum("bij,bj->bi", a, a[:, 0]), (jnp.stack([J, 2 * J]),)),  # batch dims
        (lambda a: (jnp.sum(a, axis=0), jnp.max(a), jnp.prod(a, axis=1)), (J,)),
        (lambda a: jnp.where(a > 1.3, jnp.sin(a), jnp.clip(a, 0.0, 1.0) ** 3), (J / 10,)),
        (lambda a: jnp.concatenate([a[::-1], a[1:3]]).reshape(2, 3).T, (Q,)),
        (lambda a: lax.dynamic_slice(a, (1,), (2,)), (Q,)),
        (lambda a, i: lax.dynamic_slice(a, (i,), (2,)), (Q, jnp.array(2))),
        (lambda a: lax.cond(a[0] > 0, lambda x: 2 * x, lambda x: x - 1, a), (Q,)),
        (lambda a: lax.optimization_barrier((a, 2 * a)), (SIGMA,)),
        (lambda a: sig_pow(a, 0.5), (jnp.array([0.3, 0.0, -0.7]),)),
        (vectorized_log, (jnp.array([0.3, 1e-310, 7.0]),)),  # integer shifts and bitcasts
    ],
    ids=lambda x: getattr(x, "__name__", None) if callable(x) else "",
)
def test_scalarized_values_equal_the_original(f, args):
    assert_trees_close(run_scalarized(f, *args), f(*args))


def test_the_closed_loop_vector_field_is_unchanged():
    loop = chen.build("M1")
    y = loop.init(0.0, chen.initial_state("D1"))
    assert_trees_close(run_scalarized(lambda y: loop(0.37, y, None), y), loop(0.37, y, None))


def test_custom_derivative_rules_survive():
    # sig_pow's capped slope at 0 (a NaN for the naive |x|^a sign x) must come through.
    x = jnp.array([0.3, 0.0, -0.7])

    def direct(x):
        return jnp.sum(sig_pow(x, 0.5) * jnp.array([1.0, 2.0, 3.0]))

    def via_scalarizer(x):
        out = scalarize(lambda z: jnp.sum(sig_pow(z, 0.5) * jnp.array([1.0, 2.0, 3.0])))(split(x))
        return pack(out, x.dtype)

    expected = jax.grad(direct)(x)
    assert np.all(np.isfinite(expected))
    np.testing.assert_allclose(jax.grad(via_scalarizer)(x), expected, rtol=1e-14)
    np.testing.assert_allclose(jax.jacfwd(via_scalarizer)(x), jax.jacfwd(direct)(x), rtol=1e-14)
    np.testing.assert_allclose(
        jax.vmap(via_scalarizer)(jnp.stack([x, -x])), jax.vmap(direct)(jnp.stack([x, -x]))
    )


def test_large_arrays_stay_whole():
    big = jnp.arange(DEFAULT_LIMITS.max_size + 1.0)
    assert not _is_object_array(split(big))
    small = split(jnp.arange(3.0))
    assert _is_object_array(small) and small.shape == (3,)
    f = lambda a, b: (jnp.cumsum(a)[:3] + b, a @ a)
    assert_trees_close(run_scalarized(f, big, jnp.ones(3)), f(big, jnp.ones(3)))


@pytest.fixture(scope="module")
def m1():
    return chen.build("M1")


@pytest.fixture(scope="module")
def pd_mrp():
    from jaxatt.scenarios import rigid_body_pd

    return rigid_body_pd.build(), rigid_body_pd.initial_state()


def test_simulate_scalarized_equals_simulate(m1):
    x0 = chen.initial_state("D2")
    plain = simulate(m1, x0, 0.0, 0.5, dt=1e-3, save_every=50)
    fast = simulate(m1, x0, 0.0, 0.5, dt=1e-3, save_every=50, performance=FAST)
    assert_trees_close(fast.states, plain.states, rtol=1e-12, atol=1e-14)
    assert_trees_close(fast.signals, plain.signals, rtol=1e-11, atol=1e-12)


@pytest.mark.parametrize(
    "options",
    [{"sampling": ZeroOrderHold(0.01)}, {"solver": Euler()}, {"solver": dfx.Heun()}],
    ids=["zoh", "euler", "diffrax-heun"],
)
def test_scalarized_sampling_and_solvers(pd_mrp, options):
    loop, x0 = pd_mrp
    kwargs = dict(dt=1e-3, save_every=50, **options)
    plain = simulate(loop, x0, 0.0, 0.2, **kwargs)
    fast = simulate(loop, x0, 0.0, 0.2, performance=FAST, **kwargs)
    assert_trees_close(fast.states, plain.states, rtol=1e-12, atol=1e-14)


def test_scalarized_mrp_shadow_switching_and_float32(pd_mrp):
    loop, x0 = pd_mrp
    x0 = MRPState(jnp.array([0.0, 0.0, 0.98]), jnp.array([0.0, 0.0, 0.5]))  # switches early
    euler = dict(dt=1e-3, save_every=100, solver=Euler())  # a small program: fast to compile
    plain = simulate(loop, x0, 0.0, 1.0, **euler)
    fast = simulate(loop, x0, 0.0, 1.0, performance=FAST, **euler)
    assert np.any(np.diff(np.sign(np.asarray(plain.states.plant.sigma[:, 2]))) != 0)
    assert_trees_close(fast.states, plain.states, rtol=1e-12, atol=1e-14)
    loop32 = jtu.tree_map(lambda x: x.astype(jnp.float32) if eqx.is_inexact_array(x) else x, loop)
    x32 = jtu.tree_map(lambda x: x.astype(jnp.float32), x0)
    fast32 = simulate(loop32, x32, 0.0, 1.0, performance=FAST, **euler)
    assert fast32.states.plant.sigma.dtype == jnp.float32
    np.testing.assert_allclose(fast32.states.plant.sigma, plain.states.plant.sigma, atol=1e-5)


def test_scalarized_gradients_match_finite_differences(pd_mrp):
    # Autodiff of a scalarized step goes through the plain step's JVP (a custom rule); check
    # it against central differences of the scalarized forward run, for a gain, an inertia
    # entry and an initial state component (Euler: the rule does not depend on the solver,
    # and the program compiles faster). Both sides differentiate the same smooth
    # (unsaturated) map, so 1e-6 relative leaves room for the FD error only.
    loop, x0 = pd_mrp

    @eqx.filter_jit
    def loss(k1, j11, s0):
        loop_ = eqx.tree_at(
            lambda m: (m.controller.k1, m.plant.body.inertia),
            loop,
            (k1, loop.plant.body.inertia.at[0, 0].set(j11)),
        )
        x = MRPState(x0.sigma.at[0].set(s0), x0.omega)
        traj = simulate(
            loop_, x, 0.0, 0.2, dt=1e-3, save_every=20, solver=Euler(), performance=FAST
        )
        return jnp.sum(traj.signals["attitude_error"] ** 2) + jnp.sum(traj.signals["u"])

    args = (loop.controller.k1, loop.plant.body.inertia[0, 0], x0.sigma[0])
    grads = jax.grad(loss, argnums=(0, 1, 2))(*args)
    for k, g in enumerate(grads):
        h = 1e-5 * max(1.0, abs(float(args[k])))
        plus = [a + h if i == k else a for i, a in enumerate(args)]
        minus = [a - h if i == k else a for i, a in enumerate(args)]
        fd = (float(loss(*plus)) - float(loss(*minus))) / (2 * h)
        assert np.isfinite(float(g)) and abs(float(g) - fd) <= 1e-6 * abs(fd) + 1e-9, (k, g, fd)


def test_vmapped_scalarized_simulation_lowers_to_elementwise_code(m1):
    # The reason the scalarizer exists: a batch of closed loops compiles without the
    # dot/transpose kernels that vmapped 3-vector code gives (DESIGN.md, performance notes).
    x0 = jax.vmap(lambda k: chen.initial_state("D1"))(jr.split(jr.key(0), 8))
    params, static = eqx.partition(m1, eqx.is_array)

    def step_loop_hlo(scalarize):
        @jax.jit
        def run(params, x0):
            loop = eqx.combine(params, static)
            return jax.vmap(
                lambda x: simulate(
                    loop,
                    x,
                    0.0,
                    0.01,
                    dt=1e-3,
                    save_every=10,
                    performance=Performance(scalarize=scalarize),
                )
            )(x0)

        hlo = run.lower(params, x0).compile().as_text()
        computations = {c.split(" ", 1)[0]: c for c in re.split(r"\n(?=%)", hlo)}
        bodies = [computations["%" + name] for name in re.findall(r"body=%([\w.\-]+)", hlo)]
        # The inner time loop: the while body that contains no loop itself, with the fused
        # computations it calls.
        (inner,) = [body for body in bodies if " while(" not in body]
        called = re.findall(r"calls=%([\w.\-]+)", inner)
        return "\n".join([inner, *(computations["%" + name] for name in called)])

    assert " dot(" in step_loop_hlo(False)  # what the test guards against
    fast = step_loop_hlo(True)
    assert " dot(" not in fast and " transpose(" not in fast
    # The powers' logarithm (integer and float arithmetic on the bits) is scalarized too: no
    # packed (batch, 3) array in the step, and no C-library `log` call per element.
    assert "[8,3]" not in fast and " log(" not in fast


def test_large_matrix_products_stay_packed():
    # A graph Laplacian or a modal matrix must not become an O(n^3) scalar program: products
    # needing more multiplications than `max_products` are evaluated as one packed dot.
    laplacian = jnp.array(np.diag([2.0] * 6) - np.eye(6, k=1) - np.eye(6, k=-1))
    x = jnp.arange(6.0)

    def count(limits):
        def scalarized(v):
            return pack(scalarize(lambda w: laplacian @ w, limits)(split(v)), v.dtype)

        jaxpr = jax.make_jaxpr(scalarized)(x)
        names = [e.primitive.name for e in jaxpr.jaxpr.eqns]
        return names.count("dot_general"), names.count("mul")

    unrolled_dots, unrolled_muls = count(Limits(max_products=64))  # 36 products: unrolled
    packed_dots, packed_muls = count(Limits(max_products=16))
    assert unrolled_dots == 0 and unrolled_muls == 36
    assert packed_dots == 1 and packed_muls == 0
    for limits in (Limits(max_products=64), Limits(max_products=16)):
        out = pack(scalarize(lambda w: laplacian @ w, limits)(split(x)), x.dtype)
        np.testing.assert_allclose(out, laplacian @ x, rtol=1e-15)
    with pytest.raises(ValueError, match="`max_unrolled_products` must be a positive integer"):
        Performance(max_unrolled_products=0)


@pytest.mark.parametrize("bad", [1, 0, 1.0, "True"])
def test_scalarize_must_be_a_flag(bad, no_jaxtyping):
    # Regression: `scalarize not in (None, True, False)` let 1, 0 and 1.0 through (they compare
    # equal to the booleans). (The suite's type checking rejects them first; users meet this.)
    with pytest.raises(ValueError, match="`scalarize` must be True, False or None"):
        Performance(scalarize=bad)
