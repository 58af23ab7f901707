"""Plant families the library does not ship (tests/standins.py) run through `simulate`,
`monte_carlo` and `tune` unchanged: the core speaks any plant, not only rigid-body attitude.

For each stand-in: an oracle for the dynamics, `monte_carlo` equal to a Python loop of
`simulate` (vmap = loop), a tuning run, and the tuning gradient against central finite
differences of the same objective. Tolerances: the gradient checks differentiate the same
discrete RK4 map on both sides, so they agree to rounding (~1e-9 relative for a 1e-6 step)
unless a perturbation moves a sample across the tolerance band; 1e-5 relative leaves margin.
"""

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest

import jaxatt
from jaxatt import montecarlo as mc, tune
from jaxatt.controllers import NormRobustTerm, SlidingModeTracking
from jaxatt.metrics import Euclidean, SettlingTime
from jaxatt.plants import QuaternionState, RigidBodyQuaternion
from jaxatt.reaching import TwoPhasePower
from jaxatt.rotations import quat_from_axis_angle
from jaxatt.simulation import ClosedLoop
from jaxatt.sliding import LinearSurface

from .standins import (
    Agents,
    ConsensusPD,
    FlexibleBody,
    FlexibleState,
    FractionalPD,
    PointMass,
    TranslationPD,
    TranslationState,
    grunwald_letnikov_weights,
)


def _index(tree, k):
    return jax.tree.map(lambda x: x[k], tree)


def _vmap_equals_loop(loop, x0s, t1, dt, metrics):
    """monte_carlo (one compiled batch) against simulate sample by sample."""
    batch = mc.monte_carlo(loop, x0s, 0.0, t1, dt=dt, metrics=metrics, keep_trajectories=True)
    n = jax.tree.leaves(x0s)[0].shape[0]
    for k in range(n):
        single = jaxatt.simulate(loop, _index(x0s, k), 0.0, t1, dt=dt)
        for a, b in zip(
            jax.tree.leaves(_index(batch.trajectories.states, k)), jax.tree.leaves(single.states)
        ):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)
    assert bool(np.all(batch.successful))
    return batch


def _gradient_check(loop, params, objective, x0s, h=1e-6, rtol=1e-5):
    u0 = tune.initial_unconstrained(loop, params)
    (loss, aux), grads = tune.loss_and_grad(u0, loop, params, objective, x0s)
    assert np.isfinite(float(loss))
    for name in params:
        plus, minus = (dict(u0, **{name: u0[name] + d}) for d in (h, -h))
        numeric = (
            float(tune.evaluate(tune.apply(loop, params, plus), objective, x0s)[0])
            - float(tune.evaluate(tune.apply(loop, params, minus), objective, x0s)[0])
        ) / (2 * h)
        assert abs(numeric) > 1e-6, name  # the parameter moves the loss
        assert abs(float(grads[name]) - numeric) <= rtol * abs(numeric), (name, grads, numeric)
    return loss, aux


# --- 3-D double integrator under PD -------------------------------------------------------


def test_double_integrator_matches_the_closed_form_and_runs_everywhere():
    kp, kd = 4.0, 2.0  # r'' + 2 r' + 4 r = 0: underdamped, w_d = sqrt(3)
    loop = ClosedLoop(PointMass(2.0), TranslationPD(kp * 2.0, kd * 2.0))  # u/m: same gains
    x0 = TranslationState(jnp.array([1.0, -0.5, 0.2]), jnp.array([0.0, 0.3, 0.0]))
    traj = jaxatt.simulate(loop, x0, 0.0, 4.0, dt=0.01)
    wd = np.sqrt(3.0)
    t = np.asarray(traj.ts)[:, None]
    r0, v0 = np.asarray(x0.r), np.asarray(x0.v)
    exact = np.exp(-t) * (r0 * np.cos(wd * t) + (v0 + r0) / wd * np.sin(wd * t))
    np.testing.assert_allclose(traj.plant_states.r, exact, atol=1e-8)  # RK4 at dt = 0.01

    x0s = TranslationState(jr.uniform(jr.key(0), (3, 3), minval=-1, maxval=1), jnp.zeros((3, 3)))
    batch = _vmap_equals_loop(loop, x0s, 4.0, 0.01, None)  # the plant's default metrics
    assert set(batch.metrics) == {"settling_time", "peak_force", "effort"}

    params = {
        "kp": tune.Parameter("controller.kp", tune.Positive()),
        "kd": tune.Parameter("controller.kd", tune.Positive()),
    }
    objective = tune.SettlingObjective(4.0, 0.01, 0.05, signal="position_error")
    loss, aux = _gradient_check(loop, params, objective, x0s)
    assert bool(np.all(aux["settled"]))  # the interpolated-crossing branch
    result = tune.tune(loop, params, objective, x0s, steps=3, progress=False)
    assert result.losses[-1] < result.losses[0]


