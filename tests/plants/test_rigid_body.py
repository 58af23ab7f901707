"""Rigid-body plants: conservation laws, quaternion/MRP agreement, signals, validation."""

import jax.numpy as jnp
import numpy as np
import pytest

import jaxatt
from jaxatt.controllers import OpenLoop
from jaxatt.plants import (
    Constant,
    MRPState,
    Pulse,
    QuaternionState,
    RigidBody,
    RigidBodyMRP,
    RigidBodyQuaternion,
    Sinusoid,
    Sum,
)
from jaxatt.rotations import mrp_from_quat, mrp_to_dcm, quat_to_dcm
from jaxatt.simulation import ClosedLoop, ZeroOrderHold


J_ASYM = jnp.array([[10.0, 0.5, -0.3], [0.5, 7.0, 0.2], [-0.3, 0.2, 4.0]])
OMEGA0 = jnp.array([0.3, -0.5, 0.8])
Q0 = jnp.array([0.6, 0.4, -0.5, 0.48])
Q0 = Q0 / jnp.linalg.norm(Q0)


@pytest.fixture(scope="module")
def torque_free_runs():
    """100 s torque-free tumbling of an asymmetric body, quaternion and MRP, RK4 dt 1e-3."""
    free = OpenLoop(Constant(jnp.zeros(3)))
    quat = jaxatt.simulate(
        ClosedLoop(RigidBodyQuaternion(J_ASYM), free),
        QuaternionState(Q0, OMEGA0),
        0.0,
        100.0,
        dt=1e-3,
        save_every=100,
    )
    mrp = jaxatt.simulate(
        ClosedLoop(RigidBodyMRP(J_ASYM, shadow_switching=True), free),
        MRPState(mrp_from_quat(Q0), OMEGA0),
        0.0,
        100.0,
        dt=1e-3,
        save_every=100,
    )
    return quat, mrp


def test_torque_free_energy_and_momentum_conserved(torque_free_runs):
    quat, _ = torque_free_runs
    omega = np.asarray(quat.plant_states.omega)
    J = np.asarray(J_ASYM)
    energy = 0.5 * np.einsum("ti,ij,tj->t", omega, J, omega)
    momentum = np.linalg.norm(omega @ J.T, axis=1)
    assert np.max(np.abs(energy / energy[0] - 1)) < 1e-9
    assert np.max(np.abs(momentum / momentum[0] - 1)) < 1e-9
    # The inertial angular momentum vector C^T J omega is conserved too (direction included).
    dcm = np.asarray(jnp.stack([quat_to_dcm(q) for q in quat.plant_states.q[::50]]))
    h_inertial = np.einsum("tji,tj->ti", dcm, omega[::50] @ J.T)
    assert np.max(np.abs(h_inertial - h_inertial[0])) < 1e-9 * np.linalg.norm(h_inertial[0])


def test_quaternion_norm_drift_reported_and_small(torque_free_runs):
    quat, _ = torque_free_runs
    drift = np.asarray(quat.signals["quat_norm_error"])
    direct = np.linalg.norm(np.asarray(quat.plant_states.q), axis=1) - 1
    np.testing.assert_allclose(drift, direct, atol=1e-15)
    assert np.max(np.abs(drift)) < 1e-9
    assert np.max(np.abs(drift)) > 0  # not renormalized: the drift is real and visible


def test_quaternion_and_mrp_plants_agree(torque_free_runs):
    quat, mrp = torque_free_runs
    switched = np.linalg.norm(np.asarray(mrp.plant_states.sigma), axis=1)
    assert np.all(switched <= 1 + 1e-12)  # the shadow switch kept |sigma| <= 1
    for k in range(0, quat.ts.shape[0], 25):
        np.testing.assert_allclose(
            mrp_to_dcm(mrp.plant_states.sigma[k]), quat_to_dcm(quat.plant_states.q[k]), atol=1e-9
        )
    np.testing.assert_allclose(mrp.plant_states.omega, quat.plant_states.omega, atol=1e-9)


