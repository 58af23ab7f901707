r"""Vibration-aware autodiff tuning of Shi & Song (2024)'s TVSMC and command smoother.

Issue 16 item 6: tune the TVSMC gains $k_p$, $k(0)$, $\gamma_k$ and the smoother frequency
$\omega_k$ against the attitude convergence time, with a penalty on the residual modal energy
after the manoeuvre:

$$L = T_c + w\,\bar E_n,\qquad \bar E_n = \frac1W\int_{t_1 - W}^{t_1}
\tfrac12\big(\dot n^T\dot n + n^T K_s n\big)\,dt\ \text{[J]},$$

$T_c$ the tuner's convergence time ([`jaxatt.metrics.convergence_time`][]) of
$\max_i|q_{e,i}|$ to `TOLERANCE`, the attitude error taken against the **final** command (a
slow smoother cannot hide a slow manoeuvre), on the saved grid.

- **Loop for tuning:** the smoothed case without the observer (its relay $L\,\mathrm{sign}(s_1)$
  chatters at the step and has no useful derivative), `shi2024.shaped_template(False)`,
  starting from the smoother at 0.6258 rad/s (the Hz reading, a 20 s command).
- **Simulation:** `HORIZON` = 60 s, RK4 at `DT` = 2e-2 s, saves every 0.1 s; the energy
  window is the last `WINDOW` = 10 s.
- **Transforms:** $k_p \in (0, 1)$ (sigmoid), $k(0)$, $\gamma_k$, $\omega_k$ positive ($e^u$).
  Adam(0.05) after a global-norm clip of 1.
- **Trade-off:** one run per penalty weight $w$ (`WEIGHTS`), all sharing one compiled
  loss-and-gradient (the weight is an array of the objective). Each tuned point is then
  re-measured on the paper's case 1 (with the observer) at dt = 1e-2 s over 150 s.
"""

import pathlib
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
import optax
from jaxtyping import Array, Float, PyTree

from .. import tune as tuning
from .._custom_types import RealScalarLike
from .._versions import versions_sentence
from ..metrics import convergence_time
from ..numerics import amax
from ..plants import FlexibleSloshState
from ..rotations import attitude_error_quat
from ..simulation import AbstractClosedLoop, ClosedLoop, Simulation, Status, integrate
from . import shi2024
from ._io import write_report
from ._protocol import TuningProblem, require_checkpoint, select_optimizer


TOLERANCE = 1e-2
HORIZON = 60.0
DT = 2e-2
SAVE_PERIOD = 0.1
WINDOW = 10.0
START_FREQUENCY = 2 * np.pi * shi2024.SMOOTHER_FREQUENCY_LITERAL
WEIGHTS = (0.0, 100.0, 1000.0, 10000.0)
"""Penalty weights of the trade-off curve [s/J]."""
LEARNING_RATE = 0.05


def objectives(
    loop: AbstractClosedLoop,
    x0: PyTree[Array],
    sim: Simulation,
    tolerance: float | Array = TOLERANCE,
    window: float = WINDOW,
) -> tuple[Float[Array, ""], Float[Array, ""]]:
    """`(T_c, E_n)`: the attitude convergence time [s] and the mean modal energy over the
    last `window` s [J] of one run (traceable, differentiable).

    A run that failed (any [`jaxatt.simulation.Status`][] but `successful`: a non-finite
    state, a violated constraint, an invalid plant) has `T_c = inf` and `E_n = NaN`, the
    library's rule for a failed sample: its trajectory after the failure is not physical."""
    time, energy, status = _objectives_and_status(loop, x0, sim, tolerance, window)
    successful = status == Status.successful
    return jnp.where(successful, time, jnp.inf), jnp.where(successful, energy, jnp.nan)


def _objectives_and_status(loop, x0, sim, tolerance, window):
    """`objectives` before the failure rule, and the run's status code."""
    traj = integrate(loop, x0, sim)
    target = jnp.asarray(shi2024.Q_TARGET)
    error = jax.vmap(lambda q: attitude_error_quat(q, target)[1:])(traj.plant_states.q)
    att = amax(jnp.abs(error), axis=1)
    late = traj.ts >= traj.ts[-1] - window
    energy = jnp.sum(jnp.where(late, traj.signals["modal_energy"], 0.0)) / jnp.sum(late)
    return convergence_time(traj.ts, att, tolerance), energy, traj.status


