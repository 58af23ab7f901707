"""The helpers a closed loop's step calls many times are traced once per argument shape.

JAX traces inline code again at every call site; a `jax.jit` function is traced once per
argument shape and appears in the step's jaxpr as `pjit` equations that share one inner jaxpr
(XLA inlines the calls, so the compiled step is the same). Wu 2018's safe approach evaluates a
sine-cosine pair 148 times a step (its Hill rotation 22 times); inline, tracing its gradient
took 18.7 s instead of 8.7 s (docs/testing.md, "The numeric kernels traced once too").

These tests trace Wu 2018's and Shi 2024's `simulate` over a few steps and check, for each
kernel: it is called as a jit function, more often than it was traced, and with one inner
jaxpr per distinct argument signature. A kernel written inline again fails the first check.
"""

import collections

import equinox as eqx
import pytest

from jaxatt import simulate
from jaxatt.scenarios import shi2024, wu2018

from ..helpers import sub_jaxprs


def _jit_calls(jaxpr) -> dict[str, list]:
    """`name -> [(input avals, inner jaxpr), ...]` for every `pjit` equation, those inside
    other calls counted at each of their calls: as often as inline code would be traced."""
    calls = collections.defaultdict(list)

    def walk(j):
        for eqn in j.eqns:
            if eqn.primitive.name in ("pjit", "jit"):
                avals = tuple(str(v.aval) for v in eqn.invars)
                calls[eqn.params["name"]].append((avals, eqn.params["jaxpr"]))
            for sub in sub_jaxprs(eqn):
                walk(sub)

    walk(jaxpr)
    return calls


def _step_calls(loop, x0, dt, steps: int = 4) -> dict[str, list]:
    def run(loop, x0):
        return simulate(loop, x0, 0.0, steps * dt, dt=dt, throw=False)

    return _jit_calls(eqx.filter_make_jaxpr(run)(loop, x0)[0].jaxpr)


def _assert_traced_once_per_shape(calls: dict[str, list], kernel: str, at_least: int) -> None:
    """`kernel` is called as a jit function at least `at_least` times, with one inner jaxpr
    per distinct argument signature, and fewer signatures than calls."""
    found = calls.get(kernel, [])
    assert len(found) >= at_least, f"{kernel}: {len(found)} jit calls (inline code?)"
    signatures = {avals for avals, _ in found}
    assert len({id(j) for _, j in found}) == len(signatures) < len(found)


@pytest.fixture(scope="module")
def wu_calls():
    return _step_calls(wu2018.build(), wu2018.initial_state(wu2018.CASES["case2"]), wu2018.DT)


@pytest.mark.parametrize(
    "kernel, at_least",
    [
        ("_sincos_float64", 100),
        ("hill_rotation", 20),
        ("_anomaly_rates", 10),
        ("coriolis_matrices", 4),
        ("_abs_pow_primal", 4),
    ],
)
def test_wu2018s_step_traces_each_kernel_once_per_shape(wu_calls, kernel, at_least):
    _assert_traced_once_per_shape(wu_calls, kernel, at_least)


def test_shi2024s_smoother_series_is_traced_once_per_shape():
    calls = _step_calls(shi2024.build(), shi2024.initial_state(), shi2024.DT)
    _assert_traced_once_per_shape(calls, "_h", 4)
