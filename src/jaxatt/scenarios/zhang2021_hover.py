r"""Zhang et al. (2021): short-range hover with prescribed performance (SPEC seed 003).

Zhang B. et al. "Short-range hover control for spacecraft rendezvous and docking with
prescribed performance", Journal of Nanjing University of Information Science & Technology
(Natural Science Edition) 13(1):93-101, 2021.

**System.** A chaser hovers at $p_f = [0, 5, 0]$ m in the body frame of a tumbling,
uncontrolled target: [`jaxatt.plants.CoupledAttitudeOrbit`][] (eq. 8 with SPEC 003.1's
corrections: $G(\sigma_e)$, $P_e^\top$ in $L_2$, $m_p$ on the gravity terms of $L_3$,
$C = \mathrm{blkdiag}(m_p I, J_p)$), the target propagated with it.

**Controllers** (all [`jaxatt.controllers.PoseSlidingMode`][], reaching law
`ConstantRate(eps, Saturation(phi))`):

- `"linear_smc"`, eq. (11): $c = \mathrm{diag}(0.01 I_3, 0.1 I_3)$, no envelope;
- `"ppc"`, eq. (33): $c = I_6$, exponential envelopes $\rho_i = (\rho_{i0} - 0.01)e^{-0.01t}
  + 0.01$ with $\rho_0 = (40, 1.5, 1, 0.05)$ (position, attitude, velocity, angular velocity);
- `"finite_time_ppf"`, Section 4.3: $c = I_6$, finite-time envelopes with $\rho_0$ as above,
  $\rho_\infty = (0.008, 0.003, 0.008, 0.007)$, $T = 300$ s, $\alpha = (0.8, 0.7, 0.7, 0.5)$.

**Decisions** (SPEC "Decisions taken", seed 003), each a switch of [`build`][] where it
matters:

1. Target uncontrolled, $m_t = 100$ kg, $J_t = J_p = \mathrm{diag}(15, 14, 17)$ kg m^2 (not
   printed); torque-free Euler plus the disturbances, which are the same vectors as the
   chaser's, in target axes.
2. The controllers cancel $B$ exactly **including** the true target disturbances (the
   paper's "B known"); `target_disturbance_known=False` leaves them out of the controller's
   $B$.
3. $\omega_0$ in the disturbances is the chaser's mean motion $\sqrt{\mu/a^3}$
   (= 1.1259e-3 rad/s; not defined in the paper).
4. The chaser orbit comes from the elements ($a$ = 6800 km, $e$ = 0.1, $i$ = 51.8,
   $\Omega$ = 70.4, $\omega$ = 46.5, $\theta$ = 8.2 deg, $\mu$ = 3.986004418e14), never from
   the printed inertial $r$, $v$, which contradict them (SPEC 003.5: $e$ = 0.58, perigee
   inside the Earth).
5. sgn replaced by $\mathrm{sat}(s/\phi)$; $\zeta = \varepsilon = \phi = 0.01$ for all three
   controllers (not printed). $\|C^{-1}\|$ and $\|\beta_2C^{-1}\|$ are spectral norms.
6. PPC's $\dot\rho$ term with the corrected sign $+\beta_2e_2\dot\rho_2/\rho_2$
   (`rate_term="literal"` for the printed one).
7. Finite-time envelopes with $q_i$ recomputed from $\rho_0$, $\rho_\infty$, $T$, $\alpha$
   (0.0348533, 0.012541, 0.011084, 0.0013824; SPEC's 0.034855 for $q_1$ is an arithmetic
   slip); the printed $q_i$ are infeasible (the position envelope would collapse within
   40 s). `alpha_reading="swapped"` uses
   $\alpha_3 = 0.5$, $\alpha_4 = 0.7$, which reproduces the printed $q_3$, $q_4$ exactly.
8. Table 1's "initial relative" entries are the error states $e_1(0)$, $e_2(0)$;
   $\sigma_p(0) = 0$, $\omega_p(0) = 0$, so $\sigma_t(0) = -\sigma_e(0)$ and
   $\omega_t(0) = -P_e^\top\omega_e(0)$. $\|\sigma_e(0)\| = 1.049$ (a 185.5 deg rotation);
   $\sigma_e$ is never switched to its shadow set; the target's own MRP is (it tumbles).
9. Classic RK4, dt = 0.01 s, continuous control, horizon 2000 s, saved every 0.1 s.
10. **Convergence time** (Table 2): the last time the error group leaves its tolerance
    (1e-2 m, 1e-3, 1e-3 m/s, 1e-3 rad/s), interpolated between saved samples, on the
    **infinity norm** (max |component|) of each 3-vector group; the 2-norm times are
    reported too (`*_norm2`).
"""

