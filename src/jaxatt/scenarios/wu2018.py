r"""Wu, Song & Sun (2018): attitude-orbit coupled control for a safe approach with input
constraints (SPEC seed 001(c)) -- a documented **reconstruction**.

Wu G, Song S, Sun J. "Attitude-orbit coupled control for spacecraft safe approach with input
constraints", Control Theory & Applications 35(10):1511-1520, 2018. Equations (1)-(24) and
(27)-(37) are missing from the only text we have, so this scenario checks the properties the
paper states (safety, convergence, bounded inputs), not its figures.

**Data as printed.** Both spacecraft 100 kg; chaser disturbance force $J_2$ only; torque
disturbance $0.001[\cos nt, 2\cos nt, 3\cos nt]$ N m; zero initial relative velocity;
$r_d = [5, 0, 0]$ m; $\sigma(0) = [0.1, -0.1, 0.2]$ (printed "rad": MRPs are dimensionless);
$\omega(0) = [-0.01, 0.008, -0.01]$ rad/s; $\sigma_d = 0.01[\sin 10nt, -\cos 10nt, \sin 10nt]$
with $\omega_d = G(\sigma_d)^{-1}\dot\sigma_d$; Case 1 $r(0) = [48.5, -1.4, 0.2]$ m (inside the
corridor), Case 2 $r(0) = [50.1, 15.1, 32.1]$ m (outside, in the safe region); gains
$k_1 = k_2 = 0.5$, $k_3 = 0.9$, $\gamma = 0.6$, $k_s = 3$, $k_\eta = 1.6$, $k_h = 40$,
$P_1 = 0.01$, $P_2 = 0.09$; $a_1 = 48.9$, $a_2 = 49$, $a_3 = 50$ m, $\theta = \pi/90$.

**Reconstruction choices (each with its reason).**
1. *Form of h*: the product form of SPEC finding 8 ([`jaxatt.safety.CollisionAvoidance`][]):
   keep-out sphere $a_3 = 50$ m (the radius the printed c's pin; the text says $a_1$), a 2 deg
   *cone* corridor (SPEC decision; the cissoid is available), the C$^1$ cubic on
   $[a_1, a_2]$ with $c_1..c_4$ recomputed in float64; beyond $x = a_2$ (undetermined in
   the paper) $h = \bar C^2 + a_3^2(x - a_2)^2 > 0$, C$^1$ at $a_2$, so the docking axis in
   front of the mouth is safe.
2. *Frames*: the target holds its LVLH attitude, so its body frame is its Hill frame
   ($x$ radial = docking axis); the chaser's position is the Hill-frame $\rho$ of
   [`jaxatt.plants.Proximity`][] (body-fixed thrust), its attitude relative to inertial space.
3. *Surface*: a fast terminal surface $s = e_2 + \mathrm{sat}_V(k_1e_1 +
   k_2\mathrm{sig}^\gamma(e_1) + b)$ ([`jaxatt.controllers.SafeApproachSlidingMode`][]), not
   the template's integral one. Measured with the printed gains: the integral surface's
   sliding dynamics $\ddot e_1 = -k_1\dot e_1 - k_2\mathrm{sig}^{0.6}(e_1)$ are underdamped
   (3.2 m overshoot from 43.5 m, 4.8 m/s$^2$ = 480 N peak), and while the barrier holds the
   chaser off the sphere the integral winds up and drives it round the sphere at a growing
   speed (19 m/s after 10 s). The velocity limit $V = 0.5$ m/s is ours: $k_1 = 0.5$ alone
   asks for 22 m/s from Case 1's 43.5 m, which no input limit of a 100 kg chaser delivers
   and no docking approach flies. It bounds the translational channel only; the attitude
   surface has no limit (`RATE_LIMIT = None`: the controller's `rate_limit`, in 1/s on the
   MRP rate error, stays unused).
4. *Avoidance term*: in the sliding variable (a velocity-level barrier, so the paper's "1/h
   bounded" argument holds on the surface), $b = k_h(1/\hat h - 1/\hat h_0)\nabla(1/\hat h)$
   on $\hat h$, $h$ normalised to a distance, with an influence distance $\hat h_0 = 2$ m so
   that $b = 0$ at $r_d$ (on the axis at 5 m, $\hat h = 2.4$ m). $k_h\nabla(1/h)$ on the raw
   $h$ (in m$^4$) cannot work: $h$ grows like $10^5 d$ at the sphere and $5\times10^2 d$ at the
   corridor wall, so no single $k_h$ both brakes the chaser in time at the sphere and leaves
   $r_d$ reachable; added to the acceleration instead (the template's placement) the chaser
   crossed $h = 0$ within 1.3 s in both cases even with 1000 N.
5. *Auxiliary system*: $\dot\eta = -k_\eta\eta + \Delta$, entering through $z = s - \eta$; the
   template's extra term $-(|s^\top\Delta| + \frac12\|\Delta\|^2)\eta/\|\eta\|^2$ (kept as
   `template_auxiliary=True`) is stiff at $\eta \to 0$: at dt = 20 ms its peak $\|\eta\|$
   in Case 2 is set by round-off, 16 in one run and 477 in the same run inside a batch
   (floating-point order), and 409 in one run after the attitude channel's velocity limit
   was removed (2026-12-05, `simulate` of `build(hold_point=True, template_auxiliary=True)`).
6. *Adaptive law*: $\dot{\hat d}_m = P_1\|s\| - P_2\hat d_m$ (sigma modification), $\hat d_m
   \tanh(z/0.01)$ in place of $\hat d_m\,\mathrm{sign}(z)$.
7. *Input limits* (not printed): 20 N per body axis and 1 N m per axis.
8. *J*: the printed matrix is asymmetric ($J_{13} = 0.5$, $J_{31} = 0.4$); we use the
   symmetric $J_{13} = J_{31} = 0.5$ (SPEC decision).
9. *Target orbit* (a, e, i, Omega lost; only $\omega = f = 0$ survive): $a = 7000$ km,
   $e = 0.001$, $i = 45$ deg, $\Omega = 30$ deg; $n = \sqrt{\mu/a^3}$. The controller models
   the Keplerian relative motion; $J_2$ on the chaser ([`jaxatt.plants.RelativeOrbitJ2`][],
   about 1.4 N at 100 kg) is the unknown disturbance.
10. *Case 2's route*: flown straight at $r_d$ the chaser stays safe but stalls on the lip of
   the corridor mouth (the 0.1 m blend between the sphere and the cone) at $r \approx 9.5$ m:
   the pull towards $r_d$ and the barrier balance, the local minimum every potential-field
   method has; and at dt = 20 ms it crossed $h = 0$ there (the barrier's rate term is stiff),
   so that run uses dt = 5 ms. Case 2 is therefore flown through a hold point on the docking
   axis, 60 m out, released at 130 s (standard rendezvous practice); the direct run is
   reported as `case2_direct`.
11. *Integration*: classic RK4, dt = 0.02 s, continuous control, horizon 300 s.
"""

