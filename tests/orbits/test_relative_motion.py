"""Relative orbital motion against independent oracles: two Keplerian orbits propagated in
closed form and rotated into the target's Hill frame (nonlinear model), the closed-form
Clohessy-Wiltshire and Yamanaka-Ankersen transition matrices (linear models)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.controllers import OpenLoop
from jaxatt.orbits import (
    MU_EARTH,
    OrbitalElements,
    clohessy_wiltshire_stm,
    elements_to_state,
    hill_frame,
    hill_to_inertial,
    inertial_to_hill,
    kepler_propagate,
    mean_motion,
    state_to_elements,
    tschauner_hempel_stm,
)
from jaxatt.plants import (
    ClohessyWiltshire,
    Constant,
    RelativeOrbit,
    RelativeOrbitState,
    TschaunerHempel,
)
from jaxatt.simulation import ClosedLoop, simulate


TARGET = OrbitalElements.from_degrees(7000e3, 0.1, 51.8, 70.4, 46.5, 30.0)
RHO0 = np.array([100.0, -500.0, 200.0])
RHO_DOT0 = np.array([0.1, -0.2, 0.05])
HORIZON, DT, SAVE = 5800.0, 2.0, 100  # about one orbit (period 5828 s)
stm = jax.jit(tschauner_hempel_stm)  # compiled once, shared by the tests


@jax.jit
def keplerian_relative_states(target, rho0, rho_dot0, ts):
    """Chaser and target propagated separately by Kepler's equation, then rotated into the
    target's Hill frame at each time: the exact two-body relative motion."""
    r_t, v_t = elements_to_state(target)
    r_c, v_c = hill_to_inertial(r_t, v_t, rho0, rho_dot0)
    chaser = state_to_elements(r_c, v_c)

    def at(t):
        rt, vt = elements_to_state(kepler_propagate(target, t))
        rc, vc = elements_to_state(kepler_propagate(chaser, t))
        return inertial_to_hill(rt, vt, rc, vc)

    return jax.vmap(at)(ts)


def fly(plant, rho0, rho_dot0, theta0=float(TARGET.nu)):
    loop = ClosedLoop(plant, OpenLoop(Constant(jnp.zeros(3))))
    x0 = RelativeOrbitState(jnp.asarray(theta0), jnp.asarray(rho0), jnp.asarray(rho_dot0))
    return simulate(loop, x0, 0.0, HORIZON, dt=DT, save_every=SAVE)


@pytest.fixture(scope="module")
def nonlinear():
    return fly(RelativeOrbit(TARGET.a, TARGET.e), RHO0, RHO_DOT0)


def test_nonlinear_model_matches_two_keplerian_orbits(nonlinear):
    target = OrbitalElements(*(jnp.asarray(v, dtype=float) for v in TARGET))
    rho, rho_dot = keplerian_relative_states(target, RHO0, RHO_DOT0, nonlinear.ts)
    states = nonlinear.plant_states
    # The separation grows to 2.2 km over the orbit; the models agree to 8.6e-9 m (measured;
    # the acceptance was 1e-6 m), as notebook 07 states and asserts.
    assert abs(np.max(np.linalg.norm(rho, axis=1)) - 2.2e3) < 50
    np.testing.assert_allclose(states.rho, rho, rtol=0, atol=2e-8)
    np.testing.assert_allclose(states.rho_dot, rho_dot, rtol=0, atol=1e-9)
    # The integrated true anomaly follows Kepler's equation.
    nu = jax.vmap(lambda t: kepler_propagate(TARGET, t).nu)(nonlinear.ts)
    np.testing.assert_allclose(np.unwrap(np.asarray(states.theta)), np.unwrap(nu), atol=1e-10)


def test_tschauner_hempel_plant_matches_yamanaka_ankersen():
    traj = fly(TschaunerHempel(TARGET.a, TARGET.e), RHO0, RHO_DOT0)
    x0 = np.concatenate([RHO0, RHO_DOT0])
    expected = jax.jit(jax.vmap(stm, in_axes=(None, 0, None, None)))(
        TARGET.nu, traj.ts, TARGET.a, TARGET.e
    ) @ jnp.asarray(x0)
    got = np.concatenate([traj.plant_states.rho, traj.plant_states.rho_dot], axis=1)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-7)


