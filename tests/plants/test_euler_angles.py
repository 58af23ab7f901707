"""RigidBodyEuler and the 3-2-1 Euler-angle rotations: checked against the quaternion plant."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt._validation import host_checked
from jaxatt.controllers import OpenLoop
from jaxatt.plants import (
    Constant,
    EulerAngleState,
    QuaternionState,
    RigidBodyEuler,
    RigidBodyQuaternion,
)
from jaxatt.rotations import (
    euler321_body_rates,
    euler321_from_dcm,
    euler321_kinematics,
    euler321_to_dcm,
    euler321_to_quat,
    quat_from_axis_angle,
    quat_multiply,
    quat_to_dcm,
    skew,
)
from jaxatt.simulation import ClosedLoop, Status, simulate

from ..helpers import J0


DIAGONAL = np.diag([10.0, 12.0, 14.0])


def _random_angles(seed: int) -> jax.Array:
    u = jax.random.uniform(jax.random.key(seed), (3,), minval=-1.0, maxval=1.0)
    return jnp.array([np.pi, 0.45 * np.pi, np.pi]) * u  # |theta| < 81 deg


def _axis(i: int) -> jax.Array:
    return jnp.eye(3)[i]


@pytest.mark.parametrize("seed", range(4))
def test_rotation_conversions_agree(seed):
    angles = _random_angles(seed)
    dcm = euler321_to_dcm(angles)
    # Independent: three elementary quaternions composed by hand.
    phi, theta, psi = angles
    q = quat_multiply(
        quat_multiply(quat_from_axis_angle(_axis(2), psi), quat_from_axis_angle(_axis(1), theta)),
        quat_from_axis_angle(_axis(0), phi),
    )
    np.testing.assert_allclose(euler321_to_quat(angles), q, atol=1e-15)
    np.testing.assert_allclose(quat_to_dcm(q), dcm, atol=1e-15)
    np.testing.assert_allclose(dcm @ dcm.T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(euler321_from_dcm(dcm), angles, atol=1e-13)


@pytest.mark.parametrize("seed", range(4))
def test_kinematics_match_the_rotation_matrix_rate(seed):
    """d/dt C(a(t)) along a' = R(a) w equals -[w x] C (the DCM kinematics), to 1e-13."""
    angles = _random_angles(seed)
    omega = jax.random.normal(jax.random.key(100 + seed), (3,))
    angle_rates = euler321_kinematics(angles, omega)
    dcm, dcm_dot = jax.jvp(euler321_to_dcm, (angles,), (angle_rates,))
    np.testing.assert_allclose(dcm_dot, -skew(omega) @ dcm, atol=1e-13)
    np.testing.assert_allclose(euler321_body_rates(angles, angle_rates), omega, atol=1e-14)


@pytest.mark.parametrize("inertia", [DIAGONAL, J0], ids=["diagonal", "full"])
def test_vector_field_matches_the_quaternion_rigid_body(inertia):
    """Mapped through q(a), the Euler plant's vector field is the quaternion plant's."""
    disturbance = Constant(jnp.array([0.01, -0.02, 0.03]))
    euler = RigidBodyEuler(jnp.asarray(inertia), disturbance)
    quaternion = RigidBodyQuaternion(jnp.asarray(inertia), disturbance=disturbance)
    for seed in range(3):
        state = EulerAngleState(
            _random_angles(seed), jax.random.normal(jax.random.key(10 + seed), (3,))
        )
        torque = jax.random.normal(jax.random.key(20 + seed), (3,))
        t = jnp.asarray(0.3)
        x_dot = euler.vector_field(t, state, torque)
        q, q_dot = jax.jvp(euler321_to_quat, (state.angles,), (x_dot.angles,))
        reference = quaternion.vector_field(t, QuaternionState(q, state.omega), torque)
        np.testing.assert_allclose(q_dot, reference.q, atol=1e-13)
        np.testing.assert_allclose(x_dot.omega, reference.omega, rtol=1e-13, atol=1e-13)


def _energy_rate(plant, state):
    omega_dot = plant.vector_field(0.0, state, jnp.zeros(3)).omega
    return state.omega @ (plant.body.inertia @ omega_dot)