import math
import pathlib
from collections.abc import Sequence
from typing import TYPE_CHECKING, ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._custom_types import RealScalarLike, Vector3Like
from ..controllers import SafeApproachSlidingMode
from ..metrics import settling_time
from ..montecarlo import run_batch
from ..orbits import MU_EARTH
from ..plants import (
    Proximity,
    ProximityState,
    QuaternionState,
    RelativeOrbit,
    RelativeOrbitJ2,
    relative_orbit_state,
)
from ..references import AbstractReference, AttitudeReference, PoseReference, TranslationReference
from ..rotations import attitude_error_quat, mrp_kinematics_matrix, quat_from_mrp, rate_error
from ..safety import CollisionAvoidance, ConeCorridor, KeepOutSphere
from ..signals import AbstractSignal
from ..simulation import ClosedLoop, Simulation, Status, Trajectory
from ._io import write_report
from ._protocol import Scenario


if TYPE_CHECKING:  # annotations only: importing jaxatt.scenarios imports no matplotlib
    import matplotlib.axes


TITLE = "Wu, Song & Sun 2018: safe approach with a collision-avoidance function (reconstructed)"
MASS = 100.0
INERTIA = ((3.06, 1.0, 0.5), (1.0, 3.0, 1.0), (0.5, 1.0, 3.95))
INERTIA_PRINTED = ((3.06, 1.0, 0.5), (1.0, 3.0, 1.0), (0.4, 1.0, 3.95))
ORBIT = {"a": 7.0e6, "e": 0.001, "i": math.radians(45.0), "raan": math.radians(30.0), "argp": 0.0}
MEAN_MOTION = math.sqrt(MU_EARTH / ORBIT["a"] ** 3)
A1, A2, A3, HALF_ANGLE = 48.9, 49.0, 50.0, math.pi / 90
PRINTED_C = (-1.452e9, 2.966e7, -2.019e5, 2.369e10)
R_D = (5.0, 0.0, 0.0)
SIGMA0 = (0.1, -0.1, 0.2)
OMEGA0 = (-0.01, 0.008, -0.01)
CASES = {"case1": (48.5, -1.4, 0.2), "case2": (50.1, 15.1, 32.1)}
GAINS = dict(k1=0.5, k2=0.5, k3=0.9, gamma=0.6, k_s=3.0, k_eta=1.6, k_h=40.0, P1=0.01, P2=0.09)
FORCE_LIMIT, TORQUE_LIMIT = 20.0, 1.0
VELOCITY_LIMIT, INFLUENCE, LENGTH = 0.5, 2.0, 10.0  # m/s (translation only), m, m
RATE_LIMIT = None  # the attitude surface's MRP-rate limit [1/s]: none
HOLD_POINT, HOLD_RELEASE = (60.0, 0.0, 0.0), 130.0
HORIZON, DT, SAVE_PERIOD = 300.0, 0.02, 0.2  # s
DIRECT_DT, DIRECT_HORIZON = 0.005, 150.0
ATTITUDE_TOLERANCE = 1e-3  # on ||sigma - sigma_d||
RATE_TOLERANCE = 1e-4  # rad/s, on ||omega - C(e) omega_d||
POSITION_TOLERANCE = 1e-2  # m, on ||P - r_d||: the Monte Carlo's "converged"
MC_SAMPLES, SHORT_MC_SAMPLES, MC_SEED = 64, 8, 2018


