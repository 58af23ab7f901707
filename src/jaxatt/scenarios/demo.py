"""`jaxatt demo`: the whole workflow in about a minute and a half on a 2-core CPU.

1. Reproduce Chen et al. (2022)'s M1/M2/M3 comparison (Figs. 2-8, `metrics.json`).
2. Monte Carlo of the three controllers over random initial attitudes (within 60 deg of the
   reference, rates up to 0.05 rad/s): settling-time distributions, one compiled call each.
3. Tune M1's two-phase power law (rho, eta, lambda, both exponents) with autodiff on a small
   training batch, and validate on a fresh held-out batch.
4. Write `report.md` with the numbers measured in this run, next to the figures.
"""

import pathlib
import time

import jax.random as jr
import numpy as np

from .._versions import versions_sentence
from ..metrics import AbstractMetric, Chattering, Peak, SettlingTime
from . import chen2022_tuning, chen2022_two_phase_power as chen
from ._io import write_report


MC_SAMPLES = 128
MC_HORIZON = 10.0
MC_DT = 5e-3
TOLERANCE = 1e-3


def settling_metrics() -> dict[str, AbstractMetric]:
    """Per-sample metrics of the demo's Monte Carlo: settling of ||e_v|| below 1e-3, peak
    torque, chattering over the last 5 s."""
    return {
        "settling_time": SettlingTime("attitude_error_vector", TOLERANCE),
        "peak_torque": Peak("u"),
        "chattering": Chattering("u", MC_HORIZON - 5.0, MC_HORIZON),
    }


def run(
    out_dir: str | pathlib.Path,
    *,
    short: bool = False,
    progress: bool = True,
    tuning_samples: int = 32,
    tuning_steps: int = 20,
) -> dict:
    """Run the demo and write everything under `out_dir`; returns the summary it reports.

    `short=True` (CI) shrinks every stage: Chen reproduction in short mode, 16 Monte Carlo
    samples, 4 training samples, 2 tuning steps and 16 held-out samples validated at the tuning
    step only.
    """
    import matplotlib.pyplot as plt

    from .. import plot
    from ..montecarlo import monte_carlo

    out = pathlib.Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    timings = {}
    start = time.perf_counter()
    reproduction = chen.reproduce(out / "chen2022", short=short, progress=progress)
    timings["chen2022_reproduction"] = time.perf_counter() - start

    start = time.perf_counter()
    n = 16 if short else MC_SAMPLES
    x0s = chen2022_tuning.initial_states(jr.key(42), n)
    mc = {}
    metrics = settling_metrics()
    for name in chen.CONTROLLERS:
        result = monte_carlo(chen.build(name), x0s, 0.0, MC_HORIZON, dt=MC_DT, metrics=metrics)
        mc[name] = result
    mc_summary = {name: r.summary("settling_time") for name, r in mc.items()}
    timings["monte_carlo"] = time.perf_counter() - start
    with plot.style():
        fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
        plot.plot_settling_distribution(mc, ax=ax)
        ax.set_xlabel("settling time of $\\|e_v\\| < 10^{-3}$ [s]")
        ax.set_title(f"{n} random initial attitudes within 60 deg")
        fig.savefig(out / "montecarlo_cdf.png")
        plt.close(fig)

    start = time.perf_counter()
    tuning = chen2022_tuning.run(
        out / "tuning",
        samples=4 if short else tuning_samples,
        steps=2 if short else tuning_steps,
        validation_samples=16 if short else 128,
        progress=progress,
        validate_at_paper_step=not short,
    )
    timings["tuning_and_validation"] = time.perf_counter() - start
    summary = {
        "chen2022": {
            case: {name: reproduction[case][name]["s_settle_time"] for name in chen.CONTROLLERS}
            for case in chen.CASES
        },
        "chen2022_failed": [
            f"{case} {name}"
            for case in chen.CASES
            for name in chen.CONTROLLERS
            if not reproduction[case][name]["successful"]
        ],
        "monte_carlo": {
            name: {
                k: s[k] for k in ("count", "failed", "nonfinite", "mean", "worst", "success_rate")
            }
            for name, s in mc_summary.items()
        },
        "tuning": {
            "gains_before": tuning["gains_before"],
            "gains_after": tuning["gains_after"],
            "best_step": tuning["best_step"],
            "held_out_before": tuning["validation"]["before"],
            "held_out_after": tuning["validation"]["after"],
            "mean_settling_time_reduction": tuning["mean_settling_time_reduction"],
            "held_out_over_bounds": tuning["held_out_over_bounds"],
        },
        "timings_s": timings,
    }
    written = write_report(out / "summary.json", summary)
    _write_report(out, summary, n, tuning)
    return written