import pathlib

import jax
import jax.numpy as jnp
import numpy as np

from .._custom_types import Vector3Like
from ..controllers import PoseSlidingMode
from ..metrics import settling_time
from ..orbits import MU_EARTH, OrbitalElements, elements_to_state, mean_motion
from ..performance import ExponentialPerformance, FiniteTimePerformance
from ..plants import CoupledAttitudeOrbit, RelativePoseModel, RelativePoseState
from ..reaching import ConstantRate, Saturation
from ..signals import Sinusoid, Sum
from ..simulation import ClosedLoop, Simulation, Status, Trajectory, simulate
from ._io import write_report
from ._protocol import Scenario


TITLE = "Zhang 2021: hover near a tumbling target with prescribed performance (SMC/PPC/FT-PPF)"
CONTROLLERS = ("linear_smc", "ppc", "finite_time_ppf")

CHASER_MASS = 100.0
INERTIA_DIAGONAL = (15.0, 14.0, 17.0)
TARGET_MASS = 100.0
"""Not printed (decision 1)."""
OFFSET = (0.0, 5.0, 0.0)
ELEMENTS_DEG = (6800e3, 0.1, 51.8, 70.4, 46.5, 8.2)
"""$a$ [m], $e$, $i$, $\\Omega$, $\\omega$, $\\theta$ [deg]."""

POSITION_ERROR0 = (20.0, -20.0, 20.0)
VELOCITY_ERROR0 = (0.5, -0.5, 0.5)
ATTITUDE_ERROR0 = (0.5, -0.6, 0.7)
RATE_ERROR0 = (0.02, -0.02, 0.02)

ZETA = EPS = PHI = 0.01
LINEAR_SURFACE = (0.01, 0.01, 0.01, 0.1, 0.1, 0.1)
PPC_SURFACE = 1.0
"""$c = I_6$ of PPC and FT-PPF; the controllers hold it per component, (6,), as the tuned gains
of `jaxatt.scenarios.zhang2021_tuning` are, so that a tuned loop runs the paper's compiled
programs (the same structure and shapes; $1 \\cdot \\kappa_1$ is exact either way)."""
RHO0 = (40.0, 1.5, 1.0, 0.05)
"""Initial envelopes: position [m], attitude, velocity [m/s], angular velocity [rad/s]."""
PPC_RHO_INF = 0.01
PPC_RATE = (0.01, 0.01, 0.01, 0.01)
FT_RHO_INF = (0.008, 0.003, 0.008, 0.007)
FT_HORIZON = 300.0
FT_ALPHA = {"printed": (0.8, 0.7, 0.7, 0.5), "swapped": (0.8, 0.7, 0.5, 0.7)}
PRINTED_Q = (0.264, 0.0125, 0.0066, 0.0043)

HORIZON = 2000.0
DT = 0.01
SAVE_EVERY = 10
SHORT_HORIZON = 1000.0
SHORT_DT = 0.02
SHORT_SAVE_EVERY = 5

GROUPS = ("position", "attitude", "velocity", "angular_velocity")
SIGNALS = ("position_error", "attitude_error", "velocity_error", "rate_error")
TOLERANCES = (1e-2, 1e-3, 1e-3, 1e-3)
PAPER_TABLE2 = {
    "linear_smc": (935.0, 739.0, 743.0, 401.0),
    "ppc": (440.0, 389.0, 392.0, 316.0),
    "finite_time_ppf": (238.0, 273.0, 237.0, 257.0),
}
"""Table 2 [s]: position, attitude, velocity, angular velocity."""


def inertia() -> jax.Array:
    """$J_p = J_t = \\mathrm{diag}(15, 14, 17)$ kg m^2."""
    return jnp.diag(jnp.asarray(INERTIA_DIAGONAL))


