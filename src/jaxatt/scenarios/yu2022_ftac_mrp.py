r"""Yu, Cheng, Jin, Du (2022): finite-time MRP stabilization under angular-velocity constraints.

Yu B, Cheng Y, Jin X, Du H. "Robust finite-time attitude stabilization of rigid aircraft under
angular velocity constraints", Control and Decision 37(12):3314-3320, 2022,
DOI 10.13195/j.kzyjc.2021.0897 (SPEC.md, seed 004).

**Set-up (section 3).** The quadrotor of Table 1, $J = \mathrm{diag}(0.01175, 0.01175,
0.02229)$ kg m^2, $\dot\sigma = G(\sigma)\omega$, $J\dot\omega = -\omega^\times J\omega + \tau
+ d(t)$ with $d = (0.002\sin(t+5), 0.002\cos(2t+3), 0.003\sin(3t+2))$ N m, from
$\sigma(0) = (0.5, -0.4, 0.9)$ ($\|\sigma\| = 1.1045$, a 191.4 deg rotation, outside the unit
MRP ball: no shadow switching, as in the paper) and $\omega(0) = (-0.21, -0.23, -0.25)$ rad/s.
Controllers, each wrapped in [`jaxatt.controllers.ObserverCompensated`][] and flown with the
super-twisting observer $\rho_1 = 4$, $\rho_2 = 2$ in the closed loop's observer slot:

- FTAC, eq. (29): [`jaxatt.controllers.RateConstrainedFiniteTimeMRP`][]`(0.03, 0.01, 0.5, 0.4)`,
  so $\alpha_2 = 2/3$ and $M = 0.4$ rad/s;
- FT, eq. (23): [`jaxatt.controllers.FiniteTimeMRP`][]`(0.03, 0.01, 0.5)`;
- PD: [`jaxatt.controllers.MRPPD`][]`(0.02, 0.015)`.

**Interpretations and errata (SPEC 004):**
- Barrier as printed, $\chi(\omega) = \sum_i|\omega_i|^{1+\alpha_2}$. Theorem 1's proof needs
  $\chi(\omega(0)) < M^{1+\alpha_2}$, and the paper's $\omega(0)$ violates it
  ($\chi = 0.2598 > 0.4^{5/3} = 0.2172$; barrier ratio 1.196) although every
  $|\omega_i(0)| < M$. Two initial states are therefore simulated: `"paper"`, the literal one
  (the controller is built with `allow_inadmissible=True`; the state crosses the singular
  surface $\chi = M^{1+\alpha_2}$ in about 0.01 s with a step-dependent torque spike, and
  afterwards stays inside), and `"admissible"`, the same attitude with
  $\omega(0)$ scaled by 0.85 (barrier ratio 0.912).
- Observer reading (A) of eq. (25) (torque estimate, subtracted in (29) as printed). The
  gains $\rho_1 = 4$, $\rho_2 = 2$ meet the sufficient condition (26) in reading (B) but not in
  reading (A), whose effective sign gain is $\rho_2/J_{ii}$ (`gain_conditions()`); the
  estimate converges anyway (measured: $|\hat d - d| < 2\times10^{-4}$ N m after 6 ms).
- The PD form is not printed: $\tau = -k_1\sigma - k_2\omega$, and, like FT and FTAC, it
  subtracts the observer's $\hat d$. Without compensation none of the three laws reaches
  $\|\sigma\| < 10^{-3}$ (the disturbance leaves $\|\sigma\| \approx$ 1.5e-2 to 3e-2), so the
  comparison would say nothing about convergence speed. `build(..., compensate=False)` gives
  the uncompensated laws.
- Horizon and step are not given: 30 s (every law settles within 25 s) with classic RK4 at
  dt = 1e-4 s, continuous control, signals saved every 1e-3 s (`short=True`: dt = 2e-3 s).
  The small step is for the observer, whose reading-(A) estimate chatters with an amplitude
  of about $0.68\rho_2\,dt$ (1.4e-4 N m here, 1.4e-3 N m at dt = 1e-3 s), and for the
  crossing of the barrier's singular surface from the paper's state (see
  `RateConstrainedFiniteTimeMRP` for the step the barrier needs near its boundary).
- The settling criterion is $\|\sigma\| < 10^{-3}$ from then on; times at 1e-2 and 1e-4 are
  reported too because the PD ordering depends on the tolerance.

**Monte Carlo (acceptance).** [`sample_admissible_states`][] draws attitudes uniformly in the
ball $\|\sigma\| < 0.9$ and rates with a uniformly random barrier ratio in $[0, 0.99)$ along a
random direction ([`jaxatt.montecarlo.barrier_states`][]); [`rate_bound_monte_carlo`][]
simulates FTAC (without the opt-out) and FT, both with the observer, from the same batch over
5 s (all rate peaks occur within 4 s) with RK4 at dt = 2e-3 s, well inside the step bound of
`RateConstrainedFiniteTimeMRP` for an initial relative gap of 0.01 or more (about 7e-3 s).
"""