class TorqueDisturbance(AbstractSignal):
    r"""$0.001[\cos nt, 2\cos nt, 3\cos nt]$ N m."""

    n: float

    def __call__(self, t):
        return 0.001 * jnp.cos(self.n * t) * jnp.array([1.0, 2.0, 3.0])

    def bound(self):
        return jnp.full(3, 0.003)


class SafeApproachReference(AbstractReference):
    r"""Hold `hold` until `release` [s], then `position` (both Hill frame, m); attitude
    $\sigma_d = 0.01[\sin 10nt, -\cos 10nt, \sin 10nt]$ with $\omega_d =
    G(\sigma_d)^{-1}\dot\sigma_d$ and $\dot\omega_d$ by forward-mode autodiff. With
    `release = 0` it is the paper's constant $r_d$."""

    position: jax.Array
    hold: jax.Array
    release: jax.Array
    n: float
    output_type: ClassVar[type] = PoseReference

    def __init__(
        self,
        position: Vector3Like,
        n: RealScalarLike,
        hold: Vector3Like | None = None,
        release: RealScalarLike = 0.0,
    ):
        self.position = jnp.asarray(position, dtype=float)
        self.hold = self.position if hold is None else jnp.asarray(hold, dtype=float)
        self.release = jnp.asarray(release, dtype=float)
        self.n = float(n)

    def sigma_d(self, t: RealScalarLike) -> Float[Array, "3"]:
        w = 10.0 * self.n * t
        return 0.01 * jnp.stack([jnp.sin(w), -jnp.cos(w), jnp.sin(w)])

    def omega_d(self, t: RealScalarLike) -> Float[Array, "3"]:
        sigma, sigma_dot = jax.jvp(self.sigma_d, (t,), (jnp.ones_like(t),))
        # G^-1 = G^T / ((1 + |sigma|^2)/4)^2 (G G^T is that multiple of I): no LAPACK solve
        g = mrp_kinematics_matrix(sigma)
        return g.T @ sigma_dot / (0.25 * (1.0 + sigma @ sigma)) ** 2

    def init(self, t0):
        return None

    def __call__(self, t, state):
        t = jnp.asarray(t, dtype=float)
        omega, omega_dot = jax.jvp(self.omega_d, (t,), (jnp.ones_like(t),))
        zero = jnp.zeros(3)
        position = jnp.where(t < self.release, self.hold, self.position)
        attitude = AttitudeReference(quat_from_mrp(self.sigma_d(t)), omega, omega_dot)
        return PoseReference(TranslationReference(position, zero, zero), attitude), None