# --- three double integrators coupled through a graph Laplacian -----------------------------


PATH = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])


def test_laplacian_network_reaches_consensus_per_agent():
    loop = ClosedLoop(Agents(3), ConsensusPD(PATH, 1.5, 2.0))
    key_r, key_v = jr.split(jr.key(3))
    x0s = TranslationState(
        jr.uniform(key_r, (2, 3, 3), minval=-1, maxval=1), 0.1 * jr.normal(key_v, (2, 3, 3))
    )
    per_agent = {"settling": SettlingTime("disagreement", 1e-2, Euclidean(axes=-1))}
    batch = _vmap_equals_loop(loop, x0s, 8.0, 0.02, per_agent)
    assert batch.metrics["settling"].shape == (2, 3)  # one settling time per agent
    assert np.all(np.isfinite(batch.metrics["settling"]))
    # The Laplacian's rows sum to 0, so the mean obeys the uncoupled damped law exactly:
    # mean(v)' = -kd mean(v), mean(r) = mean(r0) + mean(v0) (1 - exp(-kd t)) / kd.
    traj = _index(batch.trajectories, 0)
    t = np.asarray(traj.ts)[:, None]
    mean_r = np.asarray(traj.plant_states.r).mean(axis=1)
    mean_v0 = np.asarray(x0s.v[0]).mean(axis=0)
    expected = np.asarray(x0s.r[0]).mean(axis=0) + mean_v0 * (1 - np.exp(-2.0 * t)) / 2.0
    np.testing.assert_allclose(mean_r, expected, atol=1e-9)

    params = {"kp": tune.Parameter("controller.kp", tune.Positive())}
    objective = tune.SettlingObjective(8.0, 0.02, 1e-2, signal="disagreement")
    _gradient_check(loop, params, objective, x0s)
    result = tune.tune(loop, params, objective, x0s, steps=2, progress=False)
    assert np.isfinite(result.losses).all()


# --- a rigid body with two modal coordinates, flown by the quaternion SMC -------------------


J0 = jnp.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])


def _smc():
    return SlidingModeTracking(
        LinearSurface(5.0),
        TwoPhasePower(1.2, 1.2, 31 / 11, 5 / 9),
        J0,
        NormRobustTerm(0.35, 0.01),
    )


def _flexible(coupling):
    return FlexibleBody(J0, jnp.asarray(coupling), jnp.array([1.5, 4.0]), jnp.array([0.02, 0.05]))


