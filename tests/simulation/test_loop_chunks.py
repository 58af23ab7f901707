"""The time loops run long loops as loops of short ones (`INNER_LOOP_STEPS`), the same calls in
the same order: XLA:CPU runs one trajectory about 3x faster per step that way (benchmarks/
README.md, "Short inner loops")."""

import jax
import jax.lax as lax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest

from jaxatt import montecarlo as mc, simulate
from jaxatt.plants import QuaternionState
from jaxatt.scenarios import chen2022_two_phase_power as chen
from jaxatt.simulation import _loop

from ..helpers import count_primitive, sub_jaxprs


DT = 1e-3


def _body(carry, x):
    """A step whose result depends on the order of the calls (a chunking that reordered or
    dropped an index would change it)."""
    value, count = carry
    value = jnp.sin(value) * 1.5 + x["a"] * jnp.cos(x["b"])
    return (value, count + 1), {"value": value, "pair": (x["a"] * 2, value - x["b"])}


def test_chunks_divide_the_loop_so_no_remainder_loop_is_compiled():
    for short in (1, _loop.INNER_LOOP_STEPS, 9, 64):
        assert _loop._chunk(short) is None  # short loops run fast as they are
    for length in (65, 66, 100, 125, 2000, 30000):
        chunk = _loop._chunk(length)
        assert chunk is not None and length % chunk == 0 and 2 <= chunk <= 64, (length, chunk)
    assert _loop._chunk(2000) == _loop.INNER_LOOP_STEPS
    assert _loop._chunk(66) == 3 and _loop._chunk(125) == 5
    for prime in (67, 10007):
        assert _loop._chunk(prime) is None  # no remainder loop: one loop, one compiled step


@pytest.mark.parametrize("length", [1, 7, 8, 9, 16, 17, 100, 125])
def test_chunked_scan_equals_one_scan_to_the_bit(length):
    k1, k2 = jr.split(jr.key(length))
    xs = {"a": jr.normal(k1, (length, 3)), "b": jr.normal(k2, (length, 3))}
    carry0 = (jnp.zeros(3), jnp.asarray(0))
    expected = lax.scan(_body, carry0, xs)
    got = _loop._scan(_body, carry0, xs, length)
    assert jax.tree.structure(got) == jax.tree.structure(expected)
    for g, e in zip(jax.tree.leaves(got), jax.tree.leaves(expected)):
        assert g.shape == e.shape and g.dtype == e.dtype
        np.testing.assert_array_equal(g, e)
    assert int(got[0][1]) == length


def test_chunked_scan_without_inputs_or_outputs():
    def count(carry, _):
        return carry * 1.01 + 1.0, None

    for length in (5, 8, 21):
        expected, _ = lax.scan(count, 0.5, None, length=length)
        got, ys = _loop._scan(count, 0.5, None, length)
        assert ys is None
        assert float(got) == float(expected)


def _innermost_scan_lengths(jaxpr) -> list[int]:
    """The lengths of the scans whose bodies hold no other scan (the loops XLA runs as loops
    of kernels), nested calls included."""
    found = []

    def has_scan(j) -> bool:
        return any(e.primitive.name == "scan" or any(map(has_scan, sub_jaxprs(e))) for e in j.eqns)

    def walk(j):
        for eqn in j.eqns:
            if eqn.primitive.name == "scan" and not has_scan(eqn.params["jaxpr"].jaxpr):
                found.append(eqn.params["length"])
            for sub in sub_jaxprs(eqn):
                walk(sub)

    walk(getattr(jaxpr, "jaxpr", jaxpr))
    return found


@pytest.fixture(scope="module")
def chen_case():
    x0s = QuaternionState(mc.attitudes_within(jr.key(0), 2, 1.0), jnp.full((2, 3), 0.01))
    return chen.build("M1"), x0s


@pytest.mark.parametrize("save_every", [1, 3, 10, 100])
def test_no_time_loop_runs_more_than_the_inner_steps_at_once(chen_case, save_every):
    loop, x0s = chen_case
    x0 = jax.tree.map(lambda a: a[0], x0s)
    steps = 300

    def saved(loop, x0):
        return simulate(loop, x0, 0.0, steps * DT, dt=DT, save_every=save_every).states

    def streamed(loop, x0s):
        return mc.monte_carlo(loop, x0s, 0.0, steps * DT, dt=DT, save_every=save_every).metrics

    for program, x in ((saved, x0), (streamed, x0s)):
        jaxpr = jax.make_jaxpr(program)(loop, x)
        lengths = _innermost_scan_lengths(jaxpr)
        # a short save interval's steps are the innermost loop; else chunks
        bound = save_every if 1 < save_every <= 64 else _loop.INNER_LOOP_STEPS
        assert lengths and max(lengths) <= bound, lengths
        # one copy of the step: no remainder loop
        assert len(lengths) == 1, lengths
        if save_every == 10:
            # 30 intervals of 10 steps: short loops stay as they are, the loop around them too
            assert lengths == [10] and count_primitive(jaxpr, "scan") == 2


def test_chunked_trajectories_equal_the_step_by_step_states(chen_case):
    # 72 steps (every step saved: chunks of 4) against 72 steps saved once (chunks of 4) and
    # 9 steps (one loop).
    loop, x0s = chen_case
    x0 = jax.tree.map(lambda a: a[0], x0s)
    every = simulate(loop, x0, 0.0, 72 * DT, dt=DT)
    last = simulate(loop, x0, 0.0, 72 * DT, dt=DT, save_every=72)
    assert every.states.plant.q.shape == (73, 4)
    np.testing.assert_allclose(every.ts, DT * np.arange(73), rtol=0, atol=1e-15)
    # Different programs (the every-step loop shares the first stage with the saved signals),
    # so agreement to rounding, as tests/simulation/test_streaming.py checks for other counts.
    for a, b in zip(jax.tree.leaves(every.states), jax.tree.leaves(last.states)):
        np.testing.assert_allclose(a[-1], b[-1], rtol=1e-13, atol=1e-15)
    # a shorter run (one loop) is the longer run's first steps
    short = simulate(loop, x0, 0.0, 9 * DT, dt=DT)
    for a, b in zip(jax.tree.leaves(every.states), jax.tree.leaves(short.states)):
        np.testing.assert_allclose(a[:10], b, rtol=1e-13, atol=1e-15)
