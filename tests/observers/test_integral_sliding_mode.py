"""Integral sliding-mode observer (Shi & Song 2024, (12)-(15)) and the time-varying SMC.

One closed loop: a rigid body (whose lumped disturbance is exactly d(t), the oracle) under the
TVSMC compensated by the observer, at two steps. The estimate reaches a floor that scales with
dt (the RK4 dead zone of the relay L sign(s1), half-width L dt / 2).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.controllers import (
    SHARP_ALPHA_BAR,
    ObserverCompensated,
    TimeVaryingSlidingMode,
    TimeVaryingSlidingModeState,
)
from jaxatt.observers import IntegralSlidingModeObserver
from jaxatt.plants import QuaternionState, RigidBodyQuaternion
from jaxatt.references import ConstantAttitude
from jaxatt.signals import Sinusoid
from jaxatt.simulation import ClosedLoop, simulate


J = jnp.diag(jnp.array([503.0, 385.0, 420.0]))


def loop():
    plant = RigidBodyQuaternion(
        J, disturbance=Sinusoid(jnp.array([0.04, 0.06, 0.04]), jnp.array([0.1, 0.2, 0.3]), 0.0, 0.5)
    )
    law = ObserverCompensated(TimeVaryingSlidingMode(10.0, 0.4))
    return ClosedLoop(
        plant, law, ConstantAttitude(), observer=IntegralSlidingModeObserver(J, plant)
    )


@pytest.fixture(scope="module")
def runs():
    q0 = jnp.array([0.8832, 0.3, -0.2, -0.3])
    x0 = QuaternionState(q0 / jnp.linalg.norm(q0), jnp.zeros(3))
    out = {}
    for dt in (4e-3, 2e-3):
        traj = simulate(loop(), x0, 0.0, 12.0, dt=dt, save_every=round(0.04 / dt))
        error = np.max(
            np.abs(np.asarray(traj.signals["d_hat"] - traj.signals["disturbance"])), axis=1
        )
        out[dt] = (np.asarray(traj.ts), error, traj)
    return out


def test_exponents_and_bad_input():
    plant = loop().plant
    obs = IntegralSlidingModeObserver(J, plant)
    np.testing.assert_allclose(float(obs.alpha2), 1.4 / 1.7, rtol=1e-15)
    literal = IntegralSlidingModeObserver(J, plant, literal_alpha2=True)
    np.testing.assert_allclose(float(literal.alpha2), 0.7 / 1.7, rtol=1e-15)
    with pytest.raises(ValueError, match="alpha1"):
        IntegralSlidingModeObserver(J, plant, alpha1=1.0)
    with pytest.raises(ValueError, match="switching_gain"):
        IntegralSlidingModeObserver(J, plant, switching_gain=0.0)


def test_estimate_reaches_a_floor_proportional_to_dt(runs):
    """Finite-time convergence to the floor; floor(4e-3) / floor(2e-3) ~ 2 (linear in dt),
    both below the dead-zone half-width L dt / 2 plus the chatter of d over a step."""
    floors = {}
    for dt, (ts, error, _) in runs.items():
        late = ts >= 6.0
        floors[dt] = error[late].max()
        assert floors[dt] < 0.6 * 100 * dt
        reached = ts[np.argmax(error < 2 * floors[dt])]
        assert reached < 3.0  # converged within 3 s and stays at the floor afterwards
        assert error[0] > 5 * floors[dt]  # d_hat starts at 0, d(0) = 0.5 N m
    ratio = floors[4e-3] / floors[2e-3]
    assert 1.5 < ratio < 2.6


def test_attitude_converges_and_v2_decreases(runs):
    """The compensated TVSMC regulates the rigid body (V2 of (27) non-increasing on the grid)."""
    ts, _, traj = runs[2e-3]
    q = np.asarray(traj.plant_states.q)
    assert np.max(np.abs(q[-1, 1:])) < 0.05
    law = loop().controller.controller
    v2 = jax.vmap(law.lyapunov, in_axes=(None, 0, 0, 0))(
        J, traj.plant_states.q, traj.plant_states.omega, traj.controller_states
    )
    assert np.max(np.diff(np.asarray(v2))) <= 0


def test_tvsmc_law_and_adaptation_match_the_printed_equations():
    """(22), (23) (with tau_max, as corrected) and (26), written out independently."""
    law = TimeVaryingSlidingMode(
        7.0, 0.3, gamma_k=0.01, gamma_c=1.5, gamma_p=0.03, gamma_d=0.1, alpha_bar=0.25
    )
    q = np.array([0.9, 0.2, -0.3, 0.1])
    q = q / np.linalg.norm(q)
    omega = np.array([0.01, -0.02, 0.03])
    k, p2 = 1.7, 0.4
    state = TimeVaryingSlidingModeState(jnp.asarray(k), jnp.asarray(p2))
    ref, _ = ConstantAttitude()(0.0, None)
    tau, rates = law(0.0, QuaternionState(jnp.asarray(q), jnp.asarray(omega)), ref, state)
    qv = q[1:]
    s = omega + k * qv
    expected_tau = -0.3 * 7 * qv - 0.7 * 7 * np.tanh(s / p2)
    k_dot = -0.01 * 0.7 * 7 * qv @ (np.tanh(s / p2) + np.tanh(k * qv / p2)) - 0.01 * 1.5 * k * (
        qv @ qv + 0.1
    )
    p2_dot = -0.03 * 6 * 0.25 * 0.7 * 7 * p2 + 0.03 * 1.5 * k**2 * (qv @ qv + 0.1)
    np.testing.assert_allclose(tau, expected_tau, rtol=1e-14)
    np.testing.assert_allclose(float(rates.k), k_dot, rtol=1e-13)
    np.testing.assert_allclose(float(rates.p2), p2_dot, rtol=1e-13)


def test_sharp_alpha_bar_and_bad_gains():
    u = np.linspace(0.0, 5.0, 2_000_001)
    np.testing.assert_allclose(np.max(u * (1 - np.tanh(u))), SHARP_ALPHA_BAR, rtol=1e-11)
    assert 0.6392 * (1 - np.tanh(0.6392)) > 0.24  # (24) fails for the printed 0.24
    for kwargs, name in (
        ({"kp": 1.0}, "kp"),
        ({"kp": 0.0}, "kp"),
        ({"max_torque": 0.0}, "max_torque"),
        ({"max_torque": -1.0}, "max_torque"),
        ({"gamma_k": 0.0}, "gamma_k"),
    ):
        with pytest.raises(ValueError, match=name):
            TimeVaryingSlidingMode(**kwargs)