import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from ..controllers import (
    MRPPD,
    AbstractController,
    FiniteTimeMRP,
    ObserverCompensated,
    RateConstrainedFiniteTimeMRP,
    homogeneous_exponent,
)
from ..metrics import max_abs, moving_average, peak, settling_time
from ..montecarlo import barrier_states, check_batch_states, run_batch
from ..numerics import safe_norm
from ..observers import SuperTwistingObserver
from ..plants import MRPState, RigidBodyMRP
from ..signals import Sinusoid
from ..simulation import ClosedLoop, Simulation, Status, Trajectory
from ._io import write_report
from ._protocol import Scenario


TITLE = "Yu 2022: finite-time MRP stabilization under rate constraints (FTAC/FT/PD + observer)"
CONTROLLERS = ("FTAC", "FT", "PD")
CASES = ("paper", "admissible")
INERTIA_DIAGONAL = (0.01175, 0.01175, 0.02229)
"""Table 1 [kg m^2]."""
SIGMA0 = (0.5, -0.4, 0.9)
OMEGA0 = (-0.21, -0.23, -0.25)
"""The paper's initial rate [rad/s] (outside the admissible set)."""
ADMISSIBLE_RATE_SCALE = 0.85
"""The admissible variant scales the paper's $\\omega(0)$ by this (barrier ratio 0.912)."""
K1, K2, ALPHA1, RATE_LIMIT = 0.03, 0.01, 0.5, 0.4
PD_K1, PD_K2 = 0.02, 0.015
RHO1, RHO2 = 4.0, 2.0
DERIVATIVE_BOUND = (0.002, 0.004, 0.009)
"""$\\max_t|\\dot d_i(t)|$ [N m/s] of the three disturbance components ($L_2 = 0.009$)."""
HORIZON = 30.0
DT = 1e-4
SHORT_DT = 2e-3
SAVE_PERIOD = 1e-3
SETTLE_TOLERANCE = 1e-3
EXTRA_TOLERANCES = (1e-2, 1e-4)
OBSERVER_TOLERANCE = 2e-4
"""Observer convergence tolerance [N m] at dt = 1e-4 s (the chattering floor is 1.4e-4)."""
OBSERVER_AVERAGING = 0.1
"""Window [s] of the moving average that separates the estimate's bias from its chatter."""
MC_SAMPLES = 500
MC_HORIZON = 5.0
MC_DT = 2e-3
MC_RATIO_MAX = 0.99
MC_SIGMA_MAX = 0.9
MC_SEED = 2022


def inertia() -> jax.Array:
    """$J = \\mathrm{diag}(0.01175, 0.01175, 0.02229)$ kg m^2 (Table 1)."""
    return jnp.diag(jnp.asarray(INERTIA_DIAGONAL))


def disturbance() -> Sinusoid:
    """$d(t) = (0.002\\sin(t+5), 0.002\\cos(2t+3), 0.003\\sin(3t+2))$ N m."""
    return Sinusoid(
        jnp.array([0.002, 0.002, 0.003]),
        jnp.array([1.0, 2.0, 3.0]),
        jnp.array([5.0, 3.0 + jnp.pi / 2, 2.0]),
    )


def plant() -> RigidBodyMRP:
    """The Table 1 quadrotor with $d(t)$, without MRP shadow switching."""
    return RigidBodyMRP(inertia(), disturbance=disturbance(), shadow_switching=False)


def observer(*, acceleration: bool = False) -> SuperTwistingObserver:
    """The observer of eq. (25), $\\rho_1 = 4$, $\\rho_2 = 2$; reading (A) unless
    `acceleration=True` (reading (B))."""
    return SuperTwistingObserver(inertia(), RHO1, RHO2, acceleration=acceleration)


