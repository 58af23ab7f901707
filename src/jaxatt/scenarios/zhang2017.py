r"""Zhang, Du, Yue, Xu (2017): integer PD versus fractional PD$^\alpha$ sliding-mode control of
close-range relative orbits (SPEC seed 001(e)).

Zhang Y, Du L, Yue X, Xu Y. "Sliding-mode control of close-range relative orbits", Journal of
Dynamics and Control 15(1):87-92, 2017, DOI 10.6052/1672-6553-2016-040.

**Set-up (SPEC "Decisions taken", 001(e)).** Target on a circular orbit, a = 7178.145 km,
$\mu$ = 3.986004418e14, $\theta(0) = 0$, its true anomaly integrated as a state; the chaser's
exact nonlinear relative motion ([`jaxatt.plants.RelativeOrbit`][], Hill frame: x radial out,
y along-track, z orbit normal) from $\rho(0) = (-60, 35, -50)$ m,
$\dot\rho(0) = (-5, 10, -8)$ m/s to $\rho_d = 0$. Gains (not printed), the same for both laws:
$c = 0.5$, $k = 1$, $\varepsilon = 0.3$, $\alpha = 0.8$; horizon 200 s.
Disturbed case (18): $d = 0.2\cos(2t)[1, 1, 1]$ m/s^2 added to $\ddot\rho$.

**Sign of the error.** SPEC's decision (and the paper) write $e = \rho_d - \rho = -\rho$;
jaxatt's controllers take $e = \rho - \rho_d = \rho$ (state minus reference, as every
controller of the library). The surfaces $s$ and $S$ change sign, and nothing else does: each
law's $u$ is the one that makes $\dot s$ (affine in $u$) equal the reaching law, and the laws
are odd, so $\dot s = -\varepsilon\,\mathrm{sgn}\,s - ks$ holds for $s$ exactly when it holds
for $-s$: the control and the trajectories are the same. Reported surfaces (e.g. `s0` =
$(-35, 27.5, -33)$) carry jaxatt's sign.

- PD, eq. (11): [`jaxatt.controllers.TranslationalSlidingMode`][] with
  `PDSurface(c)` and `Exponential(k, eps)` ($\dot s = -\varepsilon\,\mathrm{sgn}\,s - ks$).
- PD$^\alpha$, eqs. (12), (17): [`jaxatt.controllers.FractionalSlidingMode`][]: Caputo
  surface (GL of $e - e(0)$, so $S(0) = ce(0)$), Riemann-Liouville $D^{1-\alpha}$ of the
  bracket, GL weights, **full memory** (20 001 samples of each memory).
- Digital control on $t_k = kh$, $h = 0.01$ s: $u_k$ from the state at $t_k$, held over the
  step (`ZeroOrderHold(0.01)`); classic RK4 with step $h$, for both laws. `sign(0) = 0`.

**Errata (SPEC 001(e)).** The frame described in the text (z to the Earth) disagrees with the
equations; the equations' radial frame is used. (14)-(16) drop the term
$\dot e(0)t^{-\alpha}/\Gamma(1-\alpha)$ when differentiating the fractional integral: the law
(17) therefore does not make $S$ follow the reaching law exactly (see `metrics.json`: the
fractional $S$ has no finite reaching time to report). (17)'s $B'^{-1}$ of a 6x3 matrix is read
as $-I_3$. The disturbance (18) is read as an acceleration $Bd$.

**Metrics** (`metrics.json`): for each case and law, `settle_time_10m`, `settle_time_1m`
(last time $\|\rho\|$ leaves the band, interpolated between saved samples: every step for PD,
every `FRACTIONAL_SAVE_EVERY` steps for PD$^\alpha$, whose saved state holds its two memories),
`final_position_norm` [m], `energy` $\int\|u\|^2dt$ [m^2/s^3] (integrated exactly in the loop by
[`jaxatt.simulation.EnergyMeter`][]), `peak_control` $\max|u_i|$ over the saved samples
[m/s^2], and for PD `reaching_time_axis` (first zero of each $s_i$, interpolated) next to the
closed form of the reaching law and its forward-Euler (held control) value.
"""

import math
import pathlib
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from .._custom_types import RealScalarLike
from ..controllers import FractionalSlidingMode, TranslationalSlidingMode
from ..metrics import settling_time
from ..plants import RelativeOrbit, RelativeOrbitState
from ..reaching import AbstractSwitching, Exponential, Sign
from ..references import ConstantPosition
from ..signals import Sinusoid
from ..simulation import ClosedLoop, EnergyMeter, Status, Trajectory, ZeroOrderHold, simulate
from ..sliding import PDSurface
from ._io import write_report
from ._protocol import Scenario


