"""FT (eq. 23) and FTAC (eq. 6) of Yu et al. (2022): homogeneity, admissibility, barrier
reporting, the tracking form (eqs. 36-38, corrected sign) and gradients.

Oracles: the homogeneity identity of Definition 2, autodiff (`jax.jvp`) of the closed-loop
error signals along the vector field, and central finite differences.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxatt.simulation._simulate as simulate_module
from jaxatt.controllers import (
    FiniteTimeMRP,
    ObserverCompensated,
    RateBarrierState,
    RateConstrainedFiniteTimeMRP,
)
from jaxatt.metrics import settling_time
from jaxatt.numerics import safe_norm, sig_pow
from jaxatt.observers import SuperTwistingObserver
from jaxatt.plants import Constant, MRPState, RigidBodyMRP, Sinusoid
from jaxatt.references import ConstantAttitude, IntegratedReference
from jaxatt.rotations import (
    attitude_error_mrp,
    mrp_from_quat,
    mrp_kinematics_matrix,
    mrp_to_dcm,
    quat_from_axis_angle,
)
from jaxatt.simulation import ClosedLoop, ClosedLoopState, Status, simulate


J = jnp.diag(jnp.array([0.01175, 0.01175, 0.02229]))  # Yu 2022, Table 1
J_FULL = jnp.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])
PAPER_OMEGA0 = jnp.array([-0.21, -0.23, -0.25])
PAPER_SIGMA0 = jnp.array([0.5, -0.4, 0.9])


def _ftac(**kwargs):
    return RateConstrainedFiniteTimeMRP(0.03, 0.01, 0.5, 0.4, **kwargs)


# --- the derived exponent ---------------------------------------------------------------------


@pytest.mark.parametrize("alpha1", [0.2, 0.5, 0.8])
def test_alpha2_makes_the_nominal_closed_loop_homogeneous(alpha1):
    """Definition 2 for the nominal system (11) with weights (1, (1+a1)/2), degree (a1-1)/2:
    f_i(eps^r x) = eps^(k + r_i) f_i(x) for the derived alpha2, and not for a perturbed one."""
    law = FiniteTimeMRP(0.7, 0.3, alpha1)
    assert np.isclose(float(law.alpha2), 2 * alpha1 / (1 + alpha1), rtol=1e-15)
    r1, r2, degree = 1.0, (1 + alpha1) / 2, (alpha1 - 1) / 2
    g0 = mrp_kinematics_matrix(jnp.zeros(3))

    def field(sigma, omega, alpha2):
        torque = -0.7 * g0.T @ sig_pow(sigma, alpha1) - 0.3 * sig_pow(omega, alpha2)
        return g0 @ omega, jnp.linalg.solve(J, torque)

    sigma, omega = jnp.array([0.3, -0.2, 0.1]), jnp.array([0.05, 0.02, -0.04])
    for alpha2, homogeneous in ((law.alpha2, True), (1.05 * law.alpha2, False)):
        for eps in (0.1, 0.5, 3.0):
            f1, f2 = field(sigma, omega, alpha2)
            g1, g2 = field(eps**r1 * sigma, eps**r2 * omega, alpha2)
            np.testing.assert_allclose(g1, eps ** (degree + r1) * f1, rtol=1e-12)
            same = np.allclose(g2, eps ** (degree + r2) * f2, rtol=1e-9)
            assert same == homogeneous, (alpha2, eps)


def test_alpha2_is_never_an_argument_and_gains_are_validated():
    with pytest.raises(TypeError, match="unexpected keyword argument 'alpha2'"):
        FiniteTimeMRP(0.03, 0.01, 0.5, alpha2=0.6)  # type: ignore[call-arg]
    cases = [
        (lambda: FiniteTimeMRP(-0.03, 0.01, 0.5), "k1"),
        (lambda: FiniteTimeMRP(0.03, 0.0, 0.5), "k2"),
        (lambda: FiniteTimeMRP(0.03, 0.01, 1.0), "alpha1"),
        (lambda: FiniteTimeMRP(0.03, jnp.ones(2), 0.5), "k2"),
        (lambda: FiniteTimeMRP(0.03, 0.01, 0.5, inertia=-J), "inertia"),
        (lambda: RateConstrainedFiniteTimeMRP(0.03, 0.01, 0.0, 0.4), "alpha1"),
        (lambda: RateConstrainedFiniteTimeMRP(0.03, 0.01, 0.5, 0.0), "rate_limit"),
        (lambda: _ftac(guard=1.0), "guard"),
    ]
    for make, name in cases:
        with pytest.raises(ValueError, match=f"`{name}`"):
            make()


# --- admissibility and the barrier -------------------------------------------------------------


def test_paper_initial_rate_is_inadmissible_with_the_numbers_in_the_message():
    """SPEC 004.2: chi(omega(0)) = 0.25975 > 0.4^(5/3) = 0.21715 although |omega_i| < M."""
    law = _ftac()
    chi = np.sum(np.abs(np.asarray(PAPER_OMEGA0)) ** (5 / 3))
    assert np.isclose(chi, 0.25975, atol=1e-5) and np.isclose(0.4 ** (5 / 3), 0.21715, atol=1e-5)
    np.testing.assert_allclose(float(law.chi(PAPER_OMEGA0)), chi, rtol=1e-13)
    x0 = MRPState(PAPER_SIGMA0, PAPER_OMEGA0)
    reference, _ = ConstantAttitude()(0.0, None)
    with pytest.raises(ValueError, match=r"chi\(v\(0\)\) = 0\.2597.*0\.21715.*allow_inadmissible"):
        law.check_initial(0.0, x0, reference)
    # |v_i| < M on every axis is not enough (the theorem's printed hypothesis):
    with pytest.raises(ValueError, match="outside the admissible set"):
        law.check_initial(0.0, MRPState(jnp.zeros(3), jnp.full(3, 0.39)), reference)
    assert not bool(law.inside_barrier(x0, reference))
    _ftac(allow_inadmissible=True).check_initial(0.0, x0, reference)  # the opt-out: no error
    state = _ftac(allow_inadmissible=True).init(0.0, x0, reference)
    assert float(state.time_inside) == 0.0
    inside = MRPState(PAPER_SIGMA0, 0.85 * PAPER_OMEGA0)
    assert bool(law.inside_barrier(inside, reference))
    law.check_initial(0.0, inside, reference)  # no error


def test_an_inadmissible_start_through_simulate_raises_before_anything_runs(monkeypatch):
    # Regression: `init` only raised on concrete values, and inside `simulate` it is traced, so
    # the paper's state ran the whole horizon and failed afterwards with a generic message.
    def must_not_run(*args, **kwargs):
        raise AssertionError("simulate compiled or ran the loop before refusing the start")

    monkeypatch.setattr(simulate_module, "compiled", lambda *args: must_not_run)
    loop = ClosedLoop(_plant(), _ftac())
    with pytest.raises(ValueError) as info:
        simulate(loop, MRPState(PAPER_SIGMA0, PAPER_OMEGA0), 0.0, 1.0, dt=1e-3)
    message = str(info.value)
    for needle in (
        "chi(v(0)) = 0.2597",
        "M^(1+alpha2) = 0.21715",
        "barrier ratio 1.196",
        "allow_inadmissible=True",
    ):
        assert needle in message, needle


def test_traced_init_never_raises_and_admissibility_is_per_sample():
    law = _ftac()
    reference, _ = ConstantAttitude()(0.0, None)
    x0s = MRPState(jnp.stack([PAPER_SIGMA0] * 2), jnp.stack([PAPER_OMEGA0, 0.5 * PAPER_OMEGA0]))
    states = eqx.filter_vmap(lambda x: law.init(0.0, x, reference))(x0s)
    assert states.time_inside.shape == (2,)
    admissible = eqx.filter_vmap(lambda x, s: law.admissible(0.0, x, reference, s), in_axes=(0, 0))(
        x0s, states
    )
    np.testing.assert_array_equal(admissible, [False, True])


def test_barrier_guard_keeps_everything_finite_on_and_across_the_boundary():
    law = _ftac(guard=1e-3)
    level = float(law.barrier_level)
    direction = jnp.array([0.3, -0.5, 0.8])
    scale = (level / float(law.chi(direction))) ** (1 / (1 + float(law.alpha2)))
    on_boundary = scale * direction
    np.testing.assert_allclose(float(law.barrier_ratio(on_boundary)), 1.0, rtol=1e-12)
    assert np.isclose(float(law.barrier_gain(on_boundary)), 1e3, rtol=1e-6)  # 1/guard
    assert float(law.barrier_gain(jnp.zeros(3))) == 1.0
    reference, _ = ConstantAttitude()(0.0, None)

    def torque(sigma, omega, k1, k2, alpha1, m):
        law_ = RateConstrainedFiniteTimeMRP(k1, k2, alpha1, m)
        state = law_.init(0.0, MRPState(sigma, 0.0 * omega), reference)
        return law_(0.0, MRPState(sigma, omega), reference, state)[0]

    args = (0.03, 0.01, 0.5, 0.4)
    both = jax.jit(lambda *a: (torque(*a), jax.jacfwd(torque, argnums=(0, 1, 2, 3, 4, 5))(*a)))
    for omega in (on_boundary, 1.0001 * on_boundary, jnp.zeros(3), jnp.array([0.0, 0.1, 0.0])):
        for sigma in (jnp.zeros(3), jnp.array([0.0, 0.2, -0.1])):
            value, jac = both(sigma, omega, *args)
            assert np.all(np.isfinite(value))
            for block in jac:
                assert np.all(np.isfinite(block)), (sigma, omega)


def _plant(disturbance=None):
    return RigidBodyMRP(J, disturbance=disturbance, shadow_switching=False)


def test_simulate_reports_inadmissible_starts_and_later_crossings():
    """Default: an inadmissible start is reported per sample and does not abort the batch
    (with `throw=True`, `simulate` raises on it: tests/simulation). Opt-out: the initial
    excursion is accepted, a crossing after having been inside is still reported."""
    loop = ClosedLoop(_plant(Constant(jnp.zeros(3))), _ftac())
    x0s = MRPState(jnp.stack([PAPER_SIGMA0] * 2), jnp.stack([PAPER_OMEGA0, 0.85 * PAPER_OMEGA0]))
    trajs = jax.vmap(lambda x: simulate(loop, x, 0.0, 0.4, dt=1e-3, throw=False))(x0s)
    assert trajs.status.tolist() == [Status.constraint_violated, Status.successful]
    assert trajs.failure_time.tolist() == [0.0, np.inf]  # detected at t0

    def opt_out(guard, disturbance):
        law = _ftac(guard=guard, allow_inadmissible=True)
        return ClosedLoop(_plant(Constant(disturbance)), law)

    # The paper's start, and a start at rest pushed by a constant 0.03 N m that beats a barrier
    # whose gain is capped at 1/guard = 2: one compiled, batched call over both closed loops.
    loops = jax.tree.map(
        lambda a, b: jnp.stack([a, b]),
        opt_out(1e-3, jnp.zeros(3)),
        opt_out(0.5, jnp.array([0.03, 0.0, 0.0])),
    )
    x0s = MRPState(jnp.stack([PAPER_SIGMA0, jnp.zeros(3)]), jnp.stack([PAPER_OMEGA0, jnp.zeros(3)]))
    trajs = jax.vmap(lambda lp, x: simulate(lp, x, 0.0, 0.4, dt=1e-3, throw=False))(loops, x0s)
    ratio = np.asarray(trajs.signals["barrier_ratio"][0])
    assert ratio[0] > 1.19 and np.all(ratio[ratio.size // 10 :] < 1)  # enters within 0.04 s
    assert int(trajs.status[0]) == Status.successful
    assert np.max(np.abs(trajs.plant_states.omega[1, :, 0])) > 0.4
    assert int(trajs.status[1]) == Status.constraint_violated
    # The crossing is reported when it happens (between 0 and 0.4 s), not at the start.
    assert 0.0 < float(trajs.failure_time[1]) < 0.4


# --- tracking form (eqs. 36-38) ----------------------------------------------------------------


def _tracking_loop(law, plant, observer=None):
    reference = IntegratedReference(
        quat_from_axis_angle(jnp.array([0.0, 0.6, 0.8]), 0.4),
        Sinusoid(jnp.array([0.1, -0.08, 0.06]), jnp.array([0.5, 0.7, 0.9]), jnp.array([0.0, 1, 2])),
    )
    if observer is None:
        return ClosedLoop(plant, law, reference)
    return ClosedLoop(plant, ObserverCompensated(law), reference, observer=observer)


@eqx.filter_jit
def _error_rates(loop, t, y):
    """(e, v) and their exact time derivatives along the closed-loop vector field."""

    def errors(t, y):
        signals = loop.signals(t, y, None)
        return signals["attitude_error"], signals["rate_error"]

    return jax.jvp(errors, (t, y), (jnp.ones_like(t), loop(t, y, None)))


@pytest.mark.parametrize("barrier", [True, False], ids=["FTAC", "FT"])
def test_tracking_error_dynamics_match_eq_7_with_corrected_sign(barrier):
    """With the feed-forward of eq. (38) (sign corrected), e' = G(e) v and
    J v' = -v^x J v - k1 G^T sig^a1(e) - k2 g(v) sig^a2(v) exactly (nominal plant, d = 0).
    The printed sign would leave a residual 2 J v^x R omega_d."""
    if barrier:
        law = RateConstrainedFiniteTimeMRP(0.4, 0.2, 0.6, 0.5, inertia=J_FULL)
    else:
        law = FiniteTimeMRP(0.4, 0.2, 0.6, inertia=J_FULL)
    loop = _tracking_loop(law, RigidBodyMRP(J_FULL, shadow_switching=False))
    controller_state = RateBarrierState(time_inside=jnp.zeros(())) if barrier else None
    for seed in range(3):
        k1, k2, k3 = jax.random.split(jax.random.key(seed), 3)
        q_d = jax.random.normal(k2, (4,))
        plant_state = MRPState(0.5 * jax.random.normal(k1, (3,)), 0.1 * jax.random.normal(k3, (3,)))
        y = ClosedLoopState(plant_state, q_d / jnp.linalg.norm(q_d), controller_state)
        t = jnp.asarray(0.3 + seed)

        (e, v), (e_dot, v_dot) = _error_rates(loop, t, y)
        np.testing.assert_allclose(e_dot, mrp_kinematics_matrix(e) @ v, rtol=1e-10, atol=1e-13)
        gain = law.barrier_gain(v) if barrier else 1.0
        expected = (
            -jnp.cross(v, J_FULL @ v)
            - 0.4 * mrp_kinematics_matrix(e).T @ sig_pow(e, 0.6)
            - 0.2 * gain * sig_pow(v, law.alpha2)
        )
        np.testing.assert_allclose(J_FULL @ v_dot, expected, rtol=1e-9, atol=1e-12)
        # The printed sign of J v^x R omega_d would be off by 2 J v^x R omega_d, not small here.
        reference, _ = loop.reference(t, y.reference)
        desired = mrp_to_dcm(e) @ reference.omega_d
        assert np.linalg.norm(2 * J_FULL @ jnp.cross(v, desired)) > 1e3 * 1e-9 * np.linalg.norm(
            expected
        )


def test_feedforward_vanishes_for_a_constant_reference():
    reference, _ = ConstantAttitude(quat_from_axis_angle(jnp.array([1.0, 2.0, 2.0]) / 3, 1.0))(
        0.0, None
    )
    with_ff = RateConstrainedFiniteTimeMRP(0.03, 0.01, 0.5, 0.4, inertia=J_FULL)
    without = _ftac()
    state = RateBarrierState(time_inside=jnp.zeros(()))
    for seed in range(4):
        k1, k2 = jax.random.split(jax.random.key(seed))
        x = MRPState(jax.random.normal(k1, (3,)), 0.1 * jax.random.normal(k2, (3,)))
        np.testing.assert_allclose(
            with_ff(0.0, x, reference, state)[0],
            without(0.0, x, reference, state)[0],
            rtol=1e-12,
            atol=1e-15,
        )


def test_tracking_a_sinusoidal_reference_keeps_the_rate_error_below_m():
    """Remark 3 in closed loop: FTAC + observer tracks a sinusoidal omega_d (amplitudes up to
    0.1 rad/s) on the Yu plant with its disturbance. From an initial barrier ratio of 0.8 the
    barrier engages (the ratio peaks near 0.9) and every saved |v_i| stays below M = 0.2; the
    errors converge (measured after 10 s: ||e|| < 4e-6, |v_i| < 3.3e-4, the observer's
    chattering at dt = 1e-3 being the floor)."""
    m = 0.2
    law = RateConstrainedFiniteTimeMRP(0.2, 0.01, 0.5, m, inertia=J)
    disturbance = Sinusoid(
        jnp.array([0.002, 0.002, 0.003]),
        jnp.array([1.0, 2.0, 3.0]),
        jnp.array([5.0, 3.0 + jnp.pi / 2, 2.0]),
    )
    loop = _tracking_loop(law, _plant(disturbance), SuperTwistingObserver(J, 4.0, 2.0))
    reference, _ = loop.reference(0.0, loop.reference.init(0.0))
    sigma0 = jnp.array([0.2, -0.1, 0.15])
    e0 = attitude_error_mrp(sigma0, mrp_from_quat(reference.q_d))
    v0 = jnp.array([0.12, -0.08, 0.1])
    v0 = v0 * (0.8 * float(law.barrier_level) / float(law.chi(v0))) ** (1 / (1 + law.alpha2))
    x0 = MRPState(sigma0, v0 + mrp_to_dcm(e0) @ reference.omega_d)
    traj = simulate(loop, x0, 0.0, 12.0, dt=1e-3, save_every=10, throw=False)
    ratio = np.asarray(traj.signals["barrier_ratio"])
    v = np.asarray(traj.signals["rate_error"])
    np.testing.assert_allclose(v[0], v0, rtol=1e-12)
    assert np.isclose(ratio[0], 0.8, rtol=1e-12) and 0.85 < np.max(ratio) < 1
    assert np.max(np.abs(v)) < m
    assert bool(traj.successful)
    late = np.asarray(traj.ts) >= 10.0
    assert np.max(safe_norm(traj.signals["attitude_error"])[late]) < 1e-4
    assert np.max(np.abs(v[late])) < 1e-3
    omega_d = np.asarray(jax.vmap(loop.reference.omega_d)(traj.ts))
    assert np.max(np.abs(omega_d)) > 0.09  # the reference really moves


# --- gradients -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def convergence_time():
    """Time for ||sigma|| to stay below 1e-2 under FTAC (nominal plant, no disturbance) from an
    admissible state whose barrier is active (gain up to 8.5, ratio up to 0.88): 5.29 s."""
    x0 = MRPState(jnp.array([0.3, -0.2, 0.25]), jnp.array([0.15, 0.2, -0.1]))

    def loss(params):
        k1, k2, alpha1, m = params
        loop = ClosedLoop(_plant(), RateConstrainedFiniteTimeMRP(k1, k2, alpha1, m))
        traj = simulate(loop, x0, 0.0, 7.0, dt=2e-3, save_every=5)
        time = settling_time(traj.ts, safe_norm(traj.plant_states.sigma), 1e-2)
        return time, time

    # One compilation gives both the value and the forward-mode Jacobian.
    return jax.jit(jax.jacfwd(loss, has_aux=True))


def test_convergence_time_gradients_are_finite_and_match_finite_differences(convergence_time):
    """d T / d(k1, k2, alpha1, M), forward mode (reverse mode gives the same numbers to 1e-15;
    it is not run here because its compilation takes ~20 s). Both sides differentiate the same
    RK4 map; the settling-time crossing is interpolated, so T is smooth while the last exit
    stays between the same samples. Central differences with a relative step of 1e-6: the
    truncation error (~h^2 T''') and the rounding error (~eps T / h ~ 1e-9) measured below
    3e-7 relative, so 1e-5 leaves margin without hiding a wrong derivative."""
    params = jnp.array([0.2, 0.01, 0.5, 0.4])
    jac, t_conv = convergence_time(params)
    assert 4.0 < float(t_conv) < 6.5
    grads = np.asarray(jac)

    def loss(p):
        return float(convergence_time(p)[1])

    assert np.all(np.isfinite(grads)) and np.all(grads != 0)
    for i, name in enumerate(("k1", "k2", "alpha1", "M")):
        h = 1e-6 * float(params[i])
        step = jnp.zeros(4).at[i].set(h)
        numeric = (loss(params + step) - loss(params - step)) / (2 * h)
        assert abs(grads[i] - numeric) <= 1e-5 * abs(numeric), (name, grads[i], numeric)