def test_shadow_switches_are_counted_and_timed(torque_free_runs):
    """Each time the attitude passes 180 deg from the identity (q0 of the quaternion run
    changes sign), the MRP run switches to the shadow set once, after the completed step that
    left the unit ball: the event count equals the number of sign changes of q0, and each
    recorded time falls in the saved interval where q0 changed sign (for cross-checks against
    tools that count switches, e.g. Basilisk's MRPSwitchCount)."""
    quat, mrp = torque_free_runs
    q0 = np.asarray(quat.plant_states.q[:, 0])
    ts = np.asarray(quat.ts)
    changes = np.flatnonzero(np.sign(q0[1:]) != np.sign(q0[:-1]))
    record = mrp.events["shadow_switch"]
    count = int(record.count)
    assert count == changes.size and count > 5  # a tumbling body switches often
    times = np.asarray(record.times)
    kept = min(count, jaxatt.simulation.EVENT_CAPACITY)
    for k, i in enumerate(changes[:kept]):
        assert ts[i] < times[k] <= ts[i + 1], (k, times[k], ts[i], ts[i + 1])
    assert np.all(np.isnan(times[kept:]))
    # Without switching there are no events to report (and no event record).
    assert quat.events == {}


def test_an_indefinite_time_varying_inertia_fails_the_run():
    # Regression: J0 + dJ(t) was never checked, so an inertia that stopped being positive
    # definite ran to |omega| = 1e10 rad/s and was reported successful.
    swing = Sinusoid(jnp.diag(jnp.array([30.0, 0.0, 0.0])), jnp.diag(jnp.array([1.0, 0.0, 0.0])))
    plant = RigidBodyMRP(J_ASYM, inertia_perturbation=swing, shadow_switching=False)
    assert plant.body.certified_positive_definite() is False  # 30 > lambda_min(J0)
    loop = ClosedLoop(plant, OpenLoop(Constant(jnp.zeros(3))))
    x0 = MRPState(jnp.zeros(3), OMEGA0)
    traj = jaxatt.simulate(loop, x0, 0.0, 8.0, dt=0.01, throw=False)
    assert traj.status == jaxatt.Status.invalid_plant
    # The first completed step at which J(t) has a non-positive leading minor (by NumPy).
    grid = np.arange(1, 801) * 0.01
    bad = [
        t
        for t in grid
        if np.linalg.eigvalsh(np.asarray(J_ASYM) + np.diag([30 * np.sin(t), 0, 0]))[0] <= 0
    ]
    assert float(traj.failure_time) == pytest.approx(bad[0])
    with pytest.raises(jaxatt.SimulationFailed, match="invalid_plant"):
        jaxatt.simulate(loop, x0, 0.0, 8.0, dt=0.01)
    # Up front: an inertia that is not positive definite at t = 0 is refused when built.
    with pytest.raises(ValueError, match=r"J0 \+ dJ\(t\) must be positive definite"):
        RigidBody(J_ASYM, inertia_perturbation=Constant(jnp.diag(jnp.array([-11.0, 0, 0]))))
    # Chen 2022's |dJ| <= 3 < lambda_min(J0) = 14.3 is certified for every t.
    chen = Sinusoid(jnp.diag(jnp.array([1.0, 2.0, 3.0])), jnp.diag(jnp.array([0.1, 0.2, 0.3])))
    j0 = jnp.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])
    assert RigidBody(j0, chen).certified_positive_definite() is True


def test_renormalize_option_keeps_unit_norm():
    plant = RigidBodyQuaternion(J_ASYM, renormalize=True)
    traj = jaxatt.simulate(
        ClosedLoop(plant, OpenLoop(Constant(jnp.zeros(3)))),
        QuaternionState(Q0, OMEGA0),
        0.0,
        1.0,
        dt=0.05,
        save_every=20,
    )
    assert np.max(np.abs(np.asarray(traj.signals["quat_norm_error"]))) < 1e-14


def test_time_varying_inertia_and_disturbance_enter_euler_equation():
    dj = Sinusoid(jnp.diag(jnp.array([1.0, 2.0, 3.0])), jnp.diag(jnp.array([0.1, 0.2, 0.3])))
    d = Sinusoid(jnp.array([0.1, 0.2, 0.3]), jnp.array([0.1, 0.2, 0.3]))
    body = RigidBody(J_ASYM, dj, d)
    t, u = 2.5, jnp.array([0.3, -0.2, 0.1])
    J = np.asarray(J_ASYM) + np.diag([np.sin(0.25), 2 * np.sin(0.5), 3 * np.sin(0.75)])
    w = np.asarray(OMEGA0)
    torque = (
        -np.cross(w, J @ w)
        + np.asarray(u)
        + np.array([0.1, 0.2, 0.3]) * np.sin(np.array([0.1, 0.2, 0.3]) * t)
    )
    np.testing.assert_allclose(
        body.angular_acceleration(t, OMEGA0, u), np.linalg.solve(J, torque), rtol=1e-13
    )


