"""The orbit toolbox against independent references: SPEC 003.5's numbers, SciPy integration
of the two-body problem, finite differences of the gravity potential."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from jaxatt.orbits import (
    MU_EARTH,
    OrbitalElements,
    anomaly_rates,
    clohessy_wiltshire_stm,
    elements_to_state,
    hill_frame,
    j2_gravity,
    kepler_propagate,
    mean_motion,
    mean_to_true_anomaly,
    point_mass_gravity,
    relative_acceleration,
    relative_pose_errors,
    state_to_elements,
    true_to_mean_anomaly,
    tschauner_hempel_stm,
)
from jaxatt.rotations import attitude_error_mrp, mrp_to_dcm


ZHANG = OrbitalElements.from_degrees(6800e3, 0.1, 51.8, 70.4, 46.5, 8.2)


def test_elements_to_state_matches_spec_003():
    # SPEC 003.5 [V]: the elements give r = [-1.7251, 4.3718, 3.9288]e6 m, |r| = 6125.7 km,
    # v = [-5.1929, -5.4097, 3.9106]e3 m/s (4-5 printed digits).
    r, v = elements_to_state(ZHANG)
    np.testing.assert_allclose(r, [-1.7251e6, 4.3718e6, 3.9288e6], atol=0.6e2)
    np.testing.assert_allclose(v, [-5.1929e3, -5.4097e3, 3.9106e3], atol=0.6e-1)
    assert np.linalg.norm(r) == pytest.approx(6125.7e3, abs=60)


@pytest.mark.parametrize(
    "elements",
    [
        ZHANG,
        OrbitalElements.from_degrees(7178.145e3, 0.3, 98.0, 200.0, 300.0, 190.0),
        OrbitalElements.from_degrees(42164e3, 0.001, 0.5, 10.0, 20.0, 30.0),
    ],
)
def test_state_to_elements_inverts(elements):
    r, v = elements_to_state(elements)
    back = state_to_elements(r, v)
    np.testing.assert_allclose(back, elements, rtol=1e-9, atol=1e-9)


def test_circular_equatorial_orbit_has_conventional_angles():
    r, v = elements_to_state(OrbitalElements(7178145.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    back = state_to_elements(r, v)
    assert float(back.e) < 1e-12 and float(back.argp) == 0.0 and float(back.raan) == 0.0
    assert float(back.nu) == pytest.approx(1.0, abs=1e-12)  # the argument of latitude


def test_kepler_propagation_matches_numerical_integration():
    r0, v0 = elements_to_state(ZHANG)
    period = 2 * np.pi / float(mean_motion(ZHANG.a))
    dt = 0.37 * period

    def two_body(t, y):
        return np.concatenate([y[3:], -MU_EARTH * y[:3] / np.linalg.norm(y[:3]) ** 3])

    sol = solve_ivp(two_body, (0, dt), np.concatenate([r0, v0]), rtol=1e-12, atol=1e-6)
    r1, v1 = elements_to_state(kepler_propagate(ZHANG, dt))
    np.testing.assert_allclose(r1, sol.y[:3, -1], atol=1e-3)  # 1 mm after a third of an orbit
    np.testing.assert_allclose(v1, sol.y[3:, -1], atol=1e-6)


def test_gravity_is_minus_the_gradient_of_its_potential():
    r = jnp.array([-1.7e6, 4.4e6, 3.9e6])
    mu, j2, radius = MU_EARTH, 1.08262668e-3, 6378137.0

    def potential(r):  # U = mu/rho - mu J2 R^2 / (2 rho^3) (3 z^2/rho^2 - 1), a = grad U
        rho = jnp.linalg.norm(r)
        return mu / rho + mu * j2 * radius**2 / (2 * rho**3) * (1 - 3 * r[2] ** 2 / rho**2)

    total = point_mass_gravity(r) + j2_gravity(r)
    np.testing.assert_allclose(total, jax.grad(potential)(r), rtol=1e-12)


def test_bad_elements_are_refused():
    with pytest.raises(ValueError, match="eccentricity `e`"):
        elements_to_state(OrbitalElements(7e6, 1.2, 0, 0, 0, 0))
    with pytest.raises(ValueError, match="semi-major axis `a`"):
        kepler_propagate(OrbitalElements(-7e6, 0.1, 0, 0, 0, 0), 10.0)


_NAN = float("nan")
_R, _V = elements_to_state(ZHANG)


@pytest.mark.parametrize(
    ("call", "needle"),
    [
        # Each returned NaN, inf or a plausible wrong number (comment: what came back).
        (lambda: elements_to_state(ZHANG._replace(i=_NAN)), "elements_to_state: `i` must be"),
        (lambda: elements_to_state(ZHANG, 0.0), "elements_to_state: `mu` must be positive"),
        (lambda: kepler_propagate(ZHANG, _NAN), "kepler_propagate: `dt` must be finite"),  # NaN
        # a hyperbolic state: a < 0 and e > 1 returned as elements
        (lambda: state_to_elements(_R, 2 * _V), "state_to_elements: the state must be bound"),
        (lambda: state_to_elements(_R, _R / 1e3), "`r` x `v` must be non-zero"),  # e = 1
        (lambda: mean_motion(0.0), "mean_motion: the semi-major axis `a`"),  # inf
        (lambda: true_to_mean_anomaly(0.3, 1.5), "true_to_mean_anomaly: the eccentricity"),
        (lambda: mean_to_true_anomaly(0.3, -0.2), "mean_to_true_anomaly: the eccentricity"),
        (lambda: anomaly_rates(0.3, 7e6, -0.2), "anomaly_rates: the eccentricity"),  # plausible
        (lambda: anomaly_rates(0.3, 7e6, 0.1, -1.0), "anomaly_rates: `mu` must be positive"),
        (
            lambda: relative_acceleration(0.3, jnp.ones(3), jnp.ones(3), 0.0, 0.1),
            "relative_acceleration: the semi-major axis `a`",
        ),
        (lambda: tschauner_hempel_stm(0.3, 10.0, 7e6, 1.0), "tschauner_hempel_stm: the eccen"),
        (lambda: clohessy_wiltshire_stm(0.0, 10.0), "clohessy_wiltshire_stm: the mean motion"),
        (lambda: clohessy_wiltshire_stm(-1e-3, 10.0), "clohessy_wiltshire_stm: the mean motion"),
        (lambda: hill_frame(_R, _R), "hill_frame: `r_t` x `v_t` must be non-zero"),
    ],
)
def test_orbit_arguments_outside_their_domain_are_refused(call, needle):
    with pytest.raises(ValueError, match=needle):
        call()


def test_orbit_checks_leave_traced_arguments_alone():
    """Under `jit` the checks add nothing: a traced eccentricity is computed with, not checked
    (the functions run inside compiled dynamics)."""
    rates = jax.jit(lambda e: anomaly_rates(0.3, 7e6, e))(0.1)
    np.testing.assert_allclose(rates, anomaly_rates(0.3, 7e6, 0.1), rtol=1e-15)


def test_relative_pose_errors_vanish_at_the_desired_pose():
    # A chaser exactly at r_d, moving with v_d and aligned with the target has zero errors.
    rng = np.random.default_rng(0)
    sigma_t, omega_t = 0.3 * rng.normal(size=3), 0.05 * rng.normal(size=3)
    r_t, v_t = elements_to_state(ZHANG)
    offset = np.array([0.0, 5.0, 0.0])
    c_t = mrp_to_dcm(sigma_t)
    r_p = r_t + c_t.T @ offset
    v_p = v_t + c_t.T @ np.cross(omega_t, offset)
    errors = relative_pose_errors(r_p, v_p, sigma_t, omega_t, r_t, v_t, sigma_t, omega_t, offset)
    for value in errors[:4]:
        np.testing.assert_allclose(value, 0.0, atol=1e-8)
    # and sigma_e is eq. (1), P_e = C(sigma_p) C(sigma_t)^T
    sigma_p = 0.2 * rng.normal(size=3)
    errors = relative_pose_errors(r_p, v_p, sigma_p, omega_t, r_t, v_t, sigma_t, omega_t, offset)
    np.testing.assert_allclose(errors.attitude, attitude_error_mrp(sigma_p, sigma_t))
    np.testing.assert_allclose(errors.dcm, mrp_to_dcm(sigma_p) @ c_t.T, atol=1e-15)