def elements() -> OrbitalElements:
    """The chaser's orbital elements (Section 4)."""
    return OrbitalElements.from_degrees(*ELEMENTS_DEG)


def orbit_rate() -> float:
    """$\\omega_0 = \\sqrt{\\mu/a^3}$ [rad/s] (decision 3)."""
    return float(mean_motion(ELEMENTS_DEG[0], MU_EARTH))


def _harmonic(offset, sine, cosine, scale) -> Sum:
    """$(c + a\\sin\\omega_0 t + b\\cos\\omega_0 t) \\times$ `scale`."""
    w = orbit_rate()
    return Sum(
        (
            Sinusoid(scale * jnp.asarray(sine), w, 0.0, scale * jnp.asarray(offset)),
            Sinusoid(scale * jnp.asarray(cosine), w, jnp.pi / 2),
        )
    )


def disturbance_force() -> Sum:
    """Table 1's disturbance force [N] (on chaser and target, each in its body axes)."""
    return _harmonic((1.0, 2.0, 2.0), (-2.0, 1.0, -2.0), (-3.0, -2.0, 1.0), 1e-3)


def disturbance_torque() -> Sum:
    """Table 1's disturbance torque [N m]."""
    return _harmonic((2.0, 3.0, 1.0), (-1.0, 2.0, -3.0), (-3.0, -2.0, 2.0), 1e-4)


def model(*, target_disturbances: bool = True) -> RelativePoseModel:
    """The physical model (decision 1); without the target disturbances if asked."""
    m = RelativePoseModel(
        CHASER_MASS,
        inertia(),
        TARGET_MASS,
        inertia(),
        jnp.asarray(OFFSET),
        disturbance_force(),
        disturbance_torque(),
        MU_EARTH,
    )
    return m if target_disturbances else m.without_target_disturbances()


def plant() -> CoupledAttitudeOrbit:
    """The relative pose plant with the chaser disturbances."""
    return CoupledAttitudeOrbit(model(), disturbance_force(), disturbance_torque())


def envelope(
    name: str, *, alpha_reading: str = "printed"
) -> ExponentialPerformance | FiniteTimePerformance | None:
    """The envelope of controller `name` (`None` for the linear SMC)."""
    if name == "linear_smc":
        return None
    if name == "ppc":
        return ExponentialPerformance(jnp.asarray(RHO0), PPC_RHO_INF, jnp.asarray(PPC_RATE))
    if name == "finite_time_ppf":
        if alpha_reading not in FT_ALPHA:
            raise ValueError(
                f"zhang2021: `alpha_reading` must be one of {sorted(FT_ALPHA)}, got "
                f"{alpha_reading!r}."
            )
        return FiniteTimePerformance(
            jnp.asarray(RHO0),
            jnp.asarray(FT_RHO_INF),
            FT_HORIZON,
            jnp.asarray(FT_ALPHA[alpha_reading]),
        )
    raise ValueError(f"zhang2021: `name` must be one of {CONTROLLERS}, got {name!r}.")


def controller(
    name: str = "finite_time_ppf",
    *,
    target_disturbance_known: bool = True,
    rate_term: str = "corrected",
    alpha_reading: str = "printed",
) -> PoseSlidingMode:
    """Controller `name` with the paper's gains and the decisions of the module docstring."""
    surface = jnp.asarray(LINEAR_SURFACE) if name == "linear_smc" else jnp.full(6, PPC_SURFACE)
    return PoseSlidingMode(
        surface,
        ConstantRate(EPS, Saturation(PHI)),
        ZETA,
        model(target_disturbances=target_disturbance_known),
        envelope(name, alpha_reading=alpha_reading),
        rate_term=rate_term,
    )


def build(
    name: str = "finite_time_ppf",
    *,
    target_disturbance_known: bool = True,
    rate_term: str = "corrected",
    alpha_reading: str = "printed",
) -> ClosedLoop:
    """The closed loop of controller `name` (`"linear_smc"`, `"ppc"`, `"finite_time_ppf"`).

    **Arguments** (the switches of the module docstring's decisions):
    - `target_disturbance_known`: the controller's $B$ includes $f_{td}$, $\\tau_{td}$
      (decision 2).
    - `rate_term`: `"corrected"` or `"literal"` sign of PPC's $\\dot\\rho$ term (decision 6).
    - `alpha_reading`: `"printed"` or `"swapped"` finite-time exponents (decision 7).
    """
    return ClosedLoop(
        plant(),
        controller(
            name,
            target_disturbance_known=target_disturbance_known,
            rate_term=rate_term,
            alpha_reading=alpha_reading,
        ),
    )