def test_signals_compose():
    pulse = Pulse(jnp.array([1.0, 0.0, -1.0]), start=1.0, width=0.5, period=2.0)
    assert np.allclose(pulse(1.2), [1, 0, -1]) and np.allclose(pulse(1.6), 0)
    assert np.allclose(pulse(3.1), [1, 0, -1]) and np.allclose(pulse(0.5), 0)
    total = pulse + Constant(jnp.ones(3)) + Sinusoid(jnp.ones(3), 1.0, jnp.pi / 2)
    assert isinstance(total, Sum) and len(total.terms) == 3
    np.testing.assert_allclose(total(1.2), np.array([2, 1, 0]) + np.cos(1.2), rtol=1e-14)


@pytest.mark.parametrize(
    "build, needle",
    [
        (
            lambda: RigidBody(jnp.diag(jnp.array([1.0, -1.0, 2.0]))),
            "`inertia` must be a symmetric positive-definite",
        ),
        (lambda: RigidBody(jnp.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]])), "`inertia`"),
        (lambda: RigidBody(jnp.eye(2)), "`inertia` must have shape (3, 3)"),
        (
            lambda: RigidBody(jnp.eye(3), disturbance=Constant(jnp.zeros(2))),
            "`disturbance` must return arrays of shape (3,)",
        ),
        (
            lambda: RigidBody(jnp.eye(3), inertia_perturbation=Constant(jnp.zeros(3))),
            "`inertia_perturbation`",
        ),
        (lambda: Pulse(1.0, start=0.0, width=-1.0), "`width` must be positive"),
        (lambda: Pulse(1.0, start=0.0, width=1.0, period=0.5), "`period` must exceed `width`"),
        (lambda: Sinusoid(jnp.ones(3), jnp.ones(2)), "must broadcast together"),
    ],
)
def test_bad_plant_configuration_raises(build, needle):
    with pytest.raises(ValueError) as info:
        build()
    assert needle in str(info.value)


def test_a_signal_reused_across_rebuilds_is_still_shape_checked():
    """The signals' shape check is traced once per signal object (batch_field rebuilds a
    RigidBody per sample around the same signals); the cached answer still refuses a signal of
    the wrong shape, every time, and a different object of the same type is checked anew."""
    good, bad = Constant(jnp.zeros(3)), Constant(jnp.zeros(2))
    for _ in range(2):
        RigidBody(jnp.eye(3), disturbance=good)
        with pytest.raises(ValueError, match=r"`disturbance` must return arrays of shape \(3,\)"):
            RigidBody(jnp.eye(3), disturbance=bad)
        with pytest.raises(ValueError, match=r"`inertia_perturbation` must return .* \(3, 3\)"):
            RigidBody(jnp.eye(3), inertia_perturbation=good)
    RigidBody(jnp.eye(3), inertia_perturbation=Constant(jnp.zeros((3, 3))), disturbance=good)


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize(
    "build, needle",
    [
        (lambda v: RigidBodyQuaternion(jnp.eye(3), renormalize=v), "RigidBodyQuaternion"),
        (lambda v: RigidBodyMRP(jnp.eye(3), shadow_switching=v), "RigidBodyMRP"),
        (lambda v: ZeroOrderHold(0.01, delay=v), "ZeroOrderHold"),
    ],
)
def test_switches_must_be_booleans(build, needle):
    """`bool("False")` is True: a switch given as a string (or 0/1, or an array) silently chose
    the other model (e.g. `shadow_switching="False"` kept the shadow-set switch on). The
    switches of the controllers, plants, surfaces and samplings are checked alike."""
    for bad in ("False", "no", 0, 1.0, None):
        with pytest.raises(ValueError, match=rf"{needle}: `\w+` must be True or False"):
            build(bad)
    build(False), build(True), build(np.bool_(True))
