"""A sample at every step, streamed or saved: one flight-software evaluation feeds both the
signals and the solver's first stage, and the numbers stay those of the other paths."""

import diffrax
import jax
import jax.random as jr
import numpy as np
import pytest

from jaxatt import montecarlo as mc
from jaxatt.metrics import Chattering, Final
from jaxatt.plants import QuaternionState
from jaxatt.scenarios import chen2022_two_phase_power as chen
from jaxatt.simulation import RK4, Euler, Performance

from ..helpers import count_primitive, sub_jaxprs


N, HORIZON, DT = 3, 0.2, 5e-3


@pytest.fixture(scope="module")
def chen_loop():
    loop = chen.build("M1")
    keys = jr.split(jr.key(3), 2)
    x0s = QuaternionState(mc.attitudes_within(keys[0], N, 1.0), mc.rates_in_ball(keys[1], N, 0.05))
    return loop, x0s


def _interval_body(jaxpr):
    """The body of the outermost `scan`: one save interval (one step when every step saves),
    with whatever it evaluates around its steps."""
    for eqn in jaxpr.eqns:
        if eqn.primitive.name == "scan":
            return eqn.params["jaxpr"].jaxpr
        for sub in sub_jaxprs(eqn):
            body = _interval_body(sub)
            if body is not None:
                return body
    return None


@pytest.mark.parametrize("scalarize", [False, True])
@pytest.mark.parametrize("solver, stages", [(RK4(), 4), (Euler(), 1)], ids=["rk4", "euler"])
def test_the_streamed_step_evaluates_the_flight_software_once_per_stage(
    chen_loop, solver, stages, scalarize
):
    # Chen's reaching law takes one exp(a log|s|) per evaluation of the controller (per
    # component when scalarized). The streamed signals at t_i and the solver's first stage
    # f(t_i, y_i) share one evaluation, so a step holds exactly `stages` of them (before: one
    # more, which XLA did not merge: 17 exp/log pairs per compiled step against 14).
    loop, x0s = chen_loop
    y0 = loop.init(0.0, jax.tree.map(lambda a: a[0], x0s))
    per_field = count_primitive(
        jax.make_jaxpr(lambda y: loop.vector_field(0.0, y, None))(y0).jaxpr, "exp"
    )
    assert per_field == 1

    def program(loop, x0s):
        performance = Performance(scalarize=scalarize)
        return mc.monte_carlo(
            loop, x0s, 0.0, 10 * DT, dt=DT, solver=solver, performance=performance
        ).metrics

    body = _interval_body(jax.make_jaxpr(program)(loop, x0s).jaxpr)
    components = 3 if scalarize else 1
    assert count_primitive(body, "exp") == stages * per_field * components


@pytest.mark.parametrize(
    "solver, scalarize",
    [(RK4(), False), (RK4(), True), (Euler(), True), (diffrax.Heun(), True)],
    ids=["rk4-plain", "rk4-scalarized", "euler-scalarized", "diffrax-heun-scalarized"],
)
def test_streaming_every_step_equals_the_saved_trajectory(chen_loop, solver, scalarize):
    # Every step saves (save_every=1, monte_carlo's default): the shared first stage must not
    # change a number. Heun (a diffrax solver) takes no start derivative: the other branch.
    loop, x0s = chen_loop
    metrics = dict(
        loop.default_metrics(1e-2),
        final_rate=Final("rate_error"),
        chattering=Chattering("u", 0.05, 0.15),  # inside the 0.2 s run: not 0 by construction
    )
    options = dict(dt=DT, solver=solver, metrics=metrics)
    saved = mc.monte_carlo(loop, x0s, 0.0, HORIZON, keep_trajectories=True, **options)
    streamed = mc.monte_carlo(
        loop, x0s, 0.0, HORIZON, performance=Performance(scalarize=scalarize), **options
    )
    assert streamed.trajectories is None and np.all(np.asarray(streamed.successful))
    for name in metrics:
        np.testing.assert_allclose(
            streamed.metrics[name], saved.metrics[name], rtol=1e-12, atol=0, err_msg=name
        )


@pytest.mark.parametrize("scalarize", [False, True])
def test_the_saved_step_evaluates_the_flight_software_once_per_stage(chen_loop, scalarize):
    # Saving every step (the default of `simulate` and of `monte_carlo(...,
    # keep_trajectories=True)`) shares the first stage the same way.
    loop, x0s = chen_loop

    def program(loop, x0s):
        performance = Performance(scalarize=scalarize)
        result = mc.monte_carlo(
            loop, x0s, 0.0, 10 * DT, dt=DT, keep_trajectories=True, performance=performance
        )
        return result.trajectories

    body = _interval_body(jax.make_jaxpr(program)(loop, x0s).jaxpr)
    assert count_primitive(body, "exp") == 4 * (3 if scalarize else 1)


@pytest.mark.parametrize(
    "solver, scalarize",
    [(RK4(), False), (Euler(), False), (RK4(), True)],
    ids=["rk4-plain", "euler-plain", "rk4-scalarized"],
)
def test_saving_every_step_equals_saving_every_other_step(chen_loop, solver, scalarize):
    # save_every=1 computes the signals of t_i at the start of step i (sharing the first
    # stage); save_every=2 at the end of each interval, from a separate evaluation. The saves
    # they have in common must agree: states, signals and times.
    loop, x0s = chen_loop
    every, other = (
        mc.monte_carlo(
            loop,
            x0s,
            0.0,
            HORIZON,
            dt=DT,
            solver=solver,
            save_every=k,
            keep_trajectories=True,
            performance=Performance(scalarize=scalarize),
        ).trajectories
        for k in (1, 2)
    )
    np.testing.assert_array_equal(every.ts[:, ::2], other.ts)
    for a, b in zip(jax.tree.leaves(every.states), jax.tree.leaves(other.states)):
        np.testing.assert_allclose(a[:, ::2], b, rtol=1e-12, atol=1e-15)
    for name in other.signals:
        a, b = np.asarray(every.signals[name])[:, ::2], np.asarray(other.signals[name])
        # A signal computed from O(1) states carries their absolute rounding (~eps) however
        # small it is: quat_norm_error = |q| - 1 is ~1e-12 and differs by 2e-16 between the
        # two programs, so the absolute tolerance is relative to max(scale, 1).
        scale = max(np.max(np.abs(b)), 1.0)
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13 * scale, err_msg=name)
