r"""Yue & Li (2018): adaptive terminal sliding-mode control of coupled translation and attitude
(SPEC seed 001(d)).

Yue B, Li X. "Adaptive terminal sliding mode control for spacecraft with translation and
attitude maneuvers", Journal of Dynamics and Control 16(4):332-337, 2018,
DOI 10.6052/1672-6553-2018-025.

**Set-up (Table 1, eqs. 26-29; SPEC "Decisions taken", 001(d)).** [`jaxatt.plants.SixDof`][]
with $m(t) = 100 + 5\sin 0.5t$ kg, $J(t) = J_0 + \mathrm{diag}(\sin 0.1t, 2\sin 0.2t,
3\sin 0.3t)$, $J_0$ symmetrised from the printed upper triangle
$[[1000, -50, -10], [\cdot, 1000, -40], [\cdot, \cdot, 800]]$ kg m^2; body-frame disturbances
$d_f = 10[\sin(\pi t/100), \sin(2\pi t/100), \sin(3\pi t/100)] + 10[\delta(180, 2),
\delta(190, 2), \delta(200, 2)]$ N and $d_\tau$ the same with 0.5 N m ("sin(pi100t)" read as
$\sin(\pi t/100)$; pulses on $[t_i, t_i + 2)$, edges on the step grid). Start
$R(0) = (-10, 10, 20)$ m, $V(0) = 0$, $q(0)$ = normalise$(0.8832, 0.3, -0.2, -0.3)$ (scalar
first; the printed 0.893 is read as 0.8832), $\omega(0) = (0.01, -0.02, 0.01)$ rad/s; target
$R_d = 0$, $q_d = 1$. Classic RK4, dt = 0.01 s, control in every stage, horizon 250 s.

**Gains.** Printed: $\kappa_1 = 0.02$, $\kappa_2 = 0.001$, $\kappa_3 = 0.2$, $\kappa_4 = 0.25$,
$r = 0.7$, $p = 0.6$, $\varepsilon_0 = \varepsilon_1 = 0.2$, $\zeta_0 = 50$, $\zeta_1 = 70$ (the
printed lower bounds), $\sigma = 0.1m = 10$, estimates 0 at $t = 0$. Not printed (SPEC):
$\lambda_1 = 0.2$, $\lambda_2 = 0.05$, $p_0 = p_1 = 1$, boundary widths 0.01 m/s.
[`AdaptiveTerminalSixDof`][jaxatt.controllers.AdaptiveTerminalSixDof] with the
Lyapunov-consistent adaptive regressors (`literal=True`: as printed).

**Tuned gains** (`TUNED_GAINS`): found by gradient descent with `jaxatt.tune`'s optax loop
machinery on a smooth surrogate of the paper's claims (see `tune_gains`); reported side by
side with the printed set in `metrics.json`.

**Claims checked** (`claims`): position converged by 50 s and attitude by 35 s (here:
$\|R(50)\| < 0.1$ m and the attitude error angle at 35 s below 1 deg), and the pulses at
180, 190, 200 s rejected (the position deviation they cause returns below 0.1 m by 250 s).
With the printed $\kappa_1, \kappa_2$ the surface alone needs hundreds of seconds
(SPEC 001(d) [V]: on $S_1 = 0$, $R(50) = (-3.57, 3.57, 7.18)$ m), so the 50 s claim cannot
hold with them.
"""

import math
import pathlib

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..controllers import AdaptiveTerminalSixDof
from ..metrics import settling_time
from ..numerics import amax
from ..plants import SixDof, SixDofState
from ..references import ConstantPose
from ..rotations import quat_normalize
from ..signals import AbstractSignal, Pulse, Sinusoid
from ..simulation import ClosedLoop, EnergyMeter, Status, Trajectory, simulate
from ._io import write_report
from ._protocol import Scenario


TITLE = "Yue & Li 2018: adaptive terminal sliding mode for coupled 6-DOF translation and attitude"
MASS = 100.0
INERTIA = ((1000.0, -50.0, -10.0), (-50.0, 1000.0, -40.0), (-10.0, -40.0, 800.0))
R0 = (-10.0, 10.0, 20.0)
Q0 = (0.8832, 0.3, -0.2, -0.3)
OMEGA0 = (0.01, -0.02, 0.01)
HORIZON = 250.0
SHORT_HORIZON = 60.0
DT = 0.01
SAVE_EVERY = 10
PULSES = (180.0, 190.0, 200.0)