def initial_state(
    position_error: Vector3Like = POSITION_ERROR0,
    velocity_error: Vector3Like = VELOCITY_ERROR0,
    attitude_error: Vector3Like = ATTITUDE_ERROR0,
    rate_error: Vector3Like = RATE_ERROR0,
) -> RelativePoseState:
    """Table 1 (decision 8): the chaser on the orbit of the elements with $\\sigma_p = 0$,
    $\\omega_p = 0$, and the given errors; the target state follows."""
    r_p, v_p = elements_to_state(elements(), MU_EARTH)
    zero = jnp.zeros(3)
    return RelativePoseState.from_chaser(
        r_p,
        v_p,
        zero,
        zero,
        jnp.asarray(position_error, dtype=float),
        jnp.asarray(velocity_error, dtype=float),
        jnp.asarray(attitude_error, dtype=float),
        jnp.asarray(rate_error, dtype=float),
        jnp.asarray(OFFSET),
    )


def simulation(*, short: bool = False) -> Simulation:
    """RK4, continuous control (decision 9); `short=True` is CI's 1000 s at dt = 0.02 s."""
    if short:
        return Simulation(0.0, SHORT_HORIZON, SHORT_DT, save_every=SHORT_SAVE_EVERY)
    return Simulation(0.0, HORIZON, DT, save_every=SAVE_EVERY)


def _simulate(loop: ClosedLoop, x0: RelativePoseState, sim: Simulation) -> Trajectory:
    """One trajectory; a failure (e.g. an envelope violation) is kept in its `status`."""
    return simulate(loop, x0, sim.t0, sim.t1, dt=sim.dt, save_every=sim.save_every, throw=False)


def run(*, short: bool = False, progress: bool = False, **options) -> dict[str, Trajectory]:
    """Simulate the three controllers from Table 1's state; `options` go to [`build`][]."""
    from tqdm import tqdm

    x0 = initial_state()
    sim = simulation(short=short)
    return {
        name: _simulate(build(name, **options), x0, sim)
        for name in tqdm(CONTROLLERS, desc="zhang2021", disable=not progress)
    }


def _group_times(ts, traj: Trajectory, norm) -> list[jax.Array]:
    return [
        settling_time(ts, norm(traj.signals[signal]), tol)
        for signal, tol in zip(SIGNALS, TOLERANCES)
    ]


def metrics(traj: Trajectory) -> dict:
    """The per-controller metrics of `metrics.json` (one unbatched trajectory).

    Settling times on the infinity norm (decision 10) and the 2-norm; peaks of the commanded
    force and torque per component; envelope violations (saved samples where some
    $|e_i| \\ge \\rho_i$ or a margin is not finite; 0 for the linear SMC, which has no
    envelope) and the minimum margin $\\min_{t,i}(\\rho_i - |e_i|)$ (None without an envelope);
    the sample's status.
    """
    ts = traj.ts
    inf_norm = lambda x: jnp.max(jnp.abs(x), axis=-1)
    two_norm = lambda x: jnp.linalg.norm(x, axis=-1)
    out: dict = {}
    for group, t_inf, t_two in zip(
        GROUPS, _group_times(ts, traj, inf_norm), _group_times(ts, traj, two_norm)
    ):
        out[f"settle_time_{group}"] = t_inf
        out[f"settle_time_{group}_norm2"] = t_two
    out["peak_force"] = jnp.max(jnp.abs(traj.signals["force"]))
    out["peak_torque"] = jnp.max(jnp.abs(traj.signals["torque"]))
    out["overshoot_x"] = _overshoot(traj.signals["position_error"][:, 0])
    if "envelope_margin" in traj.signals:
        margin = traj.signals["envelope_margin"]
        # `~(margin > 0)`, not `margin <= 0`: a NaN margin (a diverged run) is a violation.
        out["envelope_violations"] = jnp.sum(jnp.any(~(margin > 0), axis=-1))
        out["min_envelope_margin"] = jnp.min(margin)
    else:
        out["envelope_violations"] = jnp.array(0)
        out["min_envelope_margin"] = None
    out["status"] = traj.status
    out["final_position_error"] = inf_norm(traj.signals["position_error"][-1])
    return out


