r"""Chen, Zhu, Tao (2022): two-phase power reaching law for quaternion attitude tracking.

Chen Q, Zhu J, Tao M. "Two-phase power reaching law based spacecraft attitude control",
Control and Decision 37(5):1145-1152, 2022 (SPEC.md, seed 000).

**Set-up (section 3).** Plant $J(t)\dot\omega = -\omega^\times J(t)\omega + u + d(t)$ with
$J(t) = J_0 + \Delta J(t)$ (the Xia et al. 2011 spacecraft), per-axis torque limit 30 N m,
$\omega(0) = 0$, initial attitudes D1 $= [0.8832, 0.3, -0.2, -0.3]$ and
D2 $= [0.1, 0.8, 0.55, 0.2179]$ (both normalized: printed norms 1.000021 and 0.99998).
Controllers, all `SlidingModeTracking` on $s = e_\omega + 5 e_v$ with the robust term
$\sigma^2 s/(\sigma\|s\| + \epsilon)$, $\sigma = 0.35$, $\epsilon = 0.01$:

- M1 (eq. 41): two-phase power law, $\rho = \eta = 1.2$, $p_1/q_1 = 31/11$, $q_2/p_2 = 5/9$;
- M2 (eq. 57): exponential law, $k_1 = 1.2$, $k_2 = 0.01$;
- M3 (eq. 58): double power law, $k_3 = 1.2$, $k_4 = 0.8$, same exponents.

**Interpretations and errata (SPEC 000):**
- E11: the desired attitude is $q_d(0) = [1, 0, 0, 0]$ propagated with
  $\omega_d = 0.05[\sin(0.01\pi t), \sin(0.02\pi t), \sin(0.03\pi t)]$ rad/s (corrected eq. 5),
  $\dot\omega_d$ analytic; so $e_\omega(0) = 0$ and $s(0) = \lambda q_v(0)$.
- E3: eq. (13) read as $\dot e_\omega = F + J_0^{-1}u + D$; the controllers know only $J_0$.
- E4: M2 and M3 include $\lambda\dot e_v$ like M1 by default; `literal=True` builds eqs.
  (57)-(58) as printed (without it).
- Robust term with the vector norm as in (41) (E10: the proof's per-axis form is
  `AxisRobustTerm`).
- Saturation per axis; continuous control; classic RK4 with dt = 1e-3 s over 30 s (the paper
  gives neither step nor horizon). `sign(0) = 0`.
"""

import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..controllers import NormRobustTerm, SlidingModeTracking
from ..metrics import chattering, control_effort, peak, settling_time
from ..montecarlo import check_batch_states, run_batch
from ..numerics import safe_norm
from ..plants import QuaternionState, RigidBodyQuaternion
from ..reaching import AbstractReachingLaw, DoublePower, Exponential, TwoPhasePower
from ..references import IntegratedReference
from ..signals import Sinusoid
from ..simulation import ClosedLoop, Saturation, Simulation, Trajectory
from ..sliding import LinearSurface
from . import _xia2011
from ._io import write_report
from ._protocol import Scenario


TITLE = "Chen 2022: two-phase power reaching law, attitude tracking (M1/M2/M3, D1/D2)"
CONTROLLERS = ("M1", "M2", "M3")
CASES = ("D1", "D2")
TORQUE_LIMIT = 30.0
HORIZON = 30.0
DT = 1e-3
SLOPE = 5.0  # lambda
RHO = ETA = 1.2
BETA = 31 / 11  # p1/q1
ALPHA = 5 / 9  # q2/p2
SIGMA, EPS = 0.35, 0.01
K1, K2, K3, K4 = 1.2, 0.01, 1.2, 0.8
TOLERANCE = 1e-3
CHATTER_WINDOW = (10.0, 30.0)


def initial_attitude(case: str) -> jax.Array:
    """The normalized initial attitude of case `"D1"` or `"D2"`."""
    if case == "D1":
        return _xia2011.initial_attitude_d1()
    if case == "D2":
        q = jnp.array([0.1, 0.8, 0.55, 0.2179])
        return q / jnp.linalg.norm(q)
    raise ValueError(f"chen2022: `case` must be 'D1' or 'D2', got {case!r}.")


def initial_state(case: str) -> QuaternionState:
    return QuaternionState(initial_attitude(case), jnp.zeros(3))


def reaching_law(controller: str) -> AbstractReachingLaw:
    """The reaching law of M1 (two-phase power), M2 (exponential) or M3 (double power)."""
    if controller == "M1":
        return TwoPhasePower(RHO, ETA, BETA, ALPHA)
    if controller == "M2":
        return Exponential(K1, K2)
    if controller == "M3":
        return DoublePower(K3, K4, BETA, ALPHA)
    raise ValueError(f"chen2022: `controller` must be 'M1', 'M2' or 'M3', got {controller!r}.")