def controller(name: str, *, allow_inadmissible: bool = True) -> AbstractController:
    """The feedback law `"FTAC"`, `"FT"` or `"PD"` with the paper's gains (no observer)."""
    if name == "FTAC":
        return RateConstrainedFiniteTimeMRP(
            K1, K2, ALPHA1, RATE_LIMIT, allow_inadmissible=allow_inadmissible
        )
    if name == "FT":
        return FiniteTimeMRP(K1, K2, ALPHA1)
    if name == "PD":
        return MRPPD(PD_K1, PD_K2)
    raise ValueError(f"yu2022: `name` must be 'FTAC', 'FT' or 'PD', got {name!r}.")


def build(
    name: str = "FTAC",
    *,
    compensate: bool = True,
    allow_inadmissible: bool = True,
    acceleration: bool = False,
) -> ClosedLoop:
    """The closed loop of controller `name`.

    **Arguments:**
    - `compensate`: subtract the observer's estimate (eq. 29); False gives the bare law.
    - `allow_inadmissible`: FTAC's opt-out (needed for the paper's initial state; see
      [`jaxatt.controllers.RateConstrainedFiniteTimeMRP`][]).
    - `acceleration`: observer reading (B) instead of (A).
    """
    law = controller(name, allow_inadmissible=allow_inadmissible)
    if compensate:
        return ClosedLoop(
            plant(), ObserverCompensated(law), observer=observer(acceleration=acceleration)
        )
    return ClosedLoop(plant(), law)


def initial_state(case: str = "paper") -> MRPState:
    """`"paper"`: the literal initial state; `"admissible"`: $\\omega(0)$ scaled by 0.85."""
    if case == "paper":
        scale = 1.0
    elif case == "admissible":
        scale = ADMISSIBLE_RATE_SCALE
    else:
        raise ValueError(f"yu2022: `case` must be 'paper' or 'admissible', got {case!r}.")
    return MRPState(jnp.asarray(SIGMA0), scale * jnp.asarray(OMEGA0))


def barrier_ratio(omega: jax.Array) -> jax.Array:
    """$\\chi(\\omega)/M^{1+\\alpha_2}$ with the paper's $M$ and $\\alpha_2$, over the last axis."""
    exponent = 1 + homogeneous_exponent(ALPHA1)
    return jnp.sum(jnp.abs(omega) ** exponent, axis=-1) / RATE_LIMIT**exponent


def gain_conditions() -> dict:
    """Condition (26) for the paper's observer gains in readings (A) and (B), per axis."""
    out = {}
    for label, acceleration in (("A", False), ("B", True)):
        check = observer(acceleration=acceleration).gain_condition(jnp.asarray(DERIVATIVE_BOUND))
        out[label] = {
            "satisfied": [bool(s) for s in np.asarray(check.satisfied)],
            "rho1": RHO1,
            "rho1_bound": [float(b) for b in np.asarray(check.rho1_bound)],
            "sign_gain": [float(g) for g in np.asarray(check.sign_gain)],
            "perturbation_bound": [float(b) for b in np.asarray(check.perturbation_bound)],
        }
    return out


def simulate_batch(
    loop: ClosedLoop, x0s: MRPState, horizon: float, dt: float, save_every: int
) -> Trajectory:
    """Simulate one closed loop from a batch of initial states (the batch runner); failures
    are reported per sample in the returned trajectory's `status`. The states are checked on
    the host first, as by `monte_carlo`."""
    sim = Simulation(0.0, horizon, dt, save_every=save_every)
    x0s, _ = check_batch_states("simulate_batch", loop, x0s)
    return _simulate_batch(loop, x0s, sim)


@eqx.filter_jit
def _simulate_batch(loop: ClosedLoop, x0s: MRPState, sim: Simulation) -> Trajectory:
    return run_batch(loop, x0s, sim, {}, keep_trajectories=True).trajectories


def _save_every(dt: float) -> int:
    return max(1, round(SAVE_PERIOD / dt))


