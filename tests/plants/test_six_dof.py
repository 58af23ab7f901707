"""The 6-DOF plant against conservation laws and closed forms; its bad-input checks."""

import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.controllers import OpenLoop
from jaxatt.plants import (
    Constant,
    Proximity,
    RelativeOrbit,
    RelativeOrbitJ2,
    Sinusoid,
    SixDof,
    SixDofState,
)
from jaxatt.references import ConstantPose
from jaxatt.rotations import quat_normalize, quat_to_dcm
from jaxatt.simulation import ClosedLoop, simulate


J = jnp.array([[1000.0, -50.0, -10.0], [-50.0, 1000.0, -40.0], [-10.0, -40.0, 800.0]])


def fly(plant, x0, control=jnp.zeros(6), t1=20.0):
    loop = ClosedLoop(plant, OpenLoop(Constant(control)), ConstantPose())
    return simulate(loop, x0, 0.0, t1, dt=0.01, save_every=100)


@pytest.fixture(scope="module")
def tumbling():
    x0 = SixDofState(
        jnp.array([1.0, -2.0, 3.0]),
        jnp.array([0.3, -0.1, 0.2]),
        quat_normalize(jnp.array([0.8832, 0.3, -0.2, -0.3])),
        jnp.array([0.05, -0.1, 0.08]),
    )
    return x0, fly(SixDof(100.0, J), x0)


def test_force_free_body_moves_uniformly_while_it_tumbles(tumbling):
    """With f = 0, m V' = -m w x V keeps the inertial velocity C^T V constant."""
    x0, traj = tumbling
    v_inertial = quat_to_dcm(x0.q).T @ x0.v
    expected = np.asarray(x0.r) + np.asarray(traj.ts)[:, None] * np.asarray(v_inertial)
    np.testing.assert_allclose(traj.plant_states.r, expected, atol=1e-9)
    assert np.max(np.abs(np.asarray(traj.plant_states.v) - np.asarray(x0.v))) > 0.05  # V turns


def test_torque_free_body_keeps_its_inertial_angular_momentum(tumbling):
    _, traj = tumbling
    states = traj.plant_states
    h = np.stack([quat_to_dcm(q).T @ (J @ w) for q, w in zip(states.q, states.omega)])
    np.testing.assert_allclose(h, np.broadcast_to(h[0], h.shape), rtol=0, atol=1e-9)


def test_constant_body_force_accelerates_uniformly_with_the_time_varying_mass():
    x0 = SixDofState(jnp.zeros(3), jnp.zeros(3), jnp.array([1.0, 0, 0, 0]), jnp.zeros(3))
    plant = SixDof(100.0, J, mass_variation=Sinusoid(5.0, 0.5))
    traj = fly(plant, x0, jnp.array([10.0, 0, 0, 0, 0, 0]))
    # x'' = 10 / (100 + 5 sin 0.5 t): integrate the closed form numerically (trapezoid, fine grid).
    t = np.linspace(0, 20, 200001)
    acc = 10 / (100 + 5 * np.sin(0.5 * t))
    vel = np.concatenate([[0], np.cumsum((acc[1:] + acc[:-1]) / 2 * np.diff(t))])
    pos = np.concatenate([[0], np.cumsum((vel[1:] + vel[:-1]) / 2 * np.diff(t))])
    np.testing.assert_allclose(traj.plant_states.r[:, 0], np.interp(traj.ts, t, pos), atol=1e-6)
    np.testing.assert_allclose(traj.plant_states.r[:, 1:], 0.0, atol=1e-12)
    np.testing.assert_allclose(traj.signals["mass"], 100 + 5 * np.sin(0.5 * traj.ts))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"mass": -1.0}, "`mass` must be positive"),
        ({"mass_variation": Sinusoid(120.0, 0.5)}, "`mass_variation`"),
        (
            {"inertia_variation": Sinusoid(900.0 * jnp.eye(3), 0.1)},
            "`inertia_variation`",
        ),
    ],
)
def test_mass_or_inertia_that_can_become_non_positive_is_refused(kwargs, match):
    args = {"mass": 100.0, **kwargs}
    with pytest.raises(ValueError, match=match):
        SixDof(args.pop("mass"), J, **args)


@pytest.mark.parametrize(
    "build, match",
    [
        # a (3,) mass divided the body-frame thrust per axis: a plausible, wrong acceleration
        (lambda: Proximity(RelativeOrbit(7e6), [100.0] * 3, J), "Proximity: `mass` must be a"),
        (lambda: Proximity(RelativeOrbit(7e6), 100.0, J, i=[0.1, 0.2]), "Proximity: `i` must be"),
        (lambda: RelativeOrbitJ2(7e6, raan=[0.1] * 3), "RelativeOrbitJ2: `raan` must be a scalar"),
    ],
)
def test_proximity_and_j2_orbit_refuse_non_scalar_parameters(build, match, no_jaxtyping):
    with pytest.raises(ValueError, match=match):
        build()
