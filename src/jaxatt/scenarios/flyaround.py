r"""Fast fly-around of a target on an eccentric orbit by 6-DOF sliding-mode control
(Zhu & Yang 2009, SPEC seed 001(a): abstract only, so every number here is our choice).

Zhu Y, Yang L. "6-DOF sliding-mode control for fast fly-around", Journal of Astronautics
30(4):1482-1488, 2009 (abstract).

**Set-up (chosen, documented).**
- Target orbit: a = 7178.145 km (Zhang 2017's), e = 0.2, i = 45 deg, RAAN = 30 deg,
  argp = 30 deg, $\theta(0) = 0$ (perigee); the exact nonlinear relative motion
  ([`jaxatt.plants.RelativeOrbit`][]) with its true anomaly as a state.
- Chaser: m = 100 kg, J = diag(100, 120, 80) kg m^2, body-fixed thrust and torque
  ([`jaxatt.plants.Proximity`][]); disturbances $5\times10^{-4}[\sin 0.01t, \cos 0.01t,
  \sin 0.02t]$ m/s^2 and $10^{-3}[\cos 0.01t, \sin 0.01t, 1]$ N m, unknown to the law.
- Reference ([`jaxatt.references.FlyAround`][]): radius $R_f$ = 50 m, one revolution in
  600 s ($w_f = 2\pi/600$ rad/s), plane normal $n_f \propto (1, 0, 1)$ in the Hill frame
  (tilted 45 deg out of the orbit plane), body x axis pointing at the target.
- Law ([`jaxatt.controllers.ProximitySlidingMode`][]): translation
  `PDSurface(0.05)` + `Exponential(0.05, 1e-3, Saturation(1e-3))` on the exact model;
  attitude `SlidingModeTracking(LinearSurface(0.1), Exponential(0.2, 1e-3,
  Saturation(1e-3)), J)`. Boundary layers keep the thrust free of chattering.
- Start $\rho(0) = (-80, 30, 20)$ m, $\dot\rho(0) = (0.1, -0.2, 0)$ m/s, a 60 deg attitude
  error, $\omega(0) = (0.01, -0.01, 0.005)$ rad/s. RK4, dt = 0.1 s, continuous control,
  horizon 1200 s (two revolutions).

**Monte Carlo** (`monte_carlo_study`): 64 starts with $\rho(0)$ uniform in a 200 m cube,
$\dot\rho(0)$ in $\pm 0.5$ m/s, uniformly random attitudes and rates up to 0.02 rad/s;
reported: the worst final position error, pointing error, and the settling times.
"""

import math
import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from .._custom_types import RealScalarLike
from ..controllers import ProximitySlidingMode, SlidingModeTracking, TranslationalSlidingMode
from ..metrics import settling_time
from ..montecarlo import quaternion_states, run_batch
from ..plants import Proximity, ProximityState, QuaternionState, RelativeOrbit, RelativeOrbitState
from ..reaching import Exponential, Saturation
from ..references import FlyAround
from ..rotations import quat_from_axis_angle
from ..signals import Sinusoid
from ..simulation import ClosedLoop, EnergyMeter, Simulation, Status, Trajectory, simulate
from ..sliding import LinearSurface, PDSurface
from ._io import write_report
from ._protocol import Scenario


TITLE = (
    "Zhu & Yang 2009 (abstract): 6-DOF sliding-mode fly-around of a target on an eccentric orbit"
)
A, E = 7178.145e3, 0.2
INCLINATION, RAAN, ARGP = (math.radians(x) for x in (45.0, 30.0, 30.0))
MASS = 100.0
INERTIA = (100.0, 120.0, 80.0)
RADIUS = 50.0
RATE = 2 * math.pi / 600.0
NORMAL = (1.0, 0.0, 1.0)
HORIZON = 1200.0
SHORT_HORIZON = 200.0
DT = 0.1
SAVE_EVERY = 10
MC_SAMPLES = 64
SHORT_MC_SAMPLES = 4
POSITION_TOLERANCE = 0.1
POINTING_TOLERANCE_DEG = 1.0


def plant() -> Proximity:
    orbit = RelativeOrbit(
        A,
        E,
        disturbance=Sinusoid(
            5e-4 * jnp.ones(3), jnp.array([0.01, 0.01, 0.02]), jnp.array([0.0, math.pi / 2, 0.0])
        ),
    )
    torque = Sinusoid(
        1e-3 * jnp.array([1.0, 1.0, 0.0]),
        0.01,
        jnp.array([math.pi / 2, 0, 0]),
        1e-3 * jnp.array([0.0, 0.0, 1.0]),
    )
    return Proximity(
        orbit,
        MASS,
        jnp.diag(jnp.array(INERTIA)),
        i=INCLINATION,
        raan=RAAN,
        argp=ARGP,
        torque_disturbance=torque,
    )