def run(
    *, horizon: float = HORIZON, dt: float = DT, progress: bool = False
) -> dict[str, Trajectory]:
    """Simulate FTAC, FT and PD (all with the observer) from both `CASES`.

    Returns one trajectory per controller, batched over `CASES` (leading axis).
    """
    from tqdm import tqdm

    x0s = jax.tree_util.tree_map(
        lambda *xs: jnp.stack(xs), *[initial_state(case) for case in CASES]
    )
    return {
        name: simulate_batch(build(name), x0s, horizon, dt, _save_every(dt))
        for name in tqdm(CONTROLLERS, desc="yu2022", disable=not progress)
    }


def trajectory_metrics(traj: Trajectory) -> dict[str, jax.Array]:
    """The per-controller metrics of `metrics.json` for one (unbatched) trajectory."""
    ts = traj.ts
    omega = traj.plant_states.omega
    sigma_norm = safe_norm(traj.plant_states.sigma)
    u = traj.signals["u"]
    ratio = barrier_ratio(omega)
    out = {
        "max_abs_omega": max_abs(omega),
        "sigma_settle_time": settling_time(ts, sigma_norm, SETTLE_TOLERANCE),
        "peak_torque": peak(u),
        "peak_torque_after_0.1s": jnp.max(jnp.abs(jnp.where((ts >= 0.1)[:, None], u, 0.0))),
        # `~(|omega| < M)`, not `|omega| >= M`: a NaN rate (a diverged run) is a violation.
        "constraint_violated": jnp.any(~(jnp.abs(omega) < RATE_LIMIT)),
        "initial_barrier_ratio": ratio[0],
        "max_barrier_ratio_after_0.1s": jnp.max(jnp.where(ts >= 0.1, ratio, 0.0)),
        "admissible_initial_state": ratio[0] < 1,
        "final_sigma_norm": sigma_norm[-1],
    }
    for tol in EXTRA_TOLERANCES:
        out[f"sigma_settle_time_{tol:g}"] = settling_time(ts, sigma_norm, tol)
    if "d_hat" in traj.signals:
        difference = traj.signals["d_hat"] - traj.signals["disturbance"]
        error = jnp.max(jnp.abs(difference), axis=1)
        out["observer_error_after_5s"] = jnp.max(jnp.where(ts >= 5.0, error, 0.0))
        out["observer_convergence_time"] = settling_time(ts, error, OBSERVER_TOLERANCE)
        # The estimate chatters with an amplitude ~ rho2 dt; averaged over 0.1 s the chatter
        # cancels and what remains is the estimate's bias (|d| itself for a stuck estimate).
        bias = jnp.max(jnp.abs(moving_average(ts, difference, OBSERVER_AVERAGING)), axis=1)
        out["observer_bias_after_5s"] = jnp.max(jnp.where(ts >= 5.0, bias, 0.0))
    return out


def sample_admissible_states(
    key: jax.Array,
    n: int = MC_SAMPLES,
    *,
    sigma_max: float = MC_SIGMA_MAX,
    ratio_max: float = MC_RATIO_MAX,
) -> MRPState:
    """`n` random initial states inside FTAC's admissible set (batched `MRPState`).

    Attitudes uniform in the ball $\\|\\sigma\\| <$ `sigma_max`; rates
    $\\omega = M r^{1/(1+\\alpha_2)} w$ with $w$ a Gaussian direction normalized to
    $\\sum_i|w_i|^{1+\\alpha_2} = 1$ and the barrier ratio $r$ uniform in `[0, ratio_max)`, so
    $\\chi(\\omega) = r M^{1+\\alpha_2}$.
    """
    return barrier_states(
        key,
        n,
        max_sigma=sigma_max,
        rate_limit=RATE_LIMIT,
        exponent=1 + float(homogeneous_exponent(ALPHA1)),
        max_ratio=ratio_max,
    )