def test_clohessy_wiltshire_plant_matches_its_closed_form():
    a = 7178.145e3
    traj = fly(ClohessyWiltshire(a), RHO0, RHO_DOT0, theta0=0.3)
    n = mean_motion(a)
    x0 = jnp.asarray(np.concatenate([RHO0, RHO_DOT0]))
    expected = jax.vmap(lambda t: clohessy_wiltshire_stm(n, t) @ x0)(traj.ts)
    got = np.concatenate([traj.plant_states.rho, traj.plant_states.rho_dot], axis=1)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-7)
    # theta advances uniformly at n.
    np.testing.assert_allclose(traj.plant_states.theta, 0.3 + n * traj.ts, rtol=1e-12)


@pytest.mark.parametrize("theta0", [0.0, 2.0])
def test_tschauner_hempel_reduces_to_clohessy_wiltshire_for_circular_orbits(theta0):
    a = 7178.145e3
    for t in (10.0, 1000.0, 9000.0):
        np.testing.assert_allclose(
            stm(theta0, t, a, 0.0),
            clohessy_wiltshire_stm(mean_motion(a), t),
            rtol=1e-9,
            atol=1e-9,
        )


@pytest.mark.parametrize("e", [0.0, 0.1, 0.6])
def test_linear_models_agree_with_exact_motion_to_second_order(e):
    """Linearisation error ~ |rho|^2: halving the separation divides it by 4."""
    target = TARGET._replace(e=e)
    t = 3000.0
    phi = stm(target.nu, t, target.a, target.e)
    errors = []
    for scale in (1.0, 0.5, 0.25):
        x0 = scale * np.concatenate([RHO0, RHO_DOT0])
        rho, rho_dot = keplerian_relative_states(
            OrbitalElements(*(jnp.asarray(v, dtype=float) for v in target)),
            x0[:3],
            x0[3:],
            jnp.array([t]),
        )
        exact = np.concatenate([rho[0], rho_dot[0]])
        errors.append(np.linalg.norm((phi @ x0)[:3] - exact[:3]))
        # Relative error small for a separation of about 0.5 km ...
        assert errors[-1] < 2e-3 * np.linalg.norm(exact[:3])
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    np.testing.assert_allclose(ratios, 4.0, rtol=0.02)  # ... and second order in it


def test_frame_conversions_round_trip_and_axes():
    r_t, v_t = elements_to_state(TARGET)
    c = hill_frame(r_t, v_t)
    np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-14)
    np.testing.assert_allclose(c[0], r_t / np.linalg.norm(r_t), atol=1e-15)
    assert np.dot(c[1], v_t) > 0  # y is along-track
    np.testing.assert_allclose(c[2], np.cross(r_t, v_t) / np.linalg.norm(np.cross(r_t, v_t)))
    r_c, v_c = hill_to_inertial(r_t, v_t, RHO0, RHO_DOT0)
    rho, rho_dot = inertial_to_hill(r_t, v_t, r_c, v_c)
    np.testing.assert_allclose(rho, RHO0, atol=1e-8)
    np.testing.assert_allclose(rho_dot, RHO_DOT0, atol=1e-11)
    # A chaser on the target's own orbit, ahead in anomaly, stays at rest in the Hill frame
    # only if the orbit is circular: check the rest state of a co-orbiting point instead.
    rho, rho_dot = inertial_to_hill(r_t, v_t, r_t, v_t)
    np.testing.assert_allclose(np.concatenate([rho, rho_dot]), 0.0, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"a": -7e6}, "`a` must be positive"),
        ({"a": 7e6, "e": 1.0}, r"`e` must lie in \[0, 1\)"),
        ({"a": 7e6, "mu": 0.0}, "`mu` must be positive"),
    ],
)
def test_bad_target_orbit_is_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        RelativeOrbit(**kwargs)


def test_mu_default_is_earth():
    assert float(RelativeOrbit(7e6).mu) == MU_EARTH