def safety() -> CollisionAvoidance:
    """The reconstructed $h$: 50 m sphere, 2 deg cone, cubic blend on [48.9, 49] m."""
    return CollisionAvoidance(KeepOutSphere(A3), ConeCorridor(HALF_ANGLE), A1, A2)


def plant(j2: bool = True) -> Proximity:
    """The chaser (100 kg, symmetric J) about the target orbit; `j2=False` is the model the
    controller knows (Keplerian relative motion)."""
    orbit = RelativeOrbitJ2(**ORBIT) if j2 else RelativeOrbit(ORBIT["a"], ORBIT["e"])
    return Proximity(
        orbit,
        MASS,
        jnp.array(INERTIA),
        i=ORBIT["i"],
        raan=ORBIT["raan"],
        argp=ORBIT["argp"],
        torque_disturbance=TorqueDisturbance(MEAN_MOTION),
    )


def controller(avoidance: bool = True, **options) -> SafeApproachSlidingMode:
    """The safe-approach law with the printed gains and our limits (module docstring);
    `avoidance=False` sets $k_h = 0$ (same structure, so both batch in one program)."""
    settings = dict(
        GAINS,
        k_h=GAINS["k_h"] if avoidance else 0.0,
        force_limit=FORCE_LIMIT,
        torque_limit=TORQUE_LIMIT,
        velocity_limit=VELOCITY_LIMIT,
        rate_limit=RATE_LIMIT,
        influence=INFLUENCE,
        length=LENGTH,
        avoidance="surface",
    )
    settings.update(options)
    return SafeApproachSlidingMode(plant(j2=False), safety(), **settings)


def build(avoidance: bool = True, hold_point: bool = False, **options) -> ClosedLoop:
    """The closed loop: J2 plant, the law, and the reference ($r_d$, or the hold point
    `HOLD_POINT` until `HOLD_RELEASE` s with `hold_point=True`)."""
    hold = (HOLD_POINT, HOLD_RELEASE) if hold_point else (None, 0.0)
    reference = SafeApproachReference(R_D, MEAN_MOTION, *hold)
    return ClosedLoop(plant(), controller(avoidance, **options), reference)


def initial_state(position: Vector3Like) -> ProximityState:
    """The paper's start at the Hill `position` [m]: zero relative velocity, attitude
    `SIGMA0`, rate `OMEGA0`."""
    return ProximityState(
        relative_orbit_state(0.0, jnp.asarray(position, dtype=float), jnp.zeros(3)),
        QuaternionState(quat_from_mrp(jnp.array(SIGMA0)), jnp.array(OMEGA0)),
    )


def _stack(trees):
    return jax.tree_util.tree_map(lambda *xs: jnp.stack([jnp.asarray(x) for x in xs]), *trees)


@eqx.filter_jit
def _integrate_batch(loops: ClosedLoop, x0s: ProximityState, sim: Simulation) -> Trajectory:
    """One loop per sample (every array of `loops` stacked) through jaxatt's batch runner."""
    per_sample, structure = eqx.partition(loops, eqx.is_array)
    return run_batch(
        structure, x0s, sim, {}, batched=per_sample, keep_trajectories=True
    ).trajectories


def simulate_batch(
    starts: Float[ArrayLike, "*n 3"] | Sequence[Vector3Like],
    *,
    avoidance: bool | Bool[ArrayLike, "*n"] = True,
    hold_point: bool | Bool[ArrayLike, "*n"] = False,
    dt: float = DT,
    horizon: float = HORIZON,
) -> Trajectory:
    """Fly the law from each start (an (N, 3) array of Hill positions [m], zero velocity,
    the paper's attitude) in one compiled, vmapped program; `avoidance` and `hold_point` are
    one bool or one per start. Every start and the target are checked against $h > 0$ first
    (`ValueError` naming the start); a sample that reaches $h \\le 0$ gets status
    `constraint_violated` and its failure time, never NaN."""
    starts = np.asarray(starts, dtype=float).reshape(-1, 3)
    holds = np.broadcast_to(np.asarray(hold_point, dtype=bool), (len(starts),))
    avoids = np.broadcast_to(np.asarray(avoidance, dtype=bool), (len(starts),))
    loops = [build(bool(a), bool(h)) for a, h in zip(avoids, holds)]
    for k, p in enumerate(starts):
        loops[k].controller.check_initial(0.0, initial_state(p), loops[k].reference(0.0, None)[0])
    sim = Simulation(0.0, horizon, dt, save_every=max(1, round(SAVE_PERIOD / dt)))
    return _integrate_batch(_stack(loops), _stack([initial_state(p) for p in starts]), sim)


