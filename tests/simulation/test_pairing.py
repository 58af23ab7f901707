"""A metric stream's fresh values ride two per complex number in the scalarized loop.

The values themselves are checked where users meet them: `tests/montecarlo/test_batch.py`
compares every kind of streamed metric, scalarized, with the saved-trajectory reduction (and
fails when `unpair` swaps the two parts of a pair).
"""

import jax
import jax.numpy as jnp
import numpy as np

from jaxatt.montecarlo import monte_carlo
from jaxatt.plants import QuaternionState
from jaxatt.scenarios import chen2022_two_phase_power as chen
from jaxatt.simulation import Performance
from jaxatt.simulation._pairing import pair, plan_pairs, signal_dependencies, unpair


def test_signal_dependencies_follow_the_data_not_the_names():
    def update(state, signals):
        total, peak = state
        return (
            total + 1.0,  # the state only
            jnp.maximum(peak, jnp.abs(signals["u"]).max()),  # u
            jnp.sum(signals["u"] ** 2) + signals["e"],  # u and e
            jnp.zeros(()),  # a constant
            jnp.sin(signals["e"]) * 0.0 + total,  # e (the data flows through, times 0)
        )

    state = (jnp.zeros(()), jnp.zeros(()))
    signals = {"e": jnp.ones(()), "u": jnp.ones(3)}  # leaves in key order: e (0), u (1)
    deps = signal_dependencies(update, state, signals)
    assert deps == [frozenset(), {1}, {0, 1}, frozenset(), {0}]


def test_pairs_join_values_of_the_same_signals_first_and_only_like_with_like():
    f64, f32 = jnp.zeros((), jnp.float64), jnp.zeros((), jnp.float32)
    leaves = [f64, f64, f64, jnp.zeros(3), f64, jnp.zeros((), jnp.int32), f32, f64, jnp.zeros(3)]
    deps = [{0}, {1}, set(), {0}, {0}, {0}, {1}, {2}, {0}]
    deps = [frozenset(d) for d in deps]
    # 0 and 4 read signal 0 (same kind); 3 and 8 are (3,) arrays reading signal 0; 1 and 7
    # are left and pair in order; 2 (state only), 5 (int) and 6 (the only float32) stay.
    assert plan_pairs(leaves, deps) == ((0, 4), (1, 7), (3, 8))


def test_pairing_is_exact_for_every_float_including_nan_inf_and_signed_zero():
    values = np.array([np.nan, np.inf, -np.inf, -0.0, 5e-324, 1.0 / 3.0], np.float64)
    tree = {"a": jnp.asarray(values), "b": jnp.asarray(values[::-1]), "n": jnp.arange(6)}
    paired = pair(tree, ((0, 1),))
    assert paired.packed[0].dtype == jnp.complex128 and len(paired.rest) == 1
    back = jax.jit(unpair)(paired)
    for name in tree:
        assert np.asarray(back[name]).tobytes() == np.asarray(tree[name]).tobytes(), name


def test_the_default_scalarized_monte_carlo_carries_its_metrics_in_complex_pairs():
    loop = chen.build("M1")
    x0s = QuaternionState(jnp.tile(jnp.array([1.0, 0.0, 0.0, 0.0]), (1000, 1)), jnp.ones((1000, 3)))

    def program(performance):
        run = jax.jit(lambda x: monte_carlo(loop, x, 0.0, 0.01, dt=1e-3, performance=performance))
        return run.lower(x0s).as_text()

    assert "complex<f64>" in program(None)  # 1000 samples: scalarized, paired
    assert "complex<f64>" not in program(Performance(scalarize=False))
