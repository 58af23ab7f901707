r"""Duan, Dai, Shao, Wang (2024): two-layer consensus of 12 spacecraft under intermittent
communication.

Duan Z, Dai J, Shao Z, Wang R. Journal of Dynamics and Control 22(7), 2024,
DOI 10.6052/1672-6553-2024-030 (SPEC.md, seed 002(a)).

**Set-up.** $q = 3$ groups of $p = 4$ single-integrator agents, $\dot x_{n,m} = u_{n,m}$,
$x(0) = (5, 4, -3, 2 \mid 1, 12, 7, 10 \mid 9, 8, 11, 6)$ (mean 6), $\rho_1 = (2, 1, 2, 1)$,
$\rho_2 = (1, 0, 0, 0)$, $\Delta = \rho_1\rho_2^T$, $L_2$ the 3-node path (eigenvalues 0, 1,
3), and the closed loop (5) $\dot x = -(I_q\otimes L_1)x(t) - (L_2\otimes\Delta)x(t_i)$:
continuous intra-group coupling, inter-layer coupling held from the sampling instants
([`jaxatt.controllers.TwoLayerConsensus`][] with a [`jaxatt.networks.SampledLink`][]).
Classic RK4 at dt = 0.01 s (the sampling instants are step boundaries), horizon 60 s.

**Decisions and errata (SPEC 002(a)):**
- $L_1$ row 3 corrected to $(0, -2, 3, -1)$ (the printed $+1$ gives row sum 2; the
  corrected $L_1$ is the weighted path 1-2-1, eigenvalues 0, 0.7639, 2, 5.2361). The printed
  $L_1$ is simulated too (`build(l1="printed")`): it is not a Laplacian, the average is not
  conserved and every agent goes to **0**, not 6.
- Protocol (2) corrected to match (5) (sign, intra term continuous).
- "Intermittent": periodic sampling $h = \tau = 0.26$ s by default; random intervals
  uniform on the grid points of $(0, \tau]$ as the option `sampling="random"`.
- LMI corrected ($\eta$ sign, $\tau\eta^TS\eta$, $E_2 = e_1 - e_2$), printed form as a
  variant; margin variable and eigenvalue re-check; bisection on $\tau$
  ([`jaxatt.networks.lmi_tau_max`][]).
- The exact periodic bound $h^*$ from the one-period transition matrix of each mode
  ([`jaxatt.networks.largest_stable_interval`][]).

**Findings** (measured by `reproduce`; see `metrics.json` and `docs/gallery/duan2024.md`):
the corrected LMI is feasible for the $\lambda = 1$ mode up to $\tau = 0.7346$ s but for the
$\lambda = 3$ mode only up to $\tau = 0.2323$ s, so the paper's "feasible at
$\tau = 0.26$ s" does **not** hold for the corrected theorem; the printed theorem is
infeasible for every $\tau$ (its $L_1 - \lambda_k\Delta$ is not Hurwitz: trace
$8 - 2\lambda_k > 0$). The loop itself is stable at 0.26 s: $h^* = 0.33833$ s, and the
spectral radius at 0.26 s is 0.8655.
"""

import pathlib
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from ..controllers import TwoLayerConsensus
from ..networks import (
    CORRECTED,
    PRINTED,
    SampledLink,
    SampleSchedule,
    TwoLayerNetwork,
    decay_rate,
    disagreement_spectral_radius,
    largest_stable_interval,
    lmi_feasibility,
    lmi_tau_max,
    mode_spectral_radii,
    printed_form_ceiling,
    sampled_response,
)
from ..networks._types import MatrixLike
from ..plants import AgentsState, SingleIntegratorAgents
from ..simulation import ClosedLoop, Trajectory, simulate
from ._io import write_report
from ._protocol import Scenario