TITLE = "Zhang 2017: PD vs fractional PD^alpha sliding mode for close-range relative orbits"
SEMI_MAJOR_AXIS = 7178.145e3
MU = 3.986004418e14
RHO0 = (-60.0, 35.0, -50.0)
RHO_DOT0 = (-5.0, 10.0, -8.0)
SLOPE, K, EPS, ALPHA = 0.5, 1.0, 0.3, 0.8
HORIZON = 200.0
SHORT_HORIZON = 20.0
STEP = 0.01
FRACTIONAL_SAVE_EVERY = 50
CONTROLLERS = ("pd", "pd_alpha")
CASES = ("undisturbed", "disturbed")


def disturbance(amplitude: float = 0.2) -> Sinusoid:
    r"""Eq. (18): $0.2\cos(2t)[1, 1, 1]$ m/s^2 (`amplitude` = 0.2)."""
    return Sinusoid(amplitude * jnp.ones(3), 2.0, phase=math.pi / 2)


def plant(disturbed: bool = False) -> RelativeOrbit:
    """The nonlinear relative motion; the undisturbed case is the same signal with amplitude 0,
    so both cases share one compiled program."""
    return RelativeOrbit(SEMI_MAJOR_AXIS, 0.0, MU, disturbance(0.2 if disturbed else 0.0))


def initial_state() -> RelativeOrbitState:
    return RelativeOrbitState(jnp.asarray(0.0), jnp.asarray(RHO0), jnp.asarray(RHO_DOT0))


def build(
    controller: str = "pd",
    disturbed: bool = False,
    *,
    slope: RealScalarLike = SLOPE,
    k: RealScalarLike = K,
    eps: RealScalarLike = EPS,
    alpha: RealScalarLike = ALPHA,
    horizon: float = HORIZON,
    memory: float | None = None,
    caputo: bool = True,
    switching: AbstractSwitching = Sign(),
) -> ClosedLoop:
    """The closed loop of one law (`"pd"` or `"pd_alpha"`), undisturbed or disturbed.

    The controllers' model is the exact (undisturbed) nonlinear relative motion. `horizon`
    sizes the fractional law's full memory; `memory` (s) truncates it; `caputo=False` is the
    other reading of the surface (12); `switching` replaces sgn (e.g. a boundary layer).
    """
    model = plant(False)
    law = Exponential(k, eps, switching)
    if controller == "pd":
        ctrl = TranslationalSlidingMode(model, PDSurface(slope), law)
    elif controller == "pd_alpha":
        ctrl = FractionalSlidingMode(model, slope, law, alpha, STEP, horizon, memory, caputo=caputo)
    else:
        raise ValueError(
            f"zhang2017.build: `controller` must be one of {CONTROLLERS}, got {controller!r}."
        )
    return ClosedLoop(plant(disturbed), ctrl, ConstantPosition(), EnergyMeter())


def save_every(controller: str) -> int:
    return 1 if controller == "pd" else FRACTIONAL_SAVE_EVERY


def run(controller: str, disturbed: bool, horizon: float = HORIZON, **options) -> Trajectory:
    """Simulate one law under the paper's digital control (ZOH at h = 0.01 s, RK4 step h)."""
    loop = build(controller, disturbed, horizon=horizon, **options)
    return simulate(
        loop,
        initial_state(),
        0.0,
        horizon,
        dt=STEP,
        sampling=ZeroOrderHold(STEP),
        save_every=save_every(controller),
    )


ALPHA_STUDY = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
ALPHA_STUDY_HORIZON = 60.0


def alpha_study(
    alphas: Sequence[RealScalarLike] = ALPHA_STUDY,
    horizon: float = ALPHA_STUDY_HORIZON,
    disturbed: bool = False,
) -> dict:
    """Convergence time (to 10 m) and control energy of PD$^\\alpha$ as functions of
    $\\alpha$ (the trade-off of the abstract), with PD for reference: one compiled program
    vmapped over `alphas` (full memory over `horizon`)."""

    def one(alpha):
        traj = run("pd_alpha", disturbed, horizon, alpha=alpha)
        return (
            settling_time(traj.ts, traj.signals["position_norm"], 10.0),
            traj.signals["energy"][-1],
        )

    t10, energy = jax.jit(jax.vmap(one))(jnp.asarray(alphas))
    pd = run("pd", disturbed, horizon)
    return {
        "horizon": horizon,
        "alpha": [float(a) for a in alphas],
        "settle_time_10m": [_json(v) for v in np.asarray(t10)],
        "energy": [float(v) for v in np.asarray(energy)],
        "pd_settle_time_10m": _json(settling_time(pd.ts, pd.signals["position_norm"], 10.0)),
        "pd_energy": float(pd.signals["energy"][-1]),
    }