def reference(radius: RealScalarLike = RADIUS) -> FlyAround:
    """The fly-around reference: a circle of `radius` [m] about the target at `RATE`."""
    return FlyAround(
        A, E, INCLINATION, RAAN, ARGP, radius=radius, rate=RATE, normal=jnp.array(NORMAL)
    )


def build(
    *,
    radius: RealScalarLike = RADIUS,
    c: RealScalarLike = 0.05,
    k: RealScalarLike = 0.05,
    lam: RealScalarLike = 0.1,
    k_att: RealScalarLike = 0.2,
) -> ClosedLoop:
    """The fly-around closed loop (gains as in the module docstring)."""
    model = plant()
    model_orbit = RelativeOrbit(A, E)  # the law knows the undisturbed relative motion
    translation = TranslationalSlidingMode(
        model_orbit, PDSurface(c), Exponential(k, 1e-3, Saturation(1e-3))
    )
    attitude = SlidingModeTracking(
        LinearSurface(lam), Exponential(k_att, 1e-3, Saturation(1e-3)), jnp.diag(jnp.array(INERTIA))
    )
    controller = ProximitySlidingMode(model, translation, attitude)
    return ClosedLoop(model, controller, reference(radius), EnergyMeter())


def initial_state() -> ProximityState:
    q = quat_from_axis_angle(jnp.array([1.0, 1.0, 0.0]) / math.sqrt(2), math.radians(60))
    return ProximityState(
        RelativeOrbitState(
            jnp.asarray(0.0), jnp.array([-80.0, 30.0, 20.0]), jnp.array([0.1, -0.2, 0.0])
        ),
        QuaternionState(q, jnp.array([0.01, -0.01, 0.005])),
    )


def run(horizon: float = HORIZON, **options) -> Trajectory:
    return simulate(build(**options), initial_state(), 0.0, horizon, dt=DT, save_every=SAVE_EVERY)


def _json(value):
    value = float(value)
    return value if math.isfinite(value) else None


def trajectory_metrics(traj: Trajectory) -> dict:
    ts = np.asarray(traj.ts)
    pos = np.asarray(traj.signals["position_norm"])
    pointing = np.degrees(np.asarray(traj.signals["pointing_error"]))
    u = np.asarray(traj.signals["u"])
    tail = ts >= 190.0
    return {
        "position_settle_time_0.1m": _json(settling_time(ts, pos, POSITION_TOLERANCE)),
        "pointing_settle_time_1deg": _json(settling_time(ts, pointing, POINTING_TOLERANCE_DEG)),
        "max_position_error_after_190s": float(np.max(pos[tail])),
        "max_pointing_error_deg_after_190s": float(np.max(pointing[tail])),
        "peak_force": float(np.max(np.abs(u[:, :3]))),
        "peak_torque": float(np.max(np.abs(u[:, 3:]))),
        "energy": float(traj.signals["energy"][-1]),
        "status": int(traj.status),
    }


def dispersed_starts(key: jax.Array, n: int) -> ProximityState:
    """`n` random starts: rho in a 200 m cube, rho' within 0.5 m/s, any attitude, |w_i| < 0.02."""
    k1, k2, k3 = jr.split(key, 3)
    att = quaternion_states(k3, n, max_rate=0.02)
    return ProximityState(
        RelativeOrbitState(
            jnp.zeros(n),
            jr.uniform(k1, (n, 3), minval=-100, maxval=100),
            jr.uniform(k2, (n, 3), minval=-0.5, maxval=0.5),
        ),
        att,
    )


@eqx.filter_jit
def _run_batch(loop: ClosedLoop, x0s: ProximityState, sim: Simulation) -> Trajectory:
    return run_batch(loop, x0s, sim, {}, keep_trajectories=True).trajectories


def simulate_batch(x0s: ProximityState, horizon: float = HORIZON) -> Trajectory:
    """Fly the law from every start of the batch `x0s` in one compiled program (jaxatt's
    batch runner, `jaxatt.montecarlo.run_batch`); the starts are checked on the host first
    and a failed sample keeps its status and failure time."""
    loop = build()
    n = jax.tree_util.tree_leaves(x0s)[0].shape[0]
    x0s = loop.check_state(x0s, "x0s", (n,))
    return _run_batch(loop, x0s, Simulation(0.0, horizon, DT, save_every=SAVE_EVERY))