def _rate_errors(traj: Trajectory) -> np.ndarray:
    r"""$\|\omega - C(e)\,\omega_d\|$ [rad/s] at the save times of one trajectory (the
    attitude reference is the same with or without the hold point)."""
    reference = SafeApproachReference(R_D, MEAN_MOTION)

    def one(t, q, omega):
        attitude = reference(t, None)[0].attitude
        return rate_error(attitude_error_quat(q, attitude.q_d), omega, attitude.omega_d)

    attitude = traj.states.plant.attitude
    errors = jax.vmap(one)(traj.ts, attitude.q, attitude.omega)
    return np.linalg.norm(np.asarray(errors), axis=-1)


def trajectory_metrics(traj: Trajectory) -> dict:
    r"""The per-case metrics of `metrics.json` for one trajectory (host-side, NumPy).

    Settle times are last exits ([`jaxatt.metrics.settling_time`][]; `inf` if not settled):
    `attitude_settle_time` of $\|\sigma - \sigma_d\|$ from `ATTITUDE_TOLERANCE`,
    `rate_error_settle_time` of $\|\omega - C(e)\omega_d\|$ from `RATE_TOLERANCE`,
    `position_settle_time` of $\|P - r_d\|$ from `POSITION_TOLERANCE`. The paper's
    "the torques settle" and "$\hat d_m$ settles" are read from `peak_torque_last_50s` and
    `dm_hat_change_last_50s` against `dm_hat_peak`."""
    ts = np.asarray(traj.ts)
    rho = np.asarray(traj.states.plant.orbit.rho)
    h = np.asarray(traj.signals["h"])
    u = np.asarray(traj.signals["u"])
    e_sigma = np.linalg.norm(np.asarray(traj.signals["sigma_error"]), axis=-1)
    settle = float(settling_time(ts, e_sigma, ATTITUDE_TOLERANCE))
    position_error = np.linalg.norm(rho - np.array(R_D), axis=-1)
    failed = int(traj.status) != Status.successful
    d_hat = np.asarray(traj.signals["d_hat_translation"])
    last_50s = ts >= ts[-1] - 50.0
    return {
        "min_h": float(h.min()),
        "min_distance_to_target": float(np.linalg.norm(rho, axis=-1).min()),
        "final_position_error": float(np.linalg.norm(rho[-1] - np.array(R_D))),
        "position_settle_time": float(settling_time(ts, position_error, POSITION_TOLERANCE)),
        "final_velocity_error": float(
            np.linalg.norm(np.asarray(traj.states.plant.orbit.rho_dot)[-1])
        ),
        "attitude_settle_time": settle,
        "rate_error_settle_time": float(settling_time(ts, _rate_errors(traj), RATE_TOLERANCE)),
        "peak_force": float(np.abs(u[:, :3]).max()),
        "peak_torque": float(np.abs(u[:, 3:]).max()),
        "peak_torque_last_50s": float(np.abs(u[last_50s, 3:]).max()),
        "dm_hat_peak": float(d_hat.max()),
        "dm_hat_final": float(d_hat[-1]),
        "dm_hat_change_last_50s": float(np.ptp(d_hat[last_50s])),
        "dm_hat_attitude_final": float(np.asarray(traj.signals["d_hat_attitude"])[-1]),
        "eta_peak": float(np.abs(np.asarray(traj.signals["eta_translation"])).max()),
        "result": Status(int(traj.status)).name,
        "failure_time": float(traj.failure_time) if failed else None,
    }


def metrics(traj: Trajectory) -> dict:
    return trajectory_metrics(traj)


def _take(traj: Trajectory, k) -> Trajectory:
    """Sample `k` (an index or a slice) of a batched trajectory."""
    return jax.tree_util.tree_map(lambda x: x[k], traj)