TITLE = "Duan 2024: two-layer consensus of 12 spacecraft under intermittent communication"
GROUPS, AGENTS = 3, 4
X0 = (5.0, 4.0, -3.0, 2.0, 1.0, 12.0, 7.0, 10.0, 9.0, 8.0, 11.0, 6.0)
RHO1 = (2.0, 1.0, 2.0, 1.0)
RHO2 = (1.0, 0.0, 0.0, 0.0)
L1 = ((1.0, -1.0, 0.0, 0.0), (-1.0, 3.0, -2.0, 0.0), (0.0, -2.0, 3.0, -1.0), (0.0, 0.0, -1.0, 1.0))
"""$L_1$ with SPEC's corrected row 3."""
L1_PRINTED = (
    (1.0, -1.0, 0.0, 0.0),
    (-1.0, 3.0, -2.0, 0.0),
    (0.0, -2.0, 3.0, 1.0),
    (0.0, 0.0, -1.0, 1.0),
)
"""$L_1$ as printed (row 3 sums to 2)."""
L2 = ((1.0, -1.0, 0.0), (-1.0, 2.0, -1.0), (0.0, -1.0, 1.0))
TAU = 0.26
"""The paper's sampling bound [s]."""
DT = 0.01
HORIZON = 60.0
SAVE_EVERY = 2
RANDOM_SEED = 2024
THRESHOLD_OFFSET = 0.004
"""Simulations at $h^* \\mp$ this [s] confirm the exact bound."""
THRESHOLD_PERIODS = 150
AUTODIFF_STEPS = 8
AUTODIFF_RATE = 0.5
LMI_TOLERANCE = 1e-4
TEXTBOOK_A = ((0.0, 1.0), (0.0, -0.1))
TEXTBOOK_B = ((0.0, 0.0), (-0.375, -1.15))
"""The classic sampled-data example $\\dot x = Ax + BKx(t_k)$ (Zhang, Branicky, Phillips
2001; Fridman, Seuret, Richard 2004; Fridman 2010), with $BK$ written as `TEXTBOOK_B`."""


def network(l1: str = "corrected", rho1: MatrixLike = RHO1) -> TwoLayerNetwork:
    """The example's network; `l1="printed"` uses the printed (non-Laplacian) $L_1$."""
    if l1 not in ("corrected", "printed"):
        raise ValueError(f'duan2024: `l1` must be "corrected" or "printed", got {l1!r}.')
    printed = l1 == "printed"
    return TwoLayerNetwork(
        L1_PRINTED if printed else L1, L2, rho1, RHO2, allow_non_laplacian=printed
    )


def schedule(
    sampling: str = "periodic", tau: float = TAU, dt: float = DT, seed: int = RANDOM_SEED
) -> SampleSchedule:
    """Periodic ($h = \\tau$) or random (uniform on the grid points of $(0, \\tau]$)."""
    if sampling == "periodic":
        return SampleSchedule.periodic(tau, dt)
    if sampling == "random":
        return SampleSchedule.random(jr.key(seed), tau, dt)
    raise ValueError(f'duan2024: `sampling` must be "periodic" or "random", got {sampling!r}.')


def build(
    *,
    l1: str = "corrected",
    sampling: str = "periodic",
    tau: float = TAU,
    dt: float = DT,
    seed: int = RANDOM_SEED,
    rho1: MatrixLike = RHO1,
) -> ClosedLoop:
    """The closed loop (5): 12 single integrators under the two-layer protocol."""
    link = SampledLink(schedule(sampling, tau, dt, seed))
    return ClosedLoop(
        SingleIntegratorAgents(GROUPS, AGENTS), TwoLayerConsensus(network(l1, rho1), link)
    )


def initial_state() -> AgentsState:
    """$x(0)$ as `(q, p)` (group $n$ is row $n$)."""
    return AgentsState(jnp.asarray(X0).reshape(GROUPS, AGENTS))


def run(
    loop: ClosedLoop, *, horizon: float = HORIZON, dt: float = DT, save_every: int = SAVE_EVERY
) -> Trajectory:
    """Simulate `loop` from $x(0)$ with RK4 at `dt` and continuous control."""
    return simulate(loop, initial_state(), 0.0, horizon, dt=dt, save_every=save_every)


def trajectory_metrics(traj: Trajectory) -> dict:
    """`consensus_value` (the final mean, s), `final_spread` (max - min at the horizon),
    `max_final_deviation` ($\\max_i |x_i(T) - \\bar x(0)|$), `mean_drift`
    ($\\max_t |\\bar x(t) - \\bar x(0)|$)."""
    x = np.asarray(traj.states.plant.x)
    means = x.mean(axis=(1, 2))
    final = x[-1]
    return {
        "consensus_value": float(final.mean()),
        "final_spread": float(final.max() - final.min()),
        "max_final_deviation": float(np.max(np.abs(final - means[0]))),
        "mean_drift": float(np.max(np.abs(means - means[0]))),
    }