def rate_bound_monte_carlo(
    key: jax.Array,
    n: int = MC_SAMPLES,
    *,
    horizon: float = MC_HORIZON,
    dt: float = MC_DT,
    controllers: tuple[str, ...] = ("FTAC", "FT"),
) -> dict:
    """Simulate each controller (with the observer) from the same random admissible batch.

    **Returns:** per controller, `max_abs_omega` (n, 3) over the saved times (every 1e-2 s),
    `violated` (n,) (some saved $|\\omega_i| \\ge M$ or non-finite, or the sample's status not
    successful: a diverged or failed sample counts as a violation), `status` (n,) (`Status`
    codes, e.g. FTAC's barrier report), and the sampled `x0s` under `"x0s"`.
    """
    x0s = sample_admissible_states(key, n)
    save_every = max(1, round(1e-2 / dt))
    out: dict = {"x0s": x0s}
    for name in controllers:
        traj = simulate_batch(build(name, allow_inadmissible=False), x0s, horizon, dt, save_every)
        peak_rates = jnp.max(jnp.abs(traj.plant_states.omega), axis=1)
        out[name] = {
            "max_abs_omega": peak_rates,
            "violated": _violated(peak_rates, traj.status),
            "status": traj.status,
        }
    return out


def _violated(peak_rates, status):
    """Per sample: a saved $|\\omega_i| \\ge M$, a non-finite rate (`~(x < M)` is true for NaN),
    or an unsuccessful status."""
    return jnp.any(~(peak_rates < RATE_LIMIT), axis=-1) | (status != int(Status.successful))


def monte_carlo_summary(result: dict) -> dict:
    """The `metrics.json` summary of one controller's entry of [`rate_bound_monte_carlo`][].

    `violations` and `violation_fraction` count every sample that does not demonstrably respect
    the bound: a saved $|\\omega_i| \\ge M$, a non-finite rate, or an unsuccessful status
    (`unsuccessful_results` repeats how many were unsuccessful). `largest_abs_omega` is the
    largest saved rate, infinite (JSON `null`) when some sample's rate is not finite.
    """
    peaks = np.asarray(result["max_abs_omega"], dtype=float)
    status = np.asarray(result["status"])
    violated = np.asarray(_violated(peaks, status))
    return {
        "violations": int(np.sum(violated)),
        "violation_fraction": float(np.mean(violated)),
        "largest_abs_omega": float(np.max(np.where(np.isfinite(peaks), peaks, np.inf))),
        "unsuccessful_results": int(np.sum(status != Status.successful)),
    }


def _to_json(value):
    arr = np.asarray(value)
    if arr.dtype == bool:
        return bool(arr) if arr.ndim == 0 else [bool(v) for v in arr]
    if arr.ndim == 0:
        v = float(arr)
        return v if np.isfinite(v) else None
    return [_to_json(v) for v in arr]