def sample_corridor_starts(key: jax.Array, n: int) -> np.ndarray:
    """`n` starts in the approach corridor: $x \\sim U[20, 48.5]$ m, lateral offset uniform in
    the disc of 90 % of the cone's radius $x\\tan\\theta$ (Case 1's dispersion)."""
    kx, kr, ka = jr.split(key, 3)
    x = np.asarray(jr.uniform(kx, (n,), minval=20.0, maxval=48.5))
    r = 0.9 * x * math.tan(HALF_ANGLE) * np.sqrt(np.asarray(jr.uniform(kr, (n,))))
    a = np.asarray(jr.uniform(ka, (n,), maxval=2 * math.pi))
    return np.stack([x, r * np.cos(a), r * np.sin(a)], axis=-1)


def sample_outside_starts(key: jax.Array, n: int) -> np.ndarray:
    """`n` starts outside the keep-out sphere about Case 2: Case 2's position plus a uniform
    offset in a 10 m cube (all have $|P| > 55$ m and $h > 0$)."""
    offset = np.asarray(jr.uniform(key, (n, 3), minval=-5.0, maxval=5.0))
    return np.asarray(CASES["case2"]) + offset


def _without(traj: Trajectory) -> dict:
    """Whether one run without the avoidance term entered the keep-out set $h \\le 0$.

    `result` is the run's status name (`jaxatt.simulation.Status`). `enters_keep_out` is
    `True` if the run reached $h \\le 0$ (status `constraint_violated`, or a saved sample with
    $h \\le 0$ no later than the failure time), `False` only if the run ended successfully, and
    `None` (unknown, JSON null) if it failed another way first (e.g. `nonfinite_state`): a
    diverged run is not evidence that the chaser stayed safe. `entry_time` [s] is the failure
    time for `constraint_violated`, else the first such saved time, else `None`. `min_h` is
    over the saved samples (NaN, JSON null, if any is NaN)."""
    ts = np.asarray(traj.ts)
    h = np.asarray(traj.signals["h"])
    status = Status(int(traj.status))
    # Samples after another failure are not physical (a NaN state, an invalid plant).
    inside = (h <= 0) & (ts <= float(traj.failure_time))
    if status == Status.constraint_violated:
        entered, entry_time = True, float(traj.failure_time)
    elif inside.any():
        entered, entry_time = True, float(ts[np.argmax(inside)])
    else:
        entered = False if status == Status.successful else None
        entry_time = None
    return {
        "min_h": float(h.min()),
        "enters_keep_out": entered,
        "entry_time": entry_time,
        "result": status.name,
    }


def _rim_slide(traj: Trajectory) -> dict:
    r"""Where a run that stalls on the corridor's lip ends, and how it slides round the rim over
    the last 50 s: `final_position` [m], `azimuth_last_50s_deg` (the azimuth about the docking
    axis $x$, $\operatorname{atan2}(z, y)$ in degrees, at the window's first and last saved
    samples) and `peak_speed_last_50s` [m/s] over the saved samples."""
    ts = np.asarray(traj.ts)
    rho = np.asarray(traj.states.plant.orbit.rho)
    speed = np.linalg.norm(np.asarray(traj.states.plant.orbit.rho_dot), axis=-1)
    last_50s = ts >= ts[-1] - 50.0
    azimuth = np.degrees(np.arctan2(rho[:, 2], rho[:, 1]))[last_50s]
    return {
        "final_position": rho[-1].tolist(),
        "azimuth_last_50s_deg": [float(azimuth[0]), float(azimuth[-1])],
        "peak_speed_last_50s": float(speed[last_50s].max()),
    }