def first_zero_times(
    ts: Float[ArrayLike, " t"], s: Float[ArrayLike, "t k"], band: float = 0.0
) -> Float[np.ndarray, " k"]:
    """Per column, the first time `s` reaches 0 from its initial sign; inf if it never does.

    A sign change is located by linear interpolation between the two samples around it. A
    column may also stop short of 0 inside `band` (under continuous control, RK4 stages that
    straddle $s = 0$ average the sign and hold $|s|$ at about 1e-5 instead of crossing): the
    crossing is then extrapolated linearly from the two samples before the band.
    """
    ts, s = np.asarray(ts), np.asarray(s)
    out = []
    for i in range(s.shape[1]):
        x = s[:, i] * np.sign(s[0, i])
        hit = np.nonzero(x <= band)[0]
        if hit.size == 0:
            out.append(math.inf)
            continue
        j = hit[0]
        if j == 0:
            out.append(float(ts[0]))
            continue
        if x[j] > 0 and j >= 2:  # stopped inside the band: extrapolate from before it
            j -= 1
        out.append(float(ts[j - 1] + x[j - 1] / (x[j - 1] - x[j]) * (ts[j] - ts[j - 1])))
    return np.array(out)


def reaching_time_closed_form(
    s0: Float[ArrayLike, "*k"], k: RealScalarLike = K, eps: RealScalarLike = EPS
) -> Float[np.ndarray, "*k"]:
    """$T = \\ln(1 + k|s_0|/\\varepsilon)/k$ (continuous reaching law)."""
    return np.asarray(Exponential(k, eps).convergence_time(jnp.asarray(s0)))


def reaching_time_held(
    s0: Float[ArrayLike, "*k"],
    k: RealScalarLike = K,
    eps: RealScalarLike = EPS,
    h: RealScalarLike = STEP,
) -> Float[np.ndarray, " m"]:
    """First zero of the forward-Euler sequence $s_{j+1} = s_j - h(\\varepsilon + k s_j)$
    ($s > 0$; the reaching law under a held control), linearly interpolated in the step."""
    out = []
    for value in np.abs(np.asarray(s0, dtype=float)):
        t, s = 0.0, value
        while s - h * (eps + k * s) > 0:
            s -= h * (eps + k * s)
            t += h
        out.append(t + h * s / (h * (eps + k * s)))
    return np.array(out)


def _json(value):
    value = float(value)
    return value if math.isfinite(value) else None


def trajectory_metrics(traj: Trajectory) -> dict:
    ts = traj.ts
    norm = traj.signals["position_norm"]
    u = np.asarray(traj.signals["u"])
    out = {
        "settle_time_10m": _json(settling_time(ts, norm, 10.0)),
        "settle_time_1m": _json(settling_time(ts, norm, 1.0)),
        "final_position_norm": float(norm[-1]),
        "energy": float(traj.signals["energy"][-1]),
        "peak_control": float(np.max(np.abs(u))),
        "save_period": float(ts[1] - ts[0]),
        "status": int(traj.status),
    }
    return out