def claims(metrics: dict) -> dict[str, dict[str, bool]]:
    """The paper's claims evaluated on the metrics of each case (settling at 1e-3 unless
    stated). A claim holds only if every run it is about ended `successful`: a diverged or
    failed run never supports one (a non-finite rate already counts as a violation)."""

    def time(value) -> float:  # JSON stores an unsettled (infinite) time as None
        return float("inf") if value is None else float(value)

    out = {}
    for case in CASES:
        m = metrics[case]
        t = {name: time(m[name]["sigma_settle_time"]) for name in CONTROLLERS}
        t4 = {name: time(m[name]["sigma_settle_time_0.0001"]) for name in CONTROLLERS}
        ok = {name: m[name]["result"] == Status.successful.name for name in CONTROLLERS}
        observer_error = m["FTAC"]["observer_error_after_5s"]
        out[case] = {
            "FT_faster_than_FTAC": ok["FT"] and ok["FTAC"] and t["FT"] < t["FTAC"],
            "FT_violates_rate_bound": ok["FT"] and bool(m["FT"]["constraint_violated"]),
            "FTAC_respects_rate_bound": ok["FTAC"] and not m["FTAC"]["constraint_violated"],
            "PD_slowest": all(ok.values()) and t["PD"] > max(t["FT"], t["FTAC"]),
            "PD_slowest_at_1e-4": all(ok.values()) and t4["PD"] > max(t4["FT"], t4["FTAC"]),
            "observer_error_below_tolerance_after_5s": ok["FTAC"]
            and observer_error is not None
            and observer_error < OBSERVER_TOLERANCE,
        }
    return out


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """Run the comparison; write Figs. 1-3 equivalents, the observer error, the Monte Carlo
    histogram and `metrics.json` to `out_dir`.

    `metrics.json` holds `settings`, `gain_condition` (eq. 26 in readings A and B), per case
    (`"paper"`, `"admissible"`) and controller (`"FTAC"`, `"FT"`, `"PD"`): `max_abs_omega`
    [rad/s], `sigma_settle_time` ($\\|\\sigma\\| < 10^{-3}$ from then on, s) and the same at
    1e-2 and 1e-4, `peak_torque` [N m] (with the crossing spike; `peak_torque_after_0.1s`
    without), `constraint_violated` (some saved $|\\omega_i| \\ge M$ or non-finite),
    `admissible_initial_state`, barrier ratios, `observer_error_after_5s` [N m],
    `observer_convergence_time` (to 2e-4 N m), `observer_bias_after_5s` (the largest
    0.1 s moving average of $|\\hat d_i - d_i|$ after 5 s, N m: the estimate's bias without
    its chatter), `result`; then `claims` (the paper's claims
    evaluated on these numbers) and `monte_carlo` (FTAC vs FT from 500 random admissible
    states: violation counts and the largest rate). `short=True` (CI): dt = 2e-3 s and no
    Monte Carlo (`monte_carlo` is null, no Fig. 5); `progress=True` shows a progress bar.
    """
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dt = SHORT_DT if short else DT
    trajs = run(horizon=HORIZON, dt=dt, progress=progress)
    metrics: dict = {
        "settings": {
            "horizon": HORIZON,
            "dt": dt,
            "save_period": SAVE_PERIOD,
            "integrator": "RK4 (classic), continuous control",
            "settle_tolerance": SETTLE_TOLERANCE,
            "observer_tolerance": OBSERVER_TOLERANCE,
            "observer_reading": "A (torque estimate)",
            "all_controllers_subtract_d_hat": True,
            "admissible_rate_scale": ADMISSIBLE_RATE_SCALE,
            "rate_limit": RATE_LIMIT,
            "alpha2": float(homogeneous_exponent(ALPHA1)),
        },
        "gain_condition": gain_conditions(),
    }
    for k, case in enumerate(CASES):
        metrics[case] = {}
        for name, traj in trajs.items():
            one = jax.tree_util.tree_map(lambda x: x[k], traj)
            values = {key: _to_json(v) for key, v in trajectory_metrics(one).items()}
            values["result"] = _result_name(one)
            metrics[case][name] = values
    metrics["claims"] = claims(metrics)
    mc = None
    if short:
        metrics["monte_carlo"] = None
    else:
        if progress:
            print(f"[yu2022] Monte Carlo: FTAC and FT from {MC_SAMPLES} random admissible states")
        mc = rate_bound_monte_carlo(jr.key(MC_SEED), MC_SAMPLES)
        metrics["monte_carlo"] = {
            "samples": MC_SAMPLES,
            "seed": MC_SEED,
            "horizon": MC_HORIZON,
            "dt": MC_DT,
            "sigma_max": MC_SIGMA_MAX,
            "barrier_ratio_max": MC_RATIO_MAX,
            **{name: monte_carlo_summary(mc[name]) for name in ("FTAC", "FT")},
        }
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    written = write_report(out / "metrics.json", metrics)
    _write_figures(out, trajs, mc)
    return written


def _result_name(traj: Trajectory) -> str:
    return Status(int(traj.status)).name