def monte_carlo_summary(traj: Trajectory, starts: np.ndarray) -> dict:
    """Fraction safe (status successful and $h > 0$ at every saved sample), the minimum $h$
    over the batch, and the fraction that is safe *and* within 1 cm of $r_d$ at the end (a
    sample that crossed $h = 0$ never counts as converged: its run went on through the
    keep-out set); `largest_final_position_error` is over the safe samples (NaN if none)."""
    h = np.asarray(traj.signals["h"])
    status = np.asarray(traj.status)
    safe = (status == Status.successful) & (h > 0).all(axis=-1)
    final = np.asarray(traj.states.plant.orbit.rho)[:, -1]
    error = np.linalg.norm(final - np.array(R_D), axis=-1)
    u = np.asarray(traj.signals["u"])
    return {
        "samples": int(len(starts)),
        "fraction_safe": float(safe.mean()),
        "min_h": float(h.min()),
        "fraction_converged": float((safe & (error < 1e-2)).mean()),
        "largest_final_position_error": float(error[safe].max()) if safe.any() else math.nan,
        "peak_force": float(np.abs(u[..., :3]).max()),
        "peak_torque": float(np.abs(u[..., 3:]).max()),
        "results": {s.name: int((status == s).sum()) for s in Status if (status == s).any()},
    }


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """Cases 1 and 2 with and without the avoidance term, Case 2's direct approach, and the
    Monte Carlo; write `metrics.json` and the figures to `out_dir`.

    `metrics.json`: `blend_coefficients` ($[c_1, c_2, c_3, c_4]$ recomputed), `printed_c`,
    `settings` (every choice), `case1` and `case2` (with the avoidance term:
    [`trajectory_metrics`][] plus `without_avoidance` {`min_h`, `enters_keep_out`,
    `entry_time`, `result`}: `enters_keep_out` is null when that run failed another way
    before reaching $h \\le 0$), `case2_direct` (Case 2 flown straight at $r_d$ with
    avoidance, at dt = 5 ms: safe, but it stalls on the corridor mouth's lip;
    [`trajectory_metrics`][] and where it slides on the rim (`final_position`,
    `azimuth_last_50s_deg`, `peak_speed_last_50s`); null with `short=True`),
    `monte_carlo` ({`corridor`, `outside`}: [`monte_carlo_summary`][]), `without_avoidance`
    (the same summary of Cases 1 and 2 without the avoidance term, as a batch).
    `short=True` (CI): 4 + 4 Monte Carlo samples, no direct run.
    """
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    n = SHORT_MC_SAMPLES // 2 if short else MC_SAMPLES // 2
    k1, k2 = jr.split(jr.key(MC_SEED))
    corridor, outside = sample_corridor_starts(k1, n), sample_outside_starts(k2, n)
    cases = [CASES["case1"], CASES["case2"]]
    starts = np.concatenate([cases, corridor, outside, cases])
    holds = np.array([False, True] + [False] * n + [True] * n + [False, False])
    avoids = np.array([True] * (2 + 2 * n) + [False, False])
    if progress:
        print(f"[wu2018] Cases 1 and 2 with and without avoidance, {2 * n} Monte Carlo starts")
    batch = simulate_batch(starts, avoidance=avoids, hold_point=holds)
    on, off = _take(batch, slice(None, -2)), _take(batch, slice(-2, None))
    direct = None
    if not short:
        if progress:
            print("[wu2018] Case 2 straight at r_d with avoidance (dt = 5 ms)")
        direct = simulate_batch([CASES["case2"]], dt=DIRECT_DT, horizon=DIRECT_HORIZON)
    metrics: dict = {
        "blend_coefficients": list(safety().blend.coefficients),
        "printed_c": list(PRINTED_C),
        "settings": {
            "force_limit_N_per_axis": FORCE_LIMIT,
            "torque_limit_Nm_per_axis": TORQUE_LIMIT,
            "velocity_limit_m_per_s_translation": VELOCITY_LIMIT,
            "rate_limit_per_s_attitude": RATE_LIMIT,
            "influence": INFLUENCE,
            "length": LENGTH,
            "gains": GAINS,
            "inertia": INERTIA,
            "orbit": ORBIT,
            "hold_point": HOLD_POINT,
            "hold_release": HOLD_RELEASE,
            "horizon": HORIZON,
            "dt": DT,
            "direct_dt": DIRECT_DT,
            "direct_horizon": DIRECT_HORIZON,
            "integrator": "RK4 (classic), continuous control",
        },
    }
    for k, case in enumerate(("case1", "case2")):
        metrics[case] = trajectory_metrics(_take(on, k))
        metrics[case]["without_avoidance"] = _without(_take(off, k))
    metrics["case2"]["route"] = "hold point"
    metrics["without_avoidance"] = monte_carlo_summary(off, np.asarray(cases))
    if direct is not None:
        one = _take(direct, 0)
        metrics["case2_direct"] = trajectory_metrics(one) | _rim_slide(one)
    else:
        metrics["case2_direct"] = None
    metrics["monte_carlo"] = {
        "seed": MC_SEED,
        "corridor": monte_carlo_summary(_take(on, slice(2, 2 + n)), corridor),
        "outside": monte_carlo_summary(_take(on, slice(2 + n, None)), outside),
    }
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    written = write_report(out / "metrics.json", metrics)
    _write_figures(out, on, off, direct, n)
    return written