def test_literal_printed_r_equation_breaks_energy_conservation():
    """Erratum: torque-free Euler conserves 0.5 w^T J w; the printed 'p r' in r' does not."""
    state = EulerAngleState(jnp.array([0.1, 0.2, 0.3]), jnp.array([0.3, -0.2, 0.5]))
    correct = RigidBodyEuler(jnp.asarray(DIAGONAL))
    literal = RigidBodyEuler(jnp.asarray(DIAGONAL), literal=True)
    assert abs(_energy_rate(correct, state)) < 1e-15
    # Printed minus correct r' = (Jx - Jy)/Jz (p r - p q); times Jz r:
    p, q, r = state.omega
    expected = (DIAGONAL[0, 0] - DIAGONAL[1, 1]) * (p * r - p * q) * r
    np.testing.assert_allclose(_energy_rate(literal, state), expected, rtol=1e-13)
    assert abs(expected) > 1e-2


def test_gimbal_lock_is_reported_never_nan():
    plant = RigidBodyEuler(jnp.asarray(DIAGONAL))
    locked = EulerAngleState(jnp.array([0.2, np.pi / 2, 0.1]), jnp.array([0.1, 0.2, 0.3]))
    assert not bool(plant.valid(0.0, locked))
    assert bool(plant.valid(0.0, EulerAngleState(jnp.array([0.2, 1.5, 0.1]), locked.omega)))
    assert not bool(plant.valid(0.0, EulerAngleState(jnp.array([0.2, 1.6, 0.1]), locked.omega)))
    assert np.all(np.isfinite(plant.vector_field(0.0, locked, jnp.zeros(3)).angles))
    # Torque-free pitch rotation theta = 1.4 + 0.5 t crosses pi/2 at t = 0.34159 s; the first
    # completed step after it (dt = 0.01) is t = 0.35 s, where theta = 1.575 > pi/2.
    x0 = EulerAngleState(jnp.array([0.0, 1.4, 0.0]), jnp.array([0.0, 0.5, 0.0]))
    loop = ClosedLoop(plant, OpenLoop(Constant(jnp.zeros(3))))
    traj = simulate(loop, x0, 0.0, 0.5, dt=0.01, throw=False)
    assert int(traj.status) == Status.invalid_plant
    np.testing.assert_allclose(float(traj.failure_time), 0.35, atol=1e-12)
    assert all(np.all(np.isfinite(np.asarray(v))) for v in traj.signals.values())
    assert np.all(np.isfinite(np.asarray(traj.states.plant.angles)))


@pytest.mark.parametrize(
    "build, needle",
    [
        (
            lambda: RigidBodyEuler(jnp.asarray(DIAGONAL)).check_state(
                EulerAngleState(jnp.array([0.0, -np.pi / 2, 0.0]), jnp.zeros(3))
            ),
            "RigidBodyEuler: `x0.angles` has the pitch theta at or beyond the Euler-angle "
            "singularity",
        ),
        (lambda: RigidBodyEuler(-jnp.eye(3)), "`inertia` must be a symmetric positive-definite"),
        (
            lambda: RigidBodyEuler(jnp.asarray(J0), literal=True),
            "RigidBodyEuler: `literal=True` (the slide's printed r' equation) is written for a "
            "diagonal inertia",
        ),
        (
            lambda: RigidBodyEuler(jnp.eye(3), gimbal_margin=0.0),
            "RigidBodyEuler: `gimbal_margin` must lie in (0.0, 1.0)",
        ),
        (  # a (2,) margin broadcast against cos(theta): two answers to "valid"
            lambda: RigidBodyEuler(jnp.eye(3), gimbal_margin=jnp.array([0.1, 0.2])),
            "RigidBodyEuler: `gimbal_margin` must be a scalar",
        ),
    ],
)
def test_bad_euler_plant_input_raises(build, needle, no_jaxtyping):
    with pytest.raises(ValueError) as info:
        build()
    assert needle in str(info.value)


def test_literal_plant_builds_under_vmap():
    """The diagonal-inertia check of `literal=True` converted a traced inertia to NumPy (a
    TracerArrayConversionError); a traced inertia is now left unchecked, like every check.
    (`eval_shape`: traced as `vmap` would, without running.)"""
    inertias = jax.ShapeDtypeStruct((2, 3, 3), jnp.float64)
    with host_checked():  # as in jaxatt's own programs: no run-time check to attach
        build = eqx.filter_vmap(lambda j: RigidBodyEuler(j, literal=True))
        plants = jax.eval_shape(build, inertias)
    assert plants.body.inertia.shape == (2, 3, 3)