def simulation(horizon: float = HORIZON, dt: float = DT) -> Simulation:
    sim = Simulation(
        0.0, horizon, dt, save_every=max(1, round(SAVE_PERIOD / dt)), where="shi2024_tuning"
    )
    return sim.with_performance(sim.performance.resolve(1))


class VibrationObjective(tuning.AbstractObjective):
    r"""$L = \mathrm{mean}(T_c) + w\,\mathrm{mean}(\bar E_n)$ over a (small) batch of initial
    states (see the module docstring); aux: per-sample `convergence_time` and
    `residual_modal_energy`. The samples are unrolled (no `vmap`: the batches are tiny and a
    `vmap` doubles the compile time). A failed sample (see `objectives`) makes the loss `inf`,
    and the aux holds `successful` and `status` (each sample's [`jaxatt.simulation.Status`][]
    code), as the library's objectives do (`tune`'s error counts the failed samples)."""

    weight: Float[Array, ""]
    simulation: Simulation
    tolerance: Float[Array, ""]
    window: float = eqx.field(static=True)

    def __init__(
        self,
        weight: float,
        horizon: float = HORIZON,
        dt: float = DT,
        tolerance: float = TOLERANCE,
        window: float = WINDOW,
    ):
        if not np.isfinite(weight) or weight < 0:
            raise ValueError(f"VibrationObjective: `weight` must be >= 0, got {weight}.")
        if not 0 < window < horizon:
            raise ValueError(
                f"VibrationObjective: `window` must lie in (0, horizon), got {window}."
            )
        self.weight = jnp.asarray(weight, jnp.result_type(float))
        self.simulation = simulation(horizon, dt)
        self.tolerance = jnp.asarray(tolerance, jnp.result_type(float))
        self.window = float(window)

    def check(self, loop, x0s) -> None:
        if not isinstance(loop, AbstractClosedLoop):
            raise ValueError("VibrationObjective: the tuned module must be a closed loop.")
        n = jnp.shape(jtu.tree_leaves(x0s)[0])[0]
        loop.check_state(x0s, "inputs", (n,))

    def __call__(self, loop, x0s):
        n = jnp.shape(jtu.tree_leaves(x0s)[0])[0]
        times, energies, statuses = [], [], []
        for i in range(n):
            x0 = jtu.tree_map(lambda x, i=i: x[i], x0s)
            t, e, status = _objectives_and_status(
                loop, x0, self.simulation, self.tolerance, self.window
            )
            times.append(t)
            energies.append(e)
            statuses.append(status)
        status = jnp.stack(statuses)
        successful = status == Status.successful
        times = jnp.where(successful, jnp.stack(times), jnp.inf)
        energies = jnp.where(successful, jnp.stack(energies), jnp.nan)
        loss = jnp.mean(times) + self.weight * jnp.mean(energies)
        # The library's rule (`jaxatt.tune`): a failed sample makes the loss inf (not the NaN
        # its energy would give, nor a finite value), so that `tune` stops on it.
        loss = jnp.where(jnp.all(successful), loss, jnp.inf)
        aux = {"convergence_time": times, "residual_modal_energy": energies}
        return loss, aux | {"successful": successful, "status": status}


def template(frequency: float = START_FREQUENCY) -> ClosedLoop:
    """The tuned loop: the paper's TVSMC without the observer, smoother at `frequency`."""
    loop = shi2024.shaped_template(False)
    return eqx.tree_at(
        lambda lp: lp.reference.shaper.frequency, loop, jnp.asarray(frequency, float)
    )


def parameters() -> dict[str, tuning.Parameter]:
    return {
        "kp": tuning.Parameter("controller.kp", tuning.Interval(0.0, 1.0)),
        "k0": tuning.Parameter("controller.k0", tuning.Positive()),
        "gamma_k": tuning.Parameter("controller.gamma_k", tuning.Positive()),
        "omega_k": tuning.Parameter("reference.shaper.frequency", tuning.Positive()),
    }


_OPTIMIZER = optax.chain(optax.clip_by_global_norm(1.0), optax.adam(LEARNING_RATE))


def initial_states(samples: int = 1) -> FlexibleSloshState:
    """The paper's rest state, repeated (the problem is deterministic; `samples` > 1 only
    repeats it)."""
    x0 = shi2024.initial_state()
    return jtu.tree_map(lambda x: jnp.stack([x] * samples), x0)