def test_flexible_body_is_flown_by_the_attitude_controller():
    q0 = quat_from_axis_angle(jnp.array([0.6, 0.0, 0.8]), 0.6)
    x0 = FlexibleState(q0, jnp.zeros(3), jnp.zeros(2), jnp.zeros(2))
    # Oracle: without coupling the hub is exactly the rigid body.
    rigid = jaxatt.simulate(
        ClosedLoop(RigidBodyQuaternion(J0), _smc()),
        QuaternionState(q0, jnp.zeros(3)),
        0.0,
        3.0,
        dt=5e-3,
    )
    uncoupled = jaxatt.simulate(
        ClosedLoop(_flexible(jnp.zeros((2, 3))), _smc()), x0, 0.0, 3.0, dt=5e-3
    )
    # (Not to rounding: the two-phase law's sign switches near s = 0 turn the rounding
    # difference of a 5x5 LU solve against the rigid body's 3x3 adjugate into differences of
    # order dt |s'|; measured 3.5e-8.)
    np.testing.assert_allclose(uncoupled.plant_states.q, rigid.plant_states.q, atol=1e-6)
    coupling = jnp.array([[1.2, 0.4, -0.3], [0.2, -0.8, 0.9]])
    loop = ClosedLoop(_flexible(coupling), _smc())
    x0s = jax.tree.map(lambda a: jnp.stack([a, a]), x0)
    x0s = FlexibleState(
        jnp.stack([q0, quat_from_axis_angle(jnp.array([0.0, 1.0, 0.0]), -0.4)]),
        x0s.omega,
        x0s.eta,
        x0s.eta_dot,
    )
    metrics = {"settling_time": SettlingTime("attitude_error_vector", 1e-3)}
    batch = _vmap_equals_loop(loop, x0s, 3.0, 5e-3, metrics)
    modes = np.asarray(batch.trajectories.signals["modal_displacement"])
    assert np.max(np.abs(modes)) > 1e-3  # the manoeuvre excites the appendage
    assert np.all(np.asarray(batch.metrics["settling_time"]) < 3.0)  # and the SMC settles

    params = {"rho": tune.Parameter("controller.reaching_law.rho", tune.Positive())}
    objective = tune.SettlingObjective(3.0, 5e-3, 1e-3)
    _gradient_check(loop, params, objective, x0s)
    tune.tune(loop, params, objective, x0s, steps=1, progress=False)


# --- a controller with a discrete per-step memory -----------------------------------------


def test_fractional_pd_memory_is_advanced_after_every_completed_step():
    dt, memory = 0.02, 6
    plant = PointMass(1.0)
    x0 = TranslationState(jnp.array([1.0, -0.5, 0.25]), jnp.zeros(3))
    # alpha = 1: the GL weights are [1, -1, 0, ...], a backward difference (an oracle).
    np.testing.assert_allclose(
        grunwald_letnikov_weights(jnp.asarray(1.0), memory), [1, -1, 0, 0, 0, 0], atol=1e-15
    )
    backward = ClosedLoop(plant, FractionalPD(4.0, 2.0, 1.0, dt, memory))
    traj = jaxatt.simulate(backward, x0, 0.0, 1.0, dt=dt)
    r = np.asarray(traj.plant_states.r)
    history = np.asarray(traj.controller_states)
    # After step k the memory holds r(t_k), r(t_{k-1}), ... (r(0) before the start), exactly.
    for k in (0, 1, 2, 10, 50):
        expected = np.stack([r[max(k - j, 0)] for j in range(memory)])
        np.testing.assert_array_equal(history[k], expected)
    derivative = np.asarray(traj.signals["fractional_derivative"])
    np.testing.assert_allclose(derivative[1:], (r[1:] - r[:-1]) / dt, rtol=1e-12, atol=1e-14)

    loop = ClosedLoop(plant, FractionalPD(4.0, 2.0, 0.7, dt, memory))
    x0s = TranslationState(jnp.array([[1.0, -0.5, 0.25], [0.3, 0.8, -0.6]]), jnp.zeros((2, 3)))
    _vmap_equals_loop(loop, x0s, 6.0, dt, {"t": SettlingTime("position_error", 0.05)})
    params = {
        "kd": tune.Parameter("controller.kd", tune.Positive()),
        "alpha": tune.Parameter("controller.alpha", tune.Interval(0.0, 2.0)),
    }
    objective = tune.SettlingObjective(6.0, dt, 0.05, signal="position_error")
    _gradient_check(loop, params, objective, x0s)
    tune.tune(loop, params, objective, x0s, steps=1, progress=False)


@pytest.mark.parametrize(
    "build, needle",
    [
        (lambda: ConsensusPD(PATH + 0.1, 1.0, 1.0), "rows must sum to 0"),
        (lambda: PointMass(-1.0), "`mass` must be positive"),
    ],
)
def test_stand_ins_validate_like_library_components(build, needle):
    with pytest.raises(ValueError, match=needle):
        build()