def reference() -> IntegratedReference:
    """$q_d(0) = [1,0,0,0]$ propagated with $\\omega_d(t)$ (erratum E11)."""
    omega_d = Sinusoid(0.05 * jnp.ones(3), jnp.pi * jnp.array([0.01, 0.02, 0.03]))
    return IntegratedReference(jnp.array([1.0, 0.0, 0.0, 0.0]), omega_d)


def build(controller: str = "M1", *, literal: bool = False, saturation: bool = True) -> ClosedLoop:
    """The closed loop of controller `"M1"`, `"M2"` or `"M3"`.

    **Arguments:**
    - `literal`: M2/M3 exactly as printed in eqs. (57)-(58), without $\\lambda\\dot e_v$ (E4).
      Ignored for M1, whose eq. (41) has the term.
    - `saturation`: apply the 30 N m per-axis limit.
    """
    plant = RigidBodyQuaternion(
        _xia2011.nominal_inertia(), _xia2011.inertia_perturbation(), _xia2011.disturbance()
    )
    law = SlidingModeTracking(
        LinearSurface(SLOPE),
        reaching_law(controller),
        _xia2011.nominal_inertia(),
        NormRobustTerm(SIGMA, EPS),
        surface_feedforward=not (literal and controller != "M1"),
    )
    actuator = Saturation(TORQUE_LIMIT) if saturation else None
    return ClosedLoop(plant, law, reference(), actuator)


def simulate_cases(
    loop: ClosedLoop, x0s: QuaternionState, horizon: float = HORIZON, dt: float = DT
) -> Trajectory:
    """Simulate one closed loop from a batch of initial states (the batch runner, saving every
    step); returns the batched trajectory (failures reported in its `status`). The states
    are checked on the host first, as by `monte_carlo` (unit quaternions, finite values)."""
    sim = Simulation(0.0, horizon, dt)
    x0s, _ = check_batch_states("simulate_cases", loop, x0s)
    return _simulate_cases(loop, x0s, sim)


@eqx.filter_jit
def _simulate_cases(loop: ClosedLoop, x0s: QuaternionState, sim: Simulation) -> Trajectory:
    return run_batch(loop, x0s, sim, {}, keep_trajectories=True).trajectories


def trajectory_metrics(traj: Trajectory) -> dict[str, jax.Array]:
    """The metrics of `metrics.json` for one (unbatched) trajectory; see `reproduce`."""
    s = traj.signals["s"]
    e_v = traj.signals["attitude_error"][:, 1:]
    e_omega = traj.signals["rate_error"]
    u = traj.signals["u"]
    ts = traj.ts
    return {
        "s_settle_time": settling_time(ts, jnp.max(jnp.abs(s), axis=1), TOLERANCE),
        "s_i_settle_time": jnp.stack(
            [settling_time(ts, jnp.abs(s[:, i]), TOLERANCE) for i in range(3)]
        ),
        "ev_settle_time": settling_time(ts, safe_norm(e_v), TOLERANCE),
        "eomega_settle_time": settling_time(ts, safe_norm(e_omega), TOLERANCE),
        "peak_torque": peak(u),
        "effort": control_effort(ts, u),
        "chattering": chattering(ts, u, *CHATTER_WINDOW),
        "steady_max_abs_ev": jnp.max(jnp.abs(e_v[ts >= 20.0]), axis=0)
        if ts[-1] >= 20.0
        else jnp.full(3, jnp.nan),
        "steady_max_abs_eomega": jnp.max(jnp.abs(e_omega[ts >= 20.0]), axis=0)
        if ts[-1] >= 20.0
        else jnp.full(3, jnp.nan),
    }


def steady_state_bounds() -> dict[str, float]:
    r"""Eqs. (52)-(56) with $\theta_1, \theta_2 \to 0$ (the tightest admissible bound).

    $\zeta = \min(\epsilon/\rho, (\epsilon/\eta)^{2/(q_2/p_2 + 1)})$,
    $|e_i| \le \sqrt\zeta/\lambda$, $|e_{\omega,i}| \le 2\sqrt\zeta$. Any $\theta \in (0, 1)$
    gives a larger bound.
    """
    zeta = min(EPS / RHO, (EPS / ETA) ** (2 / (ALPHA + 1)))
    return {
        "zeta": zeta,
        "sliding": float(np.sqrt(zeta)),
        "attitude": float(np.sqrt(zeta) / SLOPE),
        "rate": float(2 * np.sqrt(zeta)),
    }


def run(
    *, horizon: float = HORIZON, dt: float = DT, literal: bool = False, progress: bool = False
) -> dict[str, Trajectory]:
    """Simulate M1, M2, M3 from D1 and D2; returns one batched trajectory per controller.

    `progress=True` shows a tqdm bar over the three controllers (one compilation each).
    """
    from tqdm import tqdm

    x0s = jax.tree_util.tree_map(
        lambda *xs: jnp.stack(xs), *[initial_state(case) for case in CASES]
    )
    trajs = {}
    for name in tqdm(CONTROLLERS, desc="chen2022", disable=not progress):
        trajs[name] = simulate_cases(build(name, literal=literal), x0s, horizon, dt)
    return trajs


