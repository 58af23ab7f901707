"""The coupled attitude-orbit error model (Zhang 2021 eq. 8, corrected) against a full inertial
simulation of both spacecraft (SPEC 003.1 [V]).

The reference differentiates the errors (5)-(7), computed from the two inertial states by
`jaxatt.orbits.relative_pose_errors`, along the inertial equations of motion of the chaser
and the target (forward-mode autodiff: exact, no finite-difference noise), and compares with
`CoupledAttitudeOrbit.vector_field`. SPEC's central differences reached 3e-6 (r_e'),
1.5e-6 (m_p v_e'), 7e-13 (J_p w_e'); autodiff lets the tolerance be rounding-level.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.orbits import MU_EARTH, OrbitalElements, elements_to_state, relative_pose_errors
from jaxatt.plants import (
    Constant,
    CoupledAttitudeOrbit,
    RelativePoseModel,
    RelativePoseState,
    Sinusoid,
    TargetState,
)
from jaxatt.rotations import mrp_kinematics_matrix, mrp_to_dcm


M_P, M_T = 100.0, 80.0
J_P = jnp.array([[15.0, 0.3, -0.2], [0.3, 14.0, 0.1], [-0.2, 0.1, 17.0]])
J_T = jnp.array([[12.0, -0.4, 0.0], [-0.4, 18.0, 0.2], [0.0, 0.2, 11.0]])
OFFSET = jnp.array([1.0, 5.0, -2.0])
F_TD = Sinusoid(jnp.array([2e-3, -1e-3, 3e-3]), 0.01, 0.3, jnp.array([1e-3, 2e-3, -1e-3]))
TAU_TD = Sinusoid(jnp.array([2e-4, 1e-4, -3e-4]), 0.02, 0.1, jnp.array([2e-4, 3e-4, 1e-4]))
F_PD = Constant(jnp.array([1e-3, -2e-3, 5e-4]))
TAU_PD = Constant(jnp.array([-1e-4, 2e-4, 3e-4]))


def rigid_inertial(t, x, mass, inertia, force, torque):
    """One spacecraft: inertial r, v; MRP attitude; body rate; body-frame force and torque."""
    r, v, sigma, omega = x
    accel = -MU_EARTH * r / jnp.linalg.norm(r) ** 3 + mrp_to_dcm(sigma).T @ force / mass
    omega_dot = jnp.linalg.solve(inertia, torque - jnp.cross(omega, inertia @ omega))
    return (v, accel, mrp_kinematics_matrix(sigma) @ omega, omega_dot)


def random_pair(seed):
    rng = np.random.default_rng(seed)
    r_t, v_t = elements_to_state(OrbitalElements.from_degrees(6800e3, 0.1, 51.8, 70.4, 46.5, 8.2))
    normal = lambda scale: scale * jnp.asarray(rng.normal(size=3))
    target = (r_t, v_t, normal(0.6), normal(0.05))
    chaser = (r_t + normal(30), v_t + normal(0.5), normal(0.6), normal(0.05))
    control = jnp.asarray(rng.normal(size=6)) * jnp.array([0.5, 0.5, 0.5, 0.05, 0.05, 0.05])
    return chaser, target, control


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_error_model_equals_the_derivative_of_the_inertial_errors(seed):
    t = 37.0
    chaser, target, u = random_pair(seed)

    def errors(chaser, target):
        e = relative_pose_errors(*chaser, *target, OFFSET)
        return e.position, e.velocity, e.attitude, e.rate

    chaser_dot = rigid_inertial(t, chaser, M_P, J_P, u[:3] + F_PD(t), u[3:] + TAU_PD(t))
    target_dot = rigid_inertial(t, target, M_T, J_T, F_TD(t), TAU_TD(t))
    _, reference = jax.jvp(errors, (chaser, target), (chaser_dot, target_dot))

    plant = CoupledAttitudeOrbit(
        RelativePoseModel(M_P, J_P, M_T, J_T, OFFSET, F_TD, TAU_TD), F_PD, TAU_PD
    )
    e = errors(chaser, target)
    state = RelativePoseState(*e, target=TargetState(*target))
    model = plant.vector_field(t, state, u)

    names = ("r_e'", "v_e'", "sigma_e'", "omega_e'")
    for name, got, want in zip(
        names, (model.position, model.velocity, model.attitude, model.rate), reference
    ):
        scale = float(jnp.max(jnp.abs(want)))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * scale + 1e-13, err_msg=name)
    for got, want in zip(jax.tree.leaves(model.target), target_dot):
        np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-20)


def test_from_chaser_inverts_the_errors():
    chaser, target, _ = random_pair(3)
    e = relative_pose_errors(*chaser, *target, OFFSET)
    state = RelativePoseState.from_chaser(
        *chaser, e.position, e.velocity, e.attitude, e.rate, OFFSET
    )
    np.testing.assert_allclose(state.target.position, target[0], rtol=1e-12)
    np.testing.assert_allclose(state.target.velocity, target[1], rtol=1e-12)
    np.testing.assert_allclose(mrp_to_dcm(state.target.attitude), mrp_to_dcm(target[2]), atol=1e-12)
    np.testing.assert_allclose(state.target.rate, target[3], atol=1e-15)


def test_table1_target_attitude_is_minus_sigma_e():
    # Zhang 2021 Table 1 with sigma_p = 0, omega_p = 0: sigma_t(0) = -sigma_e(0) (SPEC 003.5).
    sigma_e = jnp.array([0.5, -0.6, 0.7])
    omega_e = jnp.array([0.02, -0.02, 0.02])
    r_p, v_p = elements_to_state(OrbitalElements.from_degrees(6800e3, 0.1, 51.8, 70.4, 46.5, 8.2))
    state = RelativePoseState.from_chaser(
        r_p,
        v_p,
        jnp.zeros(3),
        jnp.zeros(3),
        jnp.array([20.0, -20, 20]),
        jnp.array([0.5, -0.5, 0.5]),
        sigma_e,
        omega_e,
        jnp.array([0.0, 5, 0]),
    )
    np.testing.assert_allclose(state.target.attitude, -sigma_e, atol=1e-14)
    np.testing.assert_allclose(state.target.rate, -mrp_to_dcm(sigma_e).T @ omega_e, atol=1e-16)


def test_bad_model_and_state_are_refused():
    with pytest.raises(ValueError, match="chaser_mass"):
        RelativePoseModel(0.0, J_P, M_T, J_T, OFFSET)
    with pytest.raises(ValueError, match="target_inertia"):
        RelativePoseModel(M_P, J_P, M_T, -J_T, OFFSET)
    plant = CoupledAttitudeOrbit(RelativePoseModel(M_P, J_P, M_T, J_T, OFFSET))
    chaser, target, _ = random_pair(0)
    e = relative_pose_errors(*chaser, *target, OFFSET)
    bad = RelativePoseState(
        e.position.at[0].set(jnp.nan), e.velocity, e.attitude, e.rate, TargetState(*target)
    )
    with pytest.raises(ValueError, match=r"x0\.position"):
        plant.check_state(bad)


@pytest.mark.parametrize(
    "changes, match",
    [
        # a (3,) mass divided the force per axis: a plausible, wrong acceleration
        (dict(chaser_mass=[M_P] * 3), "`chaser_mass` must be a scalar"),
        (dict(target_mass=[M_T, M_T]), "`target_mass` must be a scalar"),
        (dict(mu=[MU_EARTH] * 3), "`mu` must be a scalar"),
        # a NaN offset made every error NaN from the first step
        (dict(offset=[np.nan, 5.0, -2.0]), "`offset` must be finite"),
        (dict(offset=[np.inf, 5.0, -2.0]), "`offset` must be finite"),
    ],
)
def test_model_refuses_bad_parameters(changes, match, no_jaxtyping):
    args = dict(
        chaser_mass=M_P, chaser_inertia=J_P, target_mass=M_T, target_inertia=J_T, offset=OFFSET
    )
    with pytest.raises(ValueError, match="RelativePoseModel: " + match):
        RelativePoseModel(**{**args, **changes})