def exact_analysis(grid: int = 400) -> dict:
    """$h^*$, the radii at $\\tau$, and the radius curve over $h \\in (0, 0.5]$."""
    net = network()
    h_star = float(_h_star(net))
    hs = np.linspace(0.005, 0.5, grid)
    radii = np.asarray(_radii_curve(net, jnp.asarray(hs)))
    return {
        "exact_h_star": h_star,
        "spectral_radius_at_0_26": float(disagreement_spectral_radius(net, TAU)),
        "mode_spectral_radii_at_0_26": [float(r) for r in mode_spectral_radii(net, TAU)],
        "decay_rate_at_0_26": float(decay_rate(net, TAU)),
        "l2_eigenvalues": [float(v) for v in np.linalg.eigvalsh(np.asarray(L2))],
        "curve": {"h": hs, "radii": radii},
    }


@eqx.filter_jit
def _h_star(net: TwoLayerNetwork) -> jax.Array:
    return largest_stable_interval(net)


@eqx.filter_jit
def _radii_curve(net: TwoLayerNetwork, hs: jax.Array) -> jax.Array:
    return jax.vmap(lambda h: mode_spectral_radii(net, h))(hs)


def lmi_analysis(tol: float = LMI_TOLERANCE) -> dict:
    """Theorem 1 per mode ($\\lambda_k$ = 1, 3), corrected and printed.

    A mode's bound is NaN (null in `metrics.json`) when its bisection rests on an inconclusive
    solve ([`jaxatt.networks.lmi_tau_max`][]), and the network's bound, the smallest, is then
    NaN too. Feasibility at 0.26 s is True (every mode certified), False (a conclusive solve
    rules a mode out) or None (undecided: an inconclusive solve where a certificate is
    missing), per mode likewise, with each solve's status."""
    net = network()
    lam = np.linalg.eigvalsh(np.asarray(L2))[1:]
    a = -np.asarray(L1)
    delta = np.asarray(net.delta)
    corrected = [lmi_tau_max(a, -lk * delta, CORRECTED, tol=tol) for lk in lam]
    printed = [lmi_tau_max(a, -lk * delta, PRINTED, tol=tol) for lk in lam]
    at_tau = [lmi_feasibility(a, -lk * delta, TAU, CORRECTED) for lk in lam]
    printed_at_tau = [lmi_feasibility(a, -lk * delta, TAU, PRINTED) for lk in lam]
    return {
        "lmi_tau_max": float(np.min(corrected)),  # NaN-propagating, unlike Python's min
        "lmi_tau_max_per_mode": corrected,
        "lmi_tau_max_printed": float(np.min(printed)),
        "lmi_tau_max_printed_per_mode": printed,
        "lmi_feasible_at_0_26": _verdict(at_tau),
        "lmi_feasible_at_0_26_per_mode": [r.feasible if r.conclusive else None for r in at_tau],
        "lmi_status_at_0_26_per_mode": [r.status for r in at_tau],
        "lmi_margin_at_0_26_per_mode": [r.margin for r in at_tau],
        "lmi_printed_feasible_at_0_26": _verdict(printed_at_tau),
        "printed_form_necessary_condition": [printed_form_ceiling(L1, delta, lk) for lk in lam],
        "lmi_bisection_tolerance": tol,
    }


def _verdict(results) -> bool | None:
    """True if every solve certifies, False if a conclusive one rules a mode out, else None."""
    if all(r.feasible for r in results):
        return True
    return False if any(r.conclusive and not r.feasible for r in results) else None


def textbook_example(tol: float = LMI_TOLERANCE) -> dict:
    """The same LMI (corrected form) and exact bound on the textbook sampled-data example."""
    a, b = np.asarray(TEXTBOOK_A), np.asarray(TEXTBOOK_B)
    return {
        "lmi_tau_max": lmi_tau_max(a, b, CORRECTED, tau_high=3.0, tol=tol),
        "exact_h_star": float(_textbook_h_star(jnp.asarray(a), jnp.asarray(b))),
    }


@eqx.filter_jit
def _textbook_h_star(a: jax.Array, b: jax.Array) -> jax.Array:
    """The first sampling interval in (0, 3] s at which $\rho(F(h)) = 1$ for the textbook
    pair (inf if none, NaN if a radius on the way is NaN)."""
    from ..networks import sampled_transition, spectral_radius
    from ..networks._exact import _first_unstable_interval

    return _first_unstable_interval(
        lambda h: spectral_radius(sampled_transition(a, b, h)),
        h_max=3.0,
        grid=300,
        iterations=60,
        dtype=a.dtype,
    )