def _meridian(traj_rho: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return traj_rho[..., 0], np.hypot(traj_rho[..., 1], traj_rho[..., 2])


def plot_safe_set(
    ax: "matplotlib.axes.Axes",
    *,
    x_range: tuple[RealScalarLike, RealScalarLike] = (-5.0, 70.0),
    r_max: RealScalarLike = 40.0,
    resolution: int = 600,
) -> None:
    """Shade the forbidden set $h \\le 0$ in the meridian half-plane $(x, r)$ of the target
    body frame (the set is symmetric about the docking axis $x$)."""
    xs = np.linspace(*x_range, resolution)
    rs = np.linspace(0.0, r_max, resolution // 2)
    X, R = np.meshgrid(xs, rs)
    points = jnp.stack([X.ravel(), R.ravel(), 0.0 * R.ravel()], axis=-1)
    H = np.asarray(jax.vmap(safety())(points)).reshape(X.shape)
    ax.contourf(X, R, H, levels=[-np.inf, 0.0], colors=["0.8"])
    ax.contour(X, R, H, levels=[0.0], colors=["0.3"], linewidths=0.8)
    ax.set_xlabel("x (docking axis) [m]")
    ax.set_ylabel("r = sqrt(y^2 + z^2) [m]")


def _write_figures(out: pathlib.Path, on, off, direct, n: int) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    def named(label: str, traj, k: int) -> str:  # a failed run says so in its legend entry
        return label + plot.status_label(traj.status[k], traj.failure_time[k])

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for ax, (x_range, r_max) in zip(axes, (((-5, 70), 40), ((44, 52), 12))):
        plot_safe_set(ax, x_range=x_range, r_max=r_max)
        for k, (label, style) in enumerate((("Case 1", "C0-"), ("Case 2 (hold point)", "C1-"))):
            x, r = _meridian(np.asarray(on.states.plant.orbit.rho)[k])
            ax.plot(x, r, style, label=named(label, on, k))
        for k, label in enumerate(("Case 1, no avoidance", "Case 2, no avoidance")):
            x, r = _meridian(np.asarray(off.states.plant.orbit.rho)[k])
            ax.plot(x, r, f"C{k}--", lw=0.8, label=named(label, off, k))
        if direct is not None:
            x, r = _meridian(np.asarray(direct.states.plant.orbit.rho)[0])
            ax.plot(x, r, "C3-", label=named("Case 2, direct", direct, 0))
        ax.set_xlim(*x_range)
        ax.set_ylim(0, r_max)
    axes[0].legend(fontsize=7)
    axes[0].set_title("Trajectories over the forbidden set (grey), meridian plane")
    axes[1].set_title("The corridor mouth")
    fig.tight_layout()
    fig.savefig(out / "trajectories.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    ts = np.asarray(on.ts)[0]
    for k, label in enumerate(("Case 1", "Case 2 (hold point)")):
        rho = np.asarray(on.states.plant.orbit.rho)[k]
        label = named(label, on, k)
        axes[0, 0].semilogy(ts, np.linalg.norm(rho - np.array(R_D), axis=-1), label=label)
        e = np.linalg.norm(np.asarray(on.signals["sigma_error"])[k], axis=-1)
        axes[0, 1].semilogy(ts, np.maximum(e, 1e-12), label=label)
        u = np.asarray(on.signals["u"])[k]
        axes[1, 0].plot(ts, np.abs(u[:, :3]).max(axis=-1), label=label)
        axes[1, 1].plot(ts, np.asarray(on.signals["d_hat_translation"])[k], label=label)
    axes[0, 0].set_ylabel("||P - r_d|| [m]")
    axes[0, 1].set_ylabel("||sigma - sigma_d||")
    axes[1, 0].set_ylabel("max |f_i| [N]")
    axes[1, 1].set_ylabel("d_hat_m (translation)")
    for ax in axes[1]:
        ax.set_xlabel("t [s]")
    axes[0, 0].legend()
    fig.tight_layout()
    fig.savefig(out / "errors_inputs.png", dpi=120)
    plt.close(fig)


SCENARIO = Scenario(
    name="wu2018",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=metrics,
)