def _to_json(value):
    arr = np.asarray(value)
    if arr.ndim == 0:
        v = float(arr)
        return v if np.isfinite(v) else None
    return [_to_json(v) for v in arr]


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """Run the comparison and write Figs. 2-8 equivalents and `metrics.json` to `out_dir`.

    `metrics.json` holds `{"D1": {"M1": {...}, "M2": ..., "M3": ...}, "D2": {...}}` with, per
    controller: `s_settle_time` (every $|s_i|$ below 1e-3 from then on, s),
    `s_i_settle_time` (per axis), `ev_settle_time` ($\\|e_v\\| < 10^{-3}$),
    `eomega_settle_time`, `peak_torque` (N m), `effort` ($\\int\\|u\\|^2dt$),
    `chattering` (total variation of $u$ over t in [10, 30] s), and the steady-state maxima of
    $|e_{v,i}|$ and $|e_{\\omega,i}|$ over t >= 20 s; plus `bounds` (eqs. 55-56) and the
    simulation settings. `short=True` (CI) simulates 12 s with dt = 2e-3; `progress=True`
    shows a progress bar.
    """
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    horizon, dt = (12.0, 2e-3) if short else (HORIZON, DT)
    trajs = run(horizon=horizon, dt=dt, progress=progress)
    metrics: dict = {
        "settings": {
            "horizon": horizon,
            "dt": dt,
            "integrator": "RK4 (classic), continuous control",
            "torque_limit": TORQUE_LIMIT,
            "tolerance": TOLERANCE,
            "chattering_window": list(CHATTER_WINDOW),
            "literal_eqs_57_58": False,
        },
        "bounds": steady_state_bounds(),
    }
    for k, case in enumerate(CASES):
        metrics[case] = {}
        for name, traj in trajs.items():
            one = jax.tree_util.tree_map(lambda x: x[k], traj)
            values = trajectory_metrics(one)
            metrics[case][name] = {key: _to_json(v) for key, v in values.items()}
            metrics[case][name]["successful"] = bool(one.successful)
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    written = write_report(out / "metrics.json", metrics)
    _write_figures(out, trajs)
    return written


def _write_figures(out: pathlib.Path, trajs: dict[str, Trajectory]) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    ts = np.asarray(trajs["M1"].ts[0])
    stride = max(1, len(ts) // 3000)
    panels = [
        ("fig2_attitude_error", "attitude_error", slice(1, 4), "$e_{v,%d}$"),
        ("fig3_rate_error", "rate_error", slice(0, 3), "$e_{\\Omega,%d}$ [rad/s]"),
        ("fig4_torque", "u", slice(0, 3), "$u_%d$ [N m]"),
        ("fig5_sliding_variable", "s", slice(0, 3), "$s_%d$"),
    ]
    with plot.style():
        for case_index, case in enumerate(CASES):
            for stem, key, comps, label in panels:
                fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True, layout="constrained")
                for name, traj in trajs.items():
                    values = np.asarray(traj.signals[key][case_index])[:, comps]
                    entry = name + plot.status_label(
                        traj.status[case_index], traj.failure_time[case_index]
                    )
                    for i, ax in enumerate(axes):
                        ax.plot(ts[::stride], values[::stride, i], label=entry, lw=1.1)
                for i, ax in enumerate(axes):
                    ax.set_ylabel(label % (i + 1))
                    if key == "u":
                        ax.axhline(TORQUE_LIMIT, color="k", ls="--", lw=0.7)
                        ax.axhline(-TORQUE_LIMIT, color="k", ls="--", lw=0.7)
                axes[0].legend(ncol=3)
                axes[-1].set_xlabel("t [s]")
                fig.suptitle(f"{stem.split('_', 1)[0].title()} equivalent, case {case}")
                fig.savefig(out / f"{stem}_{case}.png")
                plt.close(fig)
        for i in range(3):  # Figs. 6-8: s_i from D1 and D2, one panel per controller
            fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True, layout="constrained")
            for ax, (name, traj) in zip(axes, trajs.items()):
                for case_index, case in enumerate(CASES):
                    s = np.asarray(traj.signals["s"][case_index])[:, i]
                    status = plot.status_label(
                        traj.status[case_index], traj.failure_time[case_index]
                    )
                    ax.plot(ts[::stride], s[::stride], label=case + status, lw=1.1)
                ax.set_ylabel(f"{name}: $s_{i + 1}$")
                ax.legend()
            axes[-1].set_xlabel("t [s]")
            fig.suptitle(f"Fig. {6 + i} equivalent: $s_{i + 1}$ from D1 and D2")
            fig.savefig(out / f"fig{6 + i}_s{i + 1}_D1_vs_D2.png")
            plt.close(fig)


SCENARIO = Scenario(
    name="chen2022",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=trajectory_metrics,
)