def case1_check(gains: dict, *, horizon: float = 150.0, dt: float = 1e-2) -> dict:
    """Forward re-check of tuned gains on the paper's case 1 (with the observer): the
    `metrics.json` entries of `shi2024` for the variant."""
    variant = shi2024.Variant(
        float(gains["omega_k"]),
        True,
        tuple((k, float(gains[k])) for k in ("kp", "k0", "gamma_k")),
    )
    (result,) = shi2024.simulate_variants([variant], horizon=horizon, dt=dt)
    return result.metrics()


def run(
    out_dir: str | pathlib.Path,
    *,
    samples: int = 1,
    steps: int = 40,
    validation_samples: int = 1,
    resume: bool = False,
    progress: bool = False,
    weights: Sequence[RealScalarLike] = WEIGHTS,
    optimizer: str = "default",
) -> dict:
    """One tuning run per penalty weight; writes `tuning.json` (gains, losses, the trade-off
    curve of convergence time vs residual modal energy on the tuning loop, and each point
    re-checked on case 1 with the observer), `report.md` and `tradeoff.png` to `out_dir`.

    The problem is deterministic (the paper's initial state): `samples` and
    `validation_samples` must be 1 (`jaxatt tune shi2024 --samples 1 --validation-samples
    1`); the held-out check is the paper's case 1 with the observer. `validation` (what
    `jaxatt tune` prints) has, per weight, that check's settle time, peak of n1, residual
    energy and `result` (its status name); `report.md` writes a check that did not end
    successfully as failed, not as its numbers.

    Each weight has its checkpoint, `checkpoint_w<w>.eqx`. `resume=True` needs at least one of
    them in `out_dir` ([`NoCheckpointError`][jaxatt.tune.NoCheckpointError] before anything
    runs, otherwise); a weight without one had not started (the weights run in order) and
    starts afresh. Every weight's checkpoint is checked before the first weight runs: one that
    belongs to another run is a [`CheckpointMismatchError`][jaxatt.tune.CheckpointMismatchError]
    then, not after the weights before it have run. A step whose loss or gradient is not
    finite raises [`NonFiniteLossError`][jaxatt.tune.NonFiniteLossError] (that weight's
    checkpoint keeps its last good step; no report is written).

    `optimizer`: `"default"` (the clip + Adam above, the recorded run's) or `"lbfgs"`
    (`optax.lbfgs()`), for every weight; written to the report's settings. Each point holds
    the gains after its last step (Adam, as recorded) or, under L-BFGS, those of its step
    with the lowest loss (`validated_step`: the number of updates behind them)."""
    chosen = select_optimizer(
        "shi2024_tuning", optimizer, _OPTIMIZER, f"clip_by_global_norm(1) + adam({LEARNING_RATE})"
    )
    if samples != 1 or validation_samples != 1:
        raise ValueError(
            "shi2024_tuning: the problem is deterministic (the paper's initial state): "
            f"`samples` and `validation_samples` must be 1, got {samples} and "
            f"{validation_samples} (CLI: --samples 1 --validation-samples 1)."
        )
    checkpoints = {w: f"checkpoint_w{w:g}.eqx" for w in weights}
    if resume:  # first: nothing is compiled or made without a checkpoint
        require_checkpoint("shi2024_tuning", out_dir, list(checkpoints.values()))
    out = pathlib.Path(out_dir)
    x0s = initial_states(samples)
    base = template()
    if resume:
        for w, name in checkpoints.items():  # every weight's, before the first one runs
            if (out / name).is_file():
                tuning.check_checkpoint(
                    base,
                    parameters(),
                    x0s,
                    out / name,
                    steps=steps,
                    optimizer=chosen.transformation,
                    objective=VibrationObjective(w),
                )
    out.mkdir(parents=True, exist_ok=True)
    start_obj = VibrationObjective(0.0)
    _, start_aux = tuning.evaluate(base, start_obj, x0s)
    points = []
    for w in weights:
        result = tuning.tune(
            base,
            parameters(),
            VibrationObjective(w),
            x0s,
            steps=steps,
            optimizer=chosen.transformation,
            checkpoint=out / checkpoints[w],
            resume=resume and (out / checkpoints[w]).is_file(),
            progress=progress,
        )
        tuned, tuned_gains, validated_step = chosen.validated(result)
        _, aux = tuning.evaluate(tuned, start_obj, x0s)
        gains = {k: float(v) for k, v in tuned_gains.items()}
        points.append(
            {
                "weight": w,
                "gains": gains,
                "validated_step": validated_step,
                "losses": [float(v) for v in result.losses],
                "convergence_time": float(aux["convergence_time"][0]),
                "residual_modal_energy": float(aux["residual_modal_energy"][0]),
                "case1": case1_check(gains),
            }
        )
    report = {
        "settings": {
            "horizon": HORIZON,
            "dt": DT,
            "tolerance": TOLERANCE,
            "energy_window": WINDOW,
            "steps": steps,
            "optimizer": chosen.label,
            "loop": "TVSMC without observer, ZV smoother (tuned frequency)",
        },
        "start": {
            "gains": {
                "kp": 0.4,
                "k0": 2.0,
                "gamma_k": 0.005,
                "omega_k": START_FREQUENCY,
            },
            "convergence_time": float(start_aux["convergence_time"][0]),
            "residual_modal_energy": float(start_aux["residual_modal_energy"][0]),
            "case1": case1_check(
                {"kp": 0.4, "k0": 2.0, "gamma_k": 0.005, "omega_k": START_FREQUENCY}
            ),
        },
        "points": points,
    }
    report["gains_before"] = report["start"]["gains"]
    report["gains_after"] = {f"w={p['weight']:g}": p["gains"] for p in points}
    report["validation"] = {
        f"w={p['weight']:g}": {
            k: p["case1"][k]
            for k in (
                "attitude_settle_time_1e-2",
                "peak_modal_n1",
                "residual_modal_energy_after_150s",
                "result",
            )
        }
        for p in points
    }
    written = write_report(out / "tuning.json", report)
    _plot(out, report)
    lines = [
        "# Vibration-aware tuning of Shi 2024's TVSMC and smoother",
        "",
        "| w [s/J] | kp | k0 | gamma_k | omega_k | T_c [s] | E_n [J] | case 1: settle 1e-2 [s] |"
        " case 1: peak n1 |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for p in [{"weight": float("nan"), **report["start"]}, *points]:
        g = p["gains"]
        lines.append(
            f"| {p['weight']:g} | {g['kp']:.4g} | {g['k0']:.4g} | {g['gamma_k']:.4g} | "
            f"{g['omega_k']:.4g} | {p['convergence_time']:.4g} | "
            f"{p['residual_modal_energy']:.3g} | {_case1_cells(p['case1'])} |"
        )
    lines += [
        "",
        "(w = nan: the paper's gains, smoother at 0.6258 rad/s.)",
        "",
        "![trade-off](tradeoff.png)",
        "",
        versions_sentence(),
        "",
    ]
    (out / "report.md").write_text("\n".join(lines))
    return written


def _case1_cells(case1: dict) -> str:
    """The report's two case-1 cells: the settle time ("not settled" if it never came) and the
    peak of n1; both "failed (<result>)" for a run that did not end successfully (its samples
    after the failure are not physical)."""
    if case1["result"] != "successful":
        return f"failed ({case1['result']}) | failed ({case1['result']})"
    settle, peak = case1["attitude_settle_time_1e-2"], case1["peak_modal_n1"]
    return " | ".join(
        (
            "not settled" if settle is None else f"{settle:.4g}",
            "n/a" if peak is None else f"{peak:.3g}",
        )
    )


def _plot(out: pathlib.Path, report: dict) -> None:
    import matplotlib.pyplot as plt

    from .. import plot

    with plot.style():
        fig, ax = plt.subplots(figsize=(5.5, 3.6), layout="constrained")
        t = [p["convergence_time"] for p in report["points"]]
        e = [p["residual_modal_energy"] for p in report["points"]]
        ax.plot(t, e, "o-", label="tuned (weight w)")
        for p in report["points"]:
            ax.annotate(f"w={p['weight']:g}", (p["convergence_time"], p["residual_modal_energy"]))
        s = report["start"]
        ax.plot(s["convergence_time"], s["residual_modal_energy"], "ks", label="paper gains")
        ax.set_yscale("log")
        ax.set_xlabel("attitude convergence time [s]")
        ax.set_ylabel("residual modal energy [J]")
        ax.legend()
        fig.savefig(out / "tradeoff.png")
        plt.close(fig)


PROBLEM = TuningProblem(
    name="shi2024",
    title="Vibration-aware tuning of Shi 2024's TVSMC gains and smoother frequency",
    run=run,
)