def _overshoot(x: jax.Array) -> jax.Array:
    """The largest excursion of `x` past zero on the side opposite to its start [m]."""
    return jnp.max(jnp.maximum(-jnp.sign(x[0]) * x, 0.0))


def _to_json(value):
    if value is None:
        return None
    arr = np.asarray(value)
    if arr.dtype.kind in "iu":
        return int(arr) if arr.ndim == 0 else [int(v) for v in arr]
    if arr.dtype == bool:
        return bool(arr)
    if arr.ndim == 0:
        v = float(arr)
        return v if np.isfinite(v) else None
    return [_to_json(v) for v in arr]


def claims(metrics: dict) -> dict:
    """The paper's claims from the reproduction's own numbers, per Table 2 column.

    `linear_slower_than_ppc[group]` and `ppc_slower_than_finite_time[group]` compare the
    infinity-norm settling times (an unsettled controller counts as infinitely slow);
    `x_overshoot_reduced_by_ppc` compares the x-position overshoot. A claim holds only if
    every run it is about has status `successful`: a diverged run, or one stopped by an
    envelope violation between saved samples, never supports one.
    """

    def t(name, group):
        v = metrics[name][f"settle_time_{group}"]
        return float("inf") if v is None else v

    def ok(*names):
        return all(metrics[n]["status"] == Status.successful for n in names)

    def smaller(a, b):  # None (a non-finite overshoot) never compares as smaller
        return a is not None and b is not None and a < b

    return {
        "linear_slower_than_ppc": {
            g: ok("linear_smc", "ppc") and t("linear_smc", g) > t("ppc", g) for g in GROUPS
        },
        "ppc_slower_than_finite_time": {
            g: ok("ppc", "finite_time_ppf") and t("ppc", g) > t("finite_time_ppf", g)
            for g in GROUPS
        },
        "x_overshoot_reduced_by_ppc": ok("linear_smc", "ppc")
        and smaller(metrics["ppc"]["overshoot_x"], metrics["linear_smc"]["overshoot_x"]),
        "envelopes_respected": ok("ppc", "finite_time_ppf")
        and all(metrics[n]["envelope_violations"] == 0 for n in ("ppc", "finite_time_ppf")),
    }


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """Simulate the three controllers, write the figures and `metrics.json` to `out_dir`.

    `metrics.json`: `{"linear_smc": {...}, "ppc": {...}, "finite_time_ppf": {...}}` (see
    [`metrics`][]), plus `paper_table2`, `claims`, `finite_time_gains` (the recomputed
    $q_i$) and `settings`.
    """
    import matplotlib.pyplot as plt

    from ._zhang2021_figures import figures

    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    trajectories = run(short=short, progress=progress)
    result = {
        name: {k: _to_json(v) for k, v in metrics(traj).items()}
        for name, traj in trajectories.items()
    }
    result["claims"] = claims(result)
    result["paper_table2"] = {
        name: dict(zip(GROUPS, times)) for name, times in PAPER_TABLE2.items()
    }
    result["finite_time_gains"] = _to_json(envelope("finite_time_ppf").gain)
    sim = simulation(short=short)
    result["settings"] = {
        "horizon": sim.t1,
        "dt": sim.dt,
        "save_period": sim.dt * sim.save_every,
        "solver": "RK4, continuous control",
        "settle_norm": "infinity norm of each 3-vector group (and 2-norm: *_norm2)",
        "tolerances": dict(zip(GROUPS, TOLERANCES)),
        "zeta_eps_phi": ZETA,
        "orbit_rate": orbit_rate(),
        "short": short,
    }
    written = write_report(out_dir / "metrics.json", result)
    for stem, fig in figures(trajectories).items():
        fig.savefig(out_dir / f"{stem}.png")
        plt.close(fig)
    return written


SCENARIO = Scenario(
    name="zhang2021",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=metrics,
)