def disagreement_growth(traj: Trajectory, h: float, periods: int = 50) -> float:
    """The disagreement's growth factor per sampling period over the last `periods` periods
    ($(\\|\\varepsilon(T)\\| / \\|\\varepsilon(T - nh)\\|)^{1/n}$), from the saved states."""
    ts = np.asarray(traj.ts)
    eps = np.asarray(traj.states.plant.x)
    eps = eps - eps.mean(axis=(1, 2), keepdims=True)
    norms = np.linalg.norm(eps.reshape(len(ts), -1), axis=1)
    start = int(np.argmin(np.abs(ts - (ts[-1] - periods * h))))
    return float((norms[-1] / norms[start]) ** (1.0 / periods))


def threshold_check(h_star: float, periods: int = THRESHOLD_PERIODS) -> dict:
    """Simulate (RK4, 40 steps per period) at $h^* \\mp$ `THRESHOLD_OFFSET` for `periods`
    periods; the disagreement must decay below and grow above."""
    out = {}
    for name, h in (("below", h_star - THRESHOLD_OFFSET), ("above", h_star + THRESHOLD_OFFSET)):
        dt = h / 40
        traj = simulate(
            build(tau=h, dt=dt), initial_state(), 0.0, periods * h, dt=dt, save_every=40
        )
        eps0 = np.asarray(traj.states.plant.x[0]) - np.mean(X0)
        epsT = np.asarray(traj.states.plant.x[-1]) - np.mean(X0)
        out[name] = {
            "h": h,
            "disagreement_ratio": float(np.linalg.norm(epsT) / np.linalg.norm(eps0)),
            "growth_per_period": disagreement_growth(traj, h),
            "spectral_radius": float(disagreement_spectral_radius(network(), h)),
        }
    return out


@eqx.filter_jit
def _h_star_and_gradient(rho1: jax.Array) -> tuple[jax.Array, jax.Array]:
    return jax.value_and_grad(lambda r: largest_stable_interval(network(rho1=r)))(rho1)


def autodiff_study(steps: int = AUTODIFF_STEPS, rate: float = AUTODIFF_RATE) -> dict:
    r"""Raise $h^*$ by projected gradient ascent on $\rho_1$ with $\sum\rho_1 = 6$ fixed and
    $\rho_{1,i} \ge 0.1$: $\rho_1 \leftarrow P(\rho_1 + r\,(g - \bar g))$, $g = \partial
    h^*/\partial\rho_1$ (implicit function theorem through `expm` and `eigvals`). The best
    iterate is kept and confirmed by the exact bound recomputed from scratch and by
    simulations at $h$ halfway between the old and new bounds."""
    rho1 = jnp.asarray(RHO1)
    history = []
    best = (-np.inf, rho1)
    for _ in range(steps):
        value, grad = _h_star_and_gradient(rho1)
        history.append({"rho1": [float(v) for v in rho1], "h_star": float(value)})
        if float(value) > best[0]:
            best = (float(value), rho1)
        grad = grad - jnp.mean(grad)
        rho1 = jnp.maximum(rho1 + rate * grad, 0.1)
        rho1 = rho1 * (sum(RHO1) / jnp.sum(rho1))
    value = float(_h_star(network(rho1=rho1)))
    history.append({"rho1": [float(v) for v in rho1], "h_star": value})
    if value > best[0]:
        best = (value, rho1)
    h0 = history[0]["h_star"]
    tuned = best[1]
    h_tuned = float(_h_star(network(rho1=tuned)))
    h_test = round(0.5 * (h0 + h_tuned) / 0.0025) * 0.0025  # a multiple of dt = h/25
    confirm = {}
    for name, r in (("paper_rho1", jnp.asarray(RHO1)), ("tuned_rho1", tuned)):
        dt = h_test / 25
        traj = simulate(
            build(tau=h_test, dt=dt, rho1=r),
            initial_state(),
            0.0,
            60 * h_test,
            dt=dt,
            save_every=25,
        )
        confirm[name] = {
            "growth_per_period": disagreement_growth(traj, h_test, periods=30),
            "spectral_radius": float(disagreement_spectral_radius(network(rho1=r), h_test)),
        }
    return {
        "history": history,
        "rho1_tuned": [float(v) for v in tuned],
        "h_star_paper_rho1": h0,
        "h_star_tuned_rho1": h_tuned,
        "decay_rate_at_0_26_paper_rho1": float(decay_rate(network(), TAU)),
        "decay_rate_at_0_26_tuned_rho1": float(decay_rate(network(rho1=tuned), TAU)),
        "h_test": h_test,
        "simulation_at_h_test": confirm,
    }