def claims(metrics: dict) -> dict:
    """The paper's claims evaluated on the reproduction's numbers, per case; the two ratios
    are None unless both runs ended successfully (a failed run's time or energy is not a
    number to compare)."""

    def t(value):
        return math.inf if value is None else value

    out = {}
    for case in CASES:
        pd, fr = metrics[case]["pd"], metrics[case]["pd_alpha"]
        # A comparison holds only if both runs ended successfully (a failed PD run's infinite
        # time would otherwise make PD^alpha "need less control time").
        ok = pd["status"] == int(Status.successful) and fr["status"] == int(Status.successful)
        ratio = t(fr["settle_time_1m"]) / t(pd["settle_time_1m"])
        out[case] = {
            "both_converge_to_1m": ok
            and math.isfinite(t(pd["settle_time_1m"]))
            and math.isfinite(t(fr["settle_time_1m"])),
            "settle_time_ratio_pd_alpha_over_pd": ratio if ok else None,
            "pd_alpha_needs_less_control_time": ok and ratio < 1.0,
            "pd_alpha_needs_much_less_control_time (ratio < 0.5)": ok and ratio < 0.5,
            "pd_alpha_consumes_more_energy": ok and fr["energy"] > pd["energy"],
            "energy_ratio_pd_alpha_over_pd": fr["energy"] / pd["energy"] if ok else None,
        }
    return out


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """Simulate both laws, undisturbed and disturbed; write the figures and `metrics.json`.

    `short=True` (CI): a 20 s horizon (PD is inside 1 m by then, at 10.35 s; PD$^\alpha$ only
    inside 10 m, at 10.74 s: it reaches 1 m at 101.5 s).
    """
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    horizon = SHORT_HORIZON if short else HORIZON
    trajs: dict = {}
    metrics: dict = {
        "settings": {
            "horizon": horizon,
            "step": STEP,
            "sampling": "zero-order hold at h, classic RK4 at h",
            "gains": {"c": SLOPE, "k": K, "eps": EPS, "alpha": ALPHA},
            "memory": "full (Caputo surface, Riemann-Liouville D^(1-alpha))",
            "rho0": RHO0,
            "rho_dot0": RHO_DOT0,
        }
    }
    for case in CASES:
        metrics[case] = {}
        for name in CONTROLLERS:
            if progress:
                print(f"[zhang2017] {case}: {name}")
            traj = run(name, case == "disturbed", horizon)
            trajs[case, name] = traj
            metrics[case][name] = trajectory_metrics(traj)
        pd = trajs[case, "pd"]
        s0 = np.asarray(pd.signals["s"][0])
        metrics[case]["pd"]["s0"] = s0.tolist()
        metrics[case]["pd"]["reaching_time_axis"] = [
            _json(v) for v in first_zero_times(pd.ts, pd.signals["s"])
        ]
        metrics[case]["pd"]["reaching_time_closed_form"] = reaching_time_closed_form(s0).tolist()
        metrics[case]["pd"]["reaching_time_held_control"] = reaching_time_held(s0).tolist()
    metrics["claims"] = claims(metrics)
    if not short:
        if progress:
            print("[zhang2017] alpha study")
        metrics["alpha_study"] = alpha_study()
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    written = write_report(out / "metrics.json", metrics)
    _write_figures(out, trajs)
    return written


def _write_figures(out: pathlib.Path, trajs: dict) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    colors = {"pd": "C0", "pd_alpha": "C1"}
    labels = {"pd": "PD", "pd_alpha": r"PD$^\alpha$"}
    with plot.style():
        for case in CASES:
            fig, axes = plt.subplots(3, 2, figsize=(9, 7), sharex=True, layout="constrained")
            for name in CONTROLLERS:
                traj = trajs[case, name]
                ts = np.asarray(traj.ts)
                rho = np.asarray(traj.plant_states.rho)
                rho_dot = np.asarray(traj.plant_states.rho_dot)
                label = labels[name] + plot.status_label(traj.status, traj.failure_time)
                for i, axis in enumerate("xyz"):
                    axes[i, 0].plot(ts, rho[:, i], color=colors[name], label=label)
                    axes[i, 1].plot(ts, rho_dot[:, i], color=colors[name], label=label)
                    axes[i, 0].set_ylabel(f"${axis}$ [m]")
                    axes[i, 1].set_ylabel(f"$\\dot {axis}$ [m/s]")
            axes[0, 0].legend()
            for ax in axes[-1]:
                ax.set_xlabel("t [s]")
            fig.suptitle(f"Relative position and velocity ({case}), Figs. 1-2 / 4-5 equivalent")
            fig.savefig(out / f"fig_state_{case}.png")
            plt.close(fig)

            fig, axes = plt.subplots(3, 1, figsize=(8, 6), sharex=True, layout="constrained")
            for name in CONTROLLERS:
                traj = trajs[case, name]
                u = np.asarray(traj.signals["u"])
                label = labels[name] + plot.status_label(traj.status, traj.failure_time)
                for i, ax in enumerate(axes):
                    ax.plot(np.asarray(traj.ts), u[:, i], color=colors[name], lw=0.6, label=label)
                    ax.set_ylabel(f"$u_{'xyz'[i]}$ [m/s$^2$]")
            axes[0].legend()
            axes[-1].set_xlabel("t [s]")
            fig.suptitle(f"Control acceleration ({case}), Fig. 3 / 6 equivalent")
            fig.savefig(out / f"fig_control_{case}.png")
            plt.close(fig)


SCENARIO = Scenario(
    name="zhang2017",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=trajectory_metrics,
)