def _fmt(value) -> str:
    return "n/a" if value is None or not np.isfinite(value) else f"{value:.3g}"


def _chen_cell(settle_time, successful: bool) -> str:
    """A reproduction's settle time: "failed" for a run that did not end successfully (its
    numbers are not physical), "not settled" for one that never settled, else 3 digits."""
    if not successful:
        return "failed"
    if settle_time is None or settle_time == np.inf:
        return "not settled"
    return _fmt(settle_time)


def _cell(key: str, value, failed: int) -> str:
    """A held-out statistic: 3 significant digits, or what a missing value means (`failed`:
    the number of failed samples of its batch)."""
    if value is None or isinstance(value, int):
        return chen2022_tuning.format_statistic(key, value, failed)
    return _fmt(value)


def _write_report(out: pathlib.Path, summary: dict, n: int, tuning: dict) -> None:
    t = summary["tuning"]
    lines = [
        "# jaxatt demo report",
        "",
        "Every number below was measured by this run (`summary.json` has them all).",
        "",
        "## 1. Chen et al. (2022): time for every |s_i| to stay below 1e-3 [s]",
        "",
        "| case | M1 two-phase | M2 exponential | M3 double power |",
        "| --- | --- | --- | --- |",
    ]
    failed = set(summary.get("chen2022_failed", ()))
    for case, row in summary["chen2022"].items():
        cells = (_chen_cell(row[k], f"{case} {k}" not in failed) for k in chen.CONTROLLERS)
        lines.append(f"| {case} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Figures: `chen2022/fig2_attitude_error_D1.png` ... `chen2022/fig8_s3_D1_vs_D2.png`.",
        "",
        f"## 2. Monte Carlo: {n} initial attitudes within 60 deg, rates up to 0.05 rad/s",
        "",
        "Settling time of ||e_v|| < 1e-3 over 10 s (RK4, dt 5e-3 s):",
        "",
        "| controller | mean of settled [s] | worst [s] | success rate | not settled | failed |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for name, s in summary["monte_carlo"].items():
        # `worst` is inf for a sample that never settled and for one that failed.
        unsettled = "not settled or failed" if s["failed"] else "not settled"
        worst = unsettled if s["worst"] == np.inf else _fmt(s["worst"])
        lines.append(
            f"| {name} | {_fmt(s['mean'])} | {worst} | {_fmt(s['success_rate'])} "
            f"| {s['nonfinite']} | {s['failed']} |"
        )
    lines += [
        "",
        "![Monte Carlo CDF](montecarlo_cdf.png)",
        "",
        "## 3. Autodiff tuning of M1 (rho, eta, lambda, p1/q1, q2/p2)",
        "",
        f"Trained on {tuning['settings']['training_samples']} samples for "
        f"{tuning['settings']['steps']} Adam steps; the gains of step {t['best_step']} (the "
        "lowest training loss) validated on "
        f"{tuning['settings']['validation_samples']} held-out samples.",
        "",
        "| gain | paper | tuned |",
        "| --- | --- | --- |",
    ]
    for k, v in t["gains_before"].items():
        lines.append(f"| {k} | {v:.4g} | {t['gains_after'][k]:.4g} |")
    before, after = t["held_out_before"], t["held_out_after"]
    lines += [
        "",
        "| held-out metric | paper gains | tuned |",
        "| --- | --- | --- |",
    ]
    for key in (
        "mean_settling_time",
        "p95_settling_time",
        "worst_settling_time",
        "settled_fraction",
        "failed",
        "max_peak_torque",
        "max_chattering",
    ):
        lines.append(
            f"| {key} | {_cell(key, before[key], before['failed'])} | "
            f"{_cell(key, after[key], after['failed'])} |"
        )
    lines += [
        "",
        chen2022_tuning.reduction_sentence(tuning),
        "",
        *chen2022_tuning.over_bounds_lines(tuning),
        "Details: `tuning/report.md`, `tuning/loss.png`, `tuning/settling_cdf.png`.",
        "",
        "Wall time per stage [s]: "
        + ", ".join(f"{k} {v:.1f}" for k, v in summary["timings_s"].items()),
        "",
        versions_sentence(),
        "",
    ]
    (out / "report.md").write_text("\n".join(lines))