def claims(metrics: dict) -> dict[str, bool]:
    """The paper's claims (and the acceptance checks) evaluated on the metrics; an undecided
    LMI verdict (None) or a NaN LMI bound supports no claim."""
    return {
        "consensus_to_initial_average_periodic": abs(metrics["consensus_value"] - 6.0) < 1e-9
        and metrics["max_final_deviation"] < 1e-9,
        "consensus_to_initial_average_random": abs(
            metrics["random_sampling"]["consensus_value"] - 6.0
        )
        < 1e-9
        and metrics["random_sampling"]["max_final_deviation"] < 1e-9,
        "converges_at_0_26": metrics["spectral_radius_at_0_26"] < 1,
        "lmi_feasible_at_0_26_corrected": metrics["lmi_feasible_at_0_26"] is True,
        "lmi_feasible_at_0_26_printed": metrics["lmi_printed_feasible_at_0_26"] is True,
        "lmi_below_exact": metrics["lmi_tau_max"] < metrics["exact_h_star"],
        "printed_L1_reaches_average": abs(metrics["printed_L1_consensus_value"] - 6.0) < 1e-3,
    }


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """Simulate and analyse; write the figures and `metrics.json` to `out_dir`.

    `metrics.json`: the issue's keys (`consensus_value`, `final_spread`, `mean_drift`,
    `lmi_tau_max`, `lmi_tau_max_per_mode`, `lmi_tau_max_printed`, `lmi_feasible_at_0_26`,
    `exact_h_star`, `spectral_radius_at_0_26`, `printed_L1_consensus_value`), then
    `random_sampling` (the same trajectory metrics under random intervals), `printed_L1`,
    the LMI details, `threshold_check` (simulations at $h^* \\mp 0.004$ s), `textbook_example`,
    `autodiff` (the study on $\\rho_1$; omitted in short mode), `claims`, `settings` and
    `timings`. `short=True` (CI): coarser LMI bisection (1e-3 s), fewer threshold periods,
    no autodiff study.
    """
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    timings = {}

    def log(message):
        if progress:
            print(f"[duan2024] {message}", flush=True)

    start = time.perf_counter()
    log("simulating periodic, random and printed-L1 cases")
    trajs = {
        "periodic": run(build()),
        "random": run(build(sampling="random")),
        "printed": run(build(l1="printed")),
    }
    timings["simulations"] = time.perf_counter() - start
    metrics: dict = dict(trajectory_metrics(trajs["periodic"]))
    random_metrics = trajectory_metrics(trajs["random"])
    random_schedule = schedule("random")
    random_metrics["max_interval"] = random_schedule.max_interval
    random_metrics["samples"] = float(trajs["random"].signals["samples"][-1])
    printed_metrics = trajectory_metrics(trajs["printed"])
    start = time.perf_counter()
    log("exact sampled-data bound")
    exact = exact_analysis(grid=200 if short else 400)
    timings["exact"] = time.perf_counter() - start
    start = time.perf_counter()
    log("LMI bisection (corrected and printed forms)")
    lmi = lmi_analysis(tol=1e-3 if short else LMI_TOLERANCE)
    timings["lmi"] = time.perf_counter() - start
    metrics.update(
        {
            "lmi_tau_max": lmi["lmi_tau_max"],
            "lmi_tau_max_per_mode": lmi["lmi_tau_max_per_mode"],
            "lmi_tau_max_printed": lmi["lmi_tau_max_printed"],
            "lmi_feasible_at_0_26": lmi["lmi_feasible_at_0_26"],
            "exact_h_star": exact["exact_h_star"],
            "spectral_radius_at_0_26": exact["spectral_radius_at_0_26"],
            "printed_L1_consensus_value": printed_metrics["consensus_value"],
        }
    )
    metrics["random_sampling"] = random_metrics
    metrics["printed_L1"] = printed_metrics
    metrics["mode_spectral_radii_at_0_26"] = exact["mode_spectral_radii_at_0_26"]
    metrics["decay_rate_at_0_26"] = exact["decay_rate_at_0_26"]
    metrics["l2_eigenvalues"] = exact["l2_eigenvalues"]
    metrics["lmi"] = {k: v for k, v in lmi.items() if k not in metrics}
    metrics["lmi_printed_feasible_at_0_26"] = lmi["lmi_printed_feasible_at_0_26"]
    start = time.perf_counter()
    log("simulations at h* -/+ 0.004 s")
    metrics["threshold_check"] = threshold_check(
        exact["exact_h_star"], periods=60 if short else THRESHOLD_PERIODS
    )
    timings["threshold_check"] = time.perf_counter() - start
    start = time.perf_counter()
    log("textbook sampled-data example")
    metrics["textbook_example"] = textbook_example(tol=1e-3 if short else LMI_TOLERANCE)
    timings["textbook"] = time.perf_counter() - start
    exact_check = sampled_response(network(), initial_state().x, jnp.full(40, TAU))
    saved = np.asarray(trajs["periodic"].states.plant.x)[:: round(TAU / DT / SAVE_EVERY)][:41]
    metrics["ode_vs_exact_discretisation"] = float(np.max(np.abs(saved - np.asarray(exact_check))))
    if short:
        metrics["autodiff"] = None
    else:
        start = time.perf_counter()
        log("autodiff study on rho1")
        metrics["autodiff"] = autodiff_study()
        timings["autodiff"] = time.perf_counter() - start
    metrics["claims"] = claims(metrics)
    metrics["settings"] = {
        "dt": DT,
        "horizon": HORIZON,
        "tau": TAU,
        "integrator": "RK4 (classic), intra-group coupling continuous, inter-layer held",
        "random_seed": RANDOM_SEED,
        "random_intervals": "uniform on the grid points of (0, tau]",
        "short": short,
    }
    metrics["timings"] = timings
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    # The LMI bounds are cvxpy's and Clarabel's numbers: their versions are recorded too.
    written = write_report(out / "metrics.json", metrics, also=("cvxpy", "clarabel"))
    _write_figures(out, trajs, exact, metrics)
    return written