PRINTED_GAINS = {
    "k1": 0.02,
    "k2": 0.001,
    "exponent": 0.7,
    "k3": 0.2,
    "k4": 0.25,
    "boundary": 0.01,
    "zeta0": 50.0,
    "zeta1": 70.0,
    "lambda1": 0.2,
    "lambda2": 0.05,
    "p": 0.6,
    "sigma": 10.0,
    "eps0": 0.2,
    "eps1": 0.2,
    "p0": 1.0,
    "p1": 1.0,
}
"""The printed gains plus SPEC's choices for the missing ones (lambda1, lambda2, p0, p1, e_i)."""

TUNED_PARAMETERS = ("k1", "k2", "k3", "k4", "lambda1", "lambda2", "sigma")
"""The gains `tune_gains` adjusts (the rest stay at their printed values)."""

TUNING_START = {
    "k1": 0.05,
    "k2": 0.01,
    "k3": 10.0,
    "k4": 50.0,
    "lambda1": 0.1,
    "lambda2": 0.05,
    "sigma": 20.0,
}
"""The tuning's starting point (it meets neither claim)."""

FORCE_LIMIT = 500.0
TORQUE_LIMIT = 50.0
"""The limits the tuned gains must respect: max |f_i| <= 500 N (5 m/s^2 on 100 kg) and
max |tau_i| <= 50 N m."""

TUNED_GAINS = dict(
    PRINTED_GAINS,
    k1=0.06491,
    k2=0.1021,
    k3=15.62,
    k4=225.1,
    lambda1=0.1743,
    lambda2=0.09524,
    sigma=96.97,
)
"""`tune_gains(steps=40)` from `TUNING_START` (the best of 40 Adam steps), rounded to 4 digits;
stored so that `reproduce` does not re-tune. Re-run 2026-12-06 (00:37 UTC, the 2-core Xeon,
XLA defaults, a fresh process): the same gains to 4 digits, best loss 0.0325 (this docstring
said 0.0407 before, with no record of how it was measured), 33.4 s and 34.6 s wall in two
runs, compilation included."""


def disturbances(scale: float) -> AbstractSignal:
    r"""$a[\sin(\pi t/100), \sin(2\pi t/100), \sin(3\pi t/100)] + a[\delta(180,2), \delta(190,2),
    \delta(200,2)]$."""
    periodic = Sinusoid(scale * jnp.ones(3), jnp.pi / 100 * jnp.array([1.0, 2.0, 3.0]))
    pulses = [Pulse(scale * jnp.eye(3)[i], start, 2.0) for i, start in enumerate(PULSES)]
    return periodic + pulses[0] + pulses[1] + pulses[2]


def plant() -> SixDof:
    return SixDof(
        MASS,
        jnp.array(INERTIA),
        mass_variation=Sinusoid(5.0, 0.5),
        inertia_variation=Sinusoid(
            jnp.diag(jnp.array([1.0, 2, 3])), jnp.diag(jnp.array([0.1, 0.2, 0.3]))
        ),
        force_disturbance=disturbances(10.0),
        torque_disturbance=disturbances(0.5),
    )


def initial_state() -> SixDofState:
    return SixDofState(
        jnp.array(R0), jnp.zeros(3), quat_normalize(jnp.array(Q0)), jnp.array(OMEGA0)
    )


def build(
    gains: dict | None = None,
    *,
    literal: bool = False,
    adaptive: bool = True,
    attitude_boundary: float | None = None,
) -> ClosedLoop:
    r"""The closed loop with `gains` (default: the printed set); `adaptive=False` is (22) with
    the true nominal mass and the force bound $F = 10\sqrt3 + 10$ N; `attitude_boundary`
    replaces the sign of (25) by a boundary layer (for gradients)."""
    gains = PRINTED_GAINS if gains is None else gains
    controller = AdaptiveTerminalSixDof(
        **gains,
        literal=literal,
        adaptive=adaptive,
        mass=MASS,
        force_bound=10.0 * math.sqrt(3) + 10,
        attitude_boundary=attitude_boundary,
    )
    return ClosedLoop(plant(), controller, ConstantPose(), EnergyMeter())


def run(gains: dict | None = None, horizon: float = HORIZON, **options) -> Trajectory:
    return simulate(
        build(gains, **options), initial_state(), 0.0, horizon, dt=DT, save_every=SAVE_EVERY
    )