def _write_figures(out: pathlib.Path, trajs: dict[str, Trajectory], mc: dict | None) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    ts = np.asarray(trajs["FTAC"].ts[0])
    colors = {"FTAC": "C0", "FT": "C1", "PD": "C2"}
    with plot.style():
        for k, case in enumerate(CASES):
            fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True, layout="constrained")
            for name, traj in trajs.items():
                sigma = np.asarray(traj.plant_states.sigma[k])
                label = name + plot.status_label(traj.status[k], traj.failure_time[k])
                for i, ax in enumerate(axes):
                    ax.plot(ts, sigma[:, i], color=colors[name], label=label, lw=1.1)
            for i, ax in enumerate(axes):
                ax.set_ylabel(f"$\\sigma_{i + 1}$")
            axes[0].legend(ncol=3)
            axes[-1].set_xlabel("t [s]")
            fig.suptitle(f"Fig. 1 equivalent: MRPs ({case} initial state)")
            fig.savefig(out / f"fig1_mrp_{case}.png")
            plt.close(fig)

            fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True, layout="constrained")
            for name, traj in trajs.items():
                omega = np.asarray(traj.plant_states.omega[k])
                label = name + plot.status_label(traj.status[k], traj.failure_time[k])
                for i, ax in enumerate(axes):
                    ax.plot(ts, omega[:, i], color=colors[name], label=label, lw=1.1)
            for i, ax in enumerate(axes):
                ax.axhline(RATE_LIMIT, color="k", ls="--", lw=0.7)
                ax.axhline(-RATE_LIMIT, color="k", ls="--", lw=0.7)
                ax.set_ylabel(f"$\\omega_{i + 1}$ [rad/s]")
            axes[0].legend(ncol=3)
            axes[-1].set_xlabel("t [s]")
            fig.suptitle(f"Fig. 2 equivalent: body rates and the bound M = 0.4 ({case})")
            fig.savefig(out / f"fig2_omega_{case}.png")
            plt.close(fig)

            ftac = jax.tree_util.tree_map(lambda x: x[k], trajs["FTAC"])
            u = np.asarray(ftac.signals["u"])
            late = ts >= 0.1
            fig, ax = plt.subplots(figsize=(7, 3.2), layout="constrained")
            for i in range(3):
                ax.plot(ts, u[:, i], lw=1.1, label=f"$\\tau_{i + 1}$")
            plot.mark_failure(ax, ftac)
            peak_late = np.max(np.abs(u[late]))
            if np.isfinite(peak_late) and peak_late > 0:  # a diverged run's NaN: autoscale
                ax.set_ylim(-1.2 * peak_late, 1.2 * peak_late)
            ax.set_xlabel("t [s]")
            ax.set_ylabel("torque [N m]")
            ax.legend(ncol=3)
            ax.set_title(
                f"Fig. 3 equivalent: FTAC torque ({case}); peak {np.max(np.abs(u)):.3g} N m "
                "before t = 0.1 s (clipped)"
            )
            fig.savefig(out / f"fig3_ftac_torque_{case}.png")
            plt.close(fig)

            error = np.asarray(ftac.signals["d_hat"] - ftac.signals["disturbance"])
            fig, ax = plt.subplots(figsize=(7, 3.2), layout="constrained")
            for i in range(3):
                ax.semilogy(ts, np.abs(error[:, i]) + 1e-12, lw=0.8, label=f"axis {i + 1}")
            plot.mark_failure(ax, ftac)
            ax.axhline(OBSERVER_TOLERANCE, color="k", ls="--", lw=0.7)
            ax.set_xlabel("t [s]")
            ax.set_ylabel("$|\\hat d_i - d_i|$ [N m]")
            ax.legend(ncol=3)
            ax.set_title(f"Observer estimation error under FTAC ({case})")
            fig.savefig(out / f"fig4_observer_error_{case}.png")
            plt.close(fig)

        if mc is None:
            return
        fig, ax = plt.subplots(figsize=(7, 3.2), layout="constrained")
        # Only finite peaks are histogrammed (a diverged sample's NaN made the bins NaN);
        # the diverged samples are counted in the legend and in metrics.json's violations.
        peaks = {n: np.max(np.asarray(mc[n]["max_abs_omega"]), axis=1) for n in ("FTAC", "FT")}
        finite = {n: p[np.isfinite(p)] for n, p in peaks.items()}
        top = max([0.5, *(float(p.max()) for p in finite.values() if p.size)])
        bins = np.linspace(0, top, 41)
        for name in ("FTAC", "FT"):
            diverged = peaks[name].size - finite[name].size
            # metrics.json's violations: the samples past the bound, non-finite or unsuccessful
            # (a failed sample's finite peak is drawn, but counted here, not passed off).
            violations = int(np.sum(np.asarray(mc[name]["violated"])))
            label = f"{name} ({violations} of {peaks[name].size} violate"
            label += f"; {diverged} non-finite, not shown)" if diverged else ")"
            ax.hist(finite[name], bins=bins, alpha=0.6, color=colors[name], label=label)
        ax.axvline(RATE_LIMIT, color="k", ls="--", lw=0.8)
        ax.set_xlabel("$\\max_{t,i} |\\omega_i(t)|$ [rad/s]")
        ax.set_ylabel("samples")
        ax.legend()
        ax.set_title("Monte Carlo over random admissible initial states")
        fig.savefig(out / "fig5_monte_carlo_peak_rate.png")
        plt.close(fig)


SCENARIO = Scenario(
    name="yu2022",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=trajectory_metrics,
)