def _write_figures(out: pathlib.Path, trajs: dict, exact: dict, metrics: dict) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    titles = {
        "periodic": "Fig. 2 equivalent: periodic sampling, h = 0.26 s (corrected L1)",
        "random": "Fig. 3 equivalent: random intervals in (0, 0.26] s (corrected L1)",
        "printed": "Printed L1 (row 3 sums to 2): the average is lost, all agents go to 0",
    }
    with plot.style():
        for name, traj in trajs.items():
            ts = np.asarray(traj.ts)
            x = np.asarray(traj.states.plant.x).reshape(len(ts), -1)
            fig, ax = plt.subplots(figsize=(7, 3.4), layout="constrained")
            for i in range(x.shape[1]):
                ax.plot(ts, x[:, i], lw=1.0, color=f"C{i // AGENTS}")
            ax.axhline(6.0, color="k", ls="--", lw=0.7)
            plot.mark_failure(ax, traj)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=8)
            ax.set_xlim(0, 20)
            ax.set_xlabel("t [s]")
            ax.set_ylabel("$x_{n,m}$ (colour: group)")
            ax.set_title(titles[name])
            fig.savefig(out / f"consensus_{name}.png")
            plt.close(fig)

        hs, radii = exact["curve"]["h"], exact["curve"]["radii"]
        fig, ax = plt.subplots(figsize=(7, 3.6), layout="constrained")
        for k, lam in enumerate(exact["l2_eigenvalues"][1:]):
            ax.plot(hs, radii[:, k], lw=1.2, label=f"mode $\\lambda_{k + 2}$ = {lam:.0f}")
        ax.axhline(1.0, color="k", lw=0.7)
        ax.axvline(
            metrics["exact_h_star"],
            color="C3",
            ls="--",
            lw=1.0,
            label=f"exact $h^*$ = {metrics['exact_h_star']:.4f} s",
        )
        ax.axvline(
            metrics["lmi_tau_max"],
            color="C2",
            ls=":",
            lw=1.2,
            label=f"LMI $\\tau_{{max}}$ = {metrics['lmi_tau_max']:.4f} s",
        )
        ax.axvline(TAU, color="0.5", ls="-.", lw=0.8, label="paper's 0.26 s")
        ax.set_xlabel("sampling period h [s]")
        ax.set_ylabel("spectral radius of $F_k(h)$")
        ax.legend(fontsize=8)
        ax.set_title("Periodic sampling: one-period spectral radius per mode")
        fig.savefig(out / "spectral_radius.png")
        plt.close(fig)


SCENARIO = Scenario(
    name="duan2024",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=trajectory_metrics,
)