def tuning_objective(
    values: Float[ArrayLike, " n"],
    *,
    horizon: float = 50.0,
    dt: float = DT,
    boundary: float = 1e-3,
    position_time: float = 50.0,
    attitude_time: float = 35.0,
) -> tuple[Float[Array, ""], dict[str, Float[Array, ""]]]:
    r"""Smooth loss of the paper's claims for the gains `values` (an array in the order of
    `TUNED_PARAMETERS`), with the attitude sign replaced by a boundary layer of `boundary`
    rad/s so that the loss is differentiable:

    $$L = \tfrac{1}{10}\mathrm{sp}\big(10\ln\frac{\|R(50)\|}{0.05\,m}\big)
    + \tfrac{1}{10}\mathrm{sp}\big(10\ln\frac{\phi(35)}{0.5^\circ}\big)
    + \mathrm{sp}\big(\frac{\max|f_i| - 0.9F}{0.05F}\big)
    + \mathrm{sp}\big(\frac{\max|\tau_i| - 0.9T}{0.05T}\big)
    + 10^{-3}\textstyle\sum\ln g,$$

    `sp` = softplus: each claim is met with a factor-2 margin (0.05 m, 0.5 deg) when its term
    is small; the last term prefers smaller gains. `position_time`, `attitude_time` (50 s,
    35 s: the claims) and `horizon` can be shortened for tests. Returns `(loss, aux)`.
    """
    gains = dict(PRINTED_GAINS, **dict(zip(TUNED_PARAMETERS, values)))
    loop = build(gains, attitude_boundary=boundary)
    traj = simulate(loop, initial_state(), 0.0, horizon, dt=dt, save_every=SAVE_EVERY, throw=False)
    ts = traj.ts
    norm = jnp.interp(position_time, ts, traj.signals["position_norm"])
    angle = jnp.degrees(jnp.interp(attitude_time, ts, traj.signals["attitude_error_angle"]))
    u = traj.signals["u"]
    peak_force = amax(jnp.abs(u[:, :3]))
    peak_torque = amax(jnp.abs(u[:, 3:]))
    sp = jax.nn.softplus
    loss = (
        0.1 * sp(10 * jnp.log(norm / 0.05))
        + 0.1 * sp(10 * jnp.log(angle / 0.5))
        + sp((peak_force - 0.9 * FORCE_LIMIT) / (0.05 * FORCE_LIMIT))
        + sp((peak_torque - 0.9 * TORQUE_LIMIT) / (0.05 * TORQUE_LIMIT))
        + 1e-3 * jnp.sum(jnp.log(jnp.asarray(values)))
    )
    aux = {
        "position_norm_at_50s": norm,
        "attitude_angle_deg_at_35s": angle,
        "peak_force": peak_force,
        "peak_torque": peak_torque,
    }
    return loss, aux


def tune_gains(steps: int = 40, learning_rate: float = 0.1, progress: bool = False) -> dict:
    """Adam on the logarithms of the `TUNED_PARAMETERS` from `TUNING_START`, minimising
    [`tuning_objective`][] (gradients by reverse-mode autodiff through the 50 s closed loop).
    Returns the best gains found and the loss history."""
    import optax

    names = TUNED_PARAMETERS
    log_values = jnp.log(jnp.array([TUNING_START[n] for n in names]))

    @jax.jit
    def loss_and_grad(z):
        return jax.value_and_grad(lambda z: tuning_objective(jnp.exp(z)), has_aux=True)(z)

    optimizer = optax.adam(learning_rate)
    opt_state = optimizer.init(log_values)
    history, best = [], (math.inf, None, None)
    for step in range(steps):
        (loss, aux), grad = loss_and_grad(log_values)
        loss = float(loss)
        history.append({"step": step, "loss": loss, **{k: float(v) for k, v in aux.items()}})
        if progress:
            print(
                f"[yue2018 tune] step {step}: loss {loss:.4g}",
                {k: round(float(v), 4) for k, v in aux.items()},
            )
        if loss < best[0]:
            best = (loss, np.exp(np.asarray(log_values)), aux)
        updates, opt_state = optimizer.update(grad, opt_state)
        log_values = optax.apply_updates(log_values, updates)
    gains = {n: float(v) for n, v in zip(names, best[1])}
    return {"gains": gains, "history": history}


def _at(ts, x, t):
    return float(np.interp(t, np.asarray(ts), np.asarray(x)))


def _json(value):
    value = float(value)
    return value if math.isfinite(value) else None