def _stack(first: ProximityState, rest: ProximityState) -> ProximityState:
    return jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a[None], b]), first, rest)


def _summary(trajs: Trajectory, seed: int, horizon: float) -> dict:
    """The Monte Carlo entry of `metrics.json`: `successful` counts the samples whose run ended
    successfully. A failed sample counts at its worst: never settled, its errors unknown (its
    samples after the failure are not physical), so each `worst_*` and the median settle time
    are None (JSON null) as soon as one sample failed, never settled or has a non-finite
    error."""
    per_sample = [
        trajectory_metrics(jax.tree_util.tree_map(lambda x, k=k: x[k], trajs))
        for k in range(trajs.ts.shape[0])
    ]

    def values(key):
        def usable(m) -> bool:
            successful = m["status"] == Status.successful
            return successful and m[key] is not None and math.isfinite(m[key])

        return [m[key] if usable(m) else None for m in per_sample]

    def worst(key):
        found = values(key)
        return None if any(v is None for v in found) else max(found)

    settle = values("position_settle_time_0.1m")
    return {
        "samples": len(per_sample),
        "seed": seed,
        "horizon": horizon,
        "successful": sum(m["status"] == Status.successful for m in per_sample),
        "worst_position_settle_time": worst("position_settle_time_0.1m"),
        "median_position_settle_time": None
        if any(v is None for v in settle)
        else float(np.median(settle)),
        "worst_pointing_settle_time": worst("pointing_settle_time_1deg"),
        "worst_max_position_error_after_190s": worst("max_position_error_after_190s"),
        "worst_max_pointing_error_deg_after_190s": worst("max_pointing_error_deg_after_190s"),
    }


def monte_carlo_study(n: int = MC_SAMPLES, horizon: float = HORIZON, seed: int = 2009) -> dict:
    """Fly the law from `n` dispersed starts (one compiled, vmapped simulation)."""
    return _summary(simulate_batch(dispersed_starts(jr.key(seed), n), horizon), seed, horizon)


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """The nominal fly-around and the Monte Carlo study, simulated together (the nominal start
    is sample 0 of one vmapped batch); figures and `metrics.json`.

    `short=True` (CI): 200 s and 4 Monte Carlo samples.
    """
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    horizon = SHORT_HORIZON if short else HORIZON
    n = SHORT_MC_SAMPLES if short else MC_SAMPLES
    seed = 2009
    if progress:
        print(f"[flyaround] nominal run and {n} dispersed starts")
    trajs = simulate_batch(_stack(initial_state(), dispersed_starts(jr.key(seed), n)), horizon)
    nominal = jax.tree_util.tree_map(lambda x: x[0], trajs)
    rest = jax.tree_util.tree_map(lambda x: x[1:], trajs)
    metrics = {
        "settings": {
            "horizon": horizon,
            "dt": DT,
            "radius": RADIUS,
            "rate": RATE,
            "normal": NORMAL,
            "target": {"a": A, "e": E},
        },
        "nominal": trajectory_metrics(nominal),
        "monte_carlo": _summary(rest, seed, horizon),
    }
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    written = write_report(out / "metrics.json", metrics)
    _write_figures(out, nominal)
    return written


def _write_figures(out: pathlib.Path, traj: Trajectory) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    ts = np.asarray(traj.ts)
    rho = np.asarray(traj.plant_states.orbit.rho)
    with plot.style():
        fig = plt.figure(figsize=(10, 4.5), layout="constrained")
        ax = fig.add_subplot(1, 2, 1, projection="3d")
        ax.plot(rho[:, 0], rho[:, 1], rho[:, 2], lw=0.8)
        ax.scatter([0], [0], [0], color="k", s=10)
        ax.set_xlabel("x radial [m]")
        ax.set_ylabel("y along-track [m]")
        ax.set_zlabel("z normal [m]")
        ax.set_title(
            "Fly-around in the target's Hill frame"
            + plot.status_label(traj.status, traj.failure_time)
        )
        ax2 = fig.add_subplot(1, 2, 2)
        ax2.semilogy(
            ts, np.asarray(traj.signals["position_norm"]) + 1e-9, label="position error [m]"
        )
        ax2.semilogy(
            ts,
            np.degrees(np.asarray(traj.signals["pointing_error"])) + 1e-9,
            label="pointing error [deg]",
        )
        plot.mark_failure(ax2, traj)
        ax2.set_xlabel("t [s]")
        ax2.legend()
        fig.savefig(out / "fig_flyaround.png")
        plt.close(fig)


SCENARIO = Scenario(
    name="flyaround",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=trajectory_metrics,
)