def trajectory_metrics(traj: Trajectory) -> dict:
    ts = np.asarray(traj.ts)
    norm = np.asarray(traj.signals["position_norm"])
    angle_deg = np.degrees(np.asarray(traj.signals["attitude_error_angle"]))
    u = np.asarray(traj.signals["u"])
    out = {
        "position_norm_at_50s": _at(ts, norm, 50.0),
        "attitude_angle_deg_at_35s": _at(ts, angle_deg, 35.0),
        "attitude_settle_time_1deg": _json(settling_time(ts, angle_deg, 1.0)),
        "position_settle_time_0.1m": _json(settling_time(ts, norm, 0.1)),
        "peak_force": float(np.max(np.abs(u[:, :3]))),
        "peak_torque": float(np.max(np.abs(u[:, 3:]))),
        "final_position_norm": float(norm[-1]),
        "final_attitude_angle_deg": float(angle_deg[-1]),
        "energy": float(traj.signals["energy"][-1]),
        "status": int(traj.status),
    }
    if ts[-1] >= PULSES[-1] + 10:
        before = norm[(ts >= PULSES[0] - 10) & (ts < PULSES[0])]
        during = norm[(ts >= PULSES[0]) & (ts <= PULSES[-1] + 10)]
        out["position_norm_before_pulses"] = float(np.max(before))
        out["position_peak_during_pulses"] = float(np.max(during))
    return out


def claims(m: dict) -> dict:
    """The paper's claims on one run's metrics; none holds for a run that did not end
    successfully (its samples after the failure are not a converged state)."""
    ok = m["status"] == int(Status.successful)
    out = {
        "position_converged_by_50s (|R| < 0.1 m)": ok and m["position_norm_at_50s"] < 0.1,
        "attitude_converged_by_35s (angle < 1 deg)": ok and m["attitude_angle_deg_at_35s"] < 1.0,
    }
    if "position_peak_during_pulses" in m:
        out["pulses_rejected (|R(250)| < 0.1 m)"] = ok and m["final_position_norm"] < 0.1
    return out


def reproduce(out_dir: str | pathlib.Path, *, short: bool = False, progress: bool = False) -> dict:
    """Printed and tuned gains side by side; figures and `metrics.json`.

    `short=True` (CI): 60 s (the 50 s and 35 s claims, not the pulses).
    """
    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    horizon = SHORT_HORIZON if short else HORIZON
    metrics: dict = {
        "settings": {
            "horizon": horizon,
            "dt": DT,
            "integrator": "RK4, continuous control",
            "inertia": INERTIA,
            "q0": Q0,
            "R0": R0,
        },
    }
    trajs = {}
    for name, gains in (("printed_gains", PRINTED_GAINS), ("tuned_gains", TUNED_GAINS)):
        if progress:
            print(f"[yue2018] {name}")
        traj = run(gains, horizon)
        trajs[name] = traj
        m = trajectory_metrics(traj)
        m["gains"] = dict(gains)
        m["claims"] = claims(m)
        metrics[name] = m
    # The numbers first: a figure that fails (e.g. on a failed run's NaN) leaves them.
    written = write_report(out / "metrics.json", metrics)
    _write_figures(out, trajs)
    return written


def _write_figures(out: pathlib.Path, trajs: dict) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    with plot.style():
        fig, axes = plt.subplots(2, 2, figsize=(10, 6), layout="constrained")
        for name, traj in trajs.items():
            ts = np.asarray(traj.ts)
            label = name + plot.status_label(traj.status, traj.failure_time)
            axes[0, 0].plot(ts, np.asarray(traj.signals["position_norm"]), label=label)
            axes[0, 1].semilogy(
                ts, np.degrees(np.asarray(traj.signals["attitude_error_angle"])) + 1e-9, label=label
            )
            u = np.asarray(traj.signals["u"])
            axes[1, 0].plot(ts, u[:, :3], lw=0.6)
            axes[1, 1].plot(ts, u[:, 3:], lw=0.6)
        axes[0, 0].set_ylabel("$\\|R\\|$ [m]")
        axes[0, 1].set_ylabel("attitude error [deg]")
        axes[1, 0].set_ylabel("force [N]")
        axes[1, 1].set_ylabel("torque [N m]")
        axes[0, 0].legend()
        for ax in axes[1]:
            ax.set_xlabel("t [s]")
        fig.suptitle("Yue & Li 2018: position, attitude, force and torque (Figs. 2-8 equivalent)")
        fig.savefig(out / "fig_yue2018.png")
        plt.close(fig)


SCENARIO = Scenario(
    name="yue2018",
    title=TITLE,
    build=build,
    reproduce=reproduce,
    metrics=trajectory_metrics,
)
