"""Every scenario figure that draws a simulated run says so when the run failed.

Audit (stops 49-50): the scenarios' figures drew a failed run (`simulate(..., throw=False)`:
a NaN state, a violated constraint) exactly as an ordinary one, so a figure could show a
diverged controller as if it had worked. Each figure writer is fed trajectories built here
(no simulation: the figures read only `ts`, `states`, `signals`, `status`, `failure_time`), one
of them failed, and every saved figure that draws that run must name its status, in a legend
entry or a title. `Figure.savefig` is intercepted to read the figure before it is closed.
"""

import collections
import types

import matplotlib


matplotlib.use("Agg")

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from jaxatt.simulation import Status, Trajectory  # noqa: E402


T = 11
TS = np.linspace(0.0, 1.0, T)
FAILED = "nonfinite_state at t = 0.4 s"


def trajectory(plant=None, batch: tuple = (), failed=(), **signals) -> Trajectory:
    """A trajectory of `T` samples (batched when `batch`) whose plant states (`plant`: name ->
    width, or a nested dict) and signals (name -> width; `None` for a scalar per sample) are
    ramps; the samples whose index is in `failed` (all of them for `failed=True`) failed at
    t = 0.4 s."""
    status = np.zeros(batch, dtype=np.int32)
    failure_time = np.full(batch, np.inf)
    if failed:
        mark = ... if failed is True else list(failed)
        status[mark] = int(Status.nonfinite_state)
        failure_time[mark] = 0.4

    def series(width):
        ramp = np.linspace(0.0, 1.0, T)
        ramp = ramp if width is None else ramp[:, None] * np.ones(width)
        return jnp.asarray(np.broadcast_to(ramp, (*batch, *ramp.shape)))

    def states(tree):  # attribute access, as on the closed loop's state modules
        fields = {k: states(v) if isinstance(v, dict) else series(v) for k, v in tree.items()}
        return collections.namedtuple("State", list(fields))(**fields)

    return Trajectory(
        jnp.asarray(np.broadcast_to(TS, (*batch, T))),
        states({"plant": plant or {}}),
        {k: series(w) for k, w in signals.items()},
        jnp.asarray(status),
        jnp.asarray(failure_time),
        {},
    )


@pytest.fixture
def saved(monkeypatch):
    """The texts (legend entries, titles) of every figure saved, by file name."""
    texts = {}

    def savefig(self, fname, *args, **kwargs):
        found = [self.get_suptitle()] if hasattr(self, "get_suptitle") else []
        for ax in self.axes:
            found.append(ax.get_title())
            legend = ax.get_legend()
            if legend is not None:
                found += [t.get_text() for t in legend.get_texts()]
        texts[str(fname).rsplit("/", 1)[-1]] = found

    monkeypatch.setattr(Figure, "savefig", savefig)
    return texts


def names_failure(texts) -> bool:
    return any(FAILED in t for t in texts)


def test_yu2022(saved, tmp_path):
    from jaxatt.scenarios import yu2022_ftac_mrp as yu

    batch = (len(yu.CASES),)
    plant = {"sigma": 3, "omega": 3}
    signals = {"u": 3, "d_hat": 3, "disturbance": 3}
    trajs = {
        "FTAC": trajectory(plant, batch, failed=[1], **signals),
        "FT": trajectory(plant, batch, **signals),
        "PD": trajectory(plant, batch, **signals),
    }
    yu._write_figures(tmp_path, trajs, None)
    for k, case in enumerate(yu.CASES):
        for stem in ("fig1_mrp", "fig2_omega", "fig3_ftac_torque", "fig4_observer_error"):
            assert names_failure(saved[f"{stem}_{case}.png"]) == (k == 1), (stem, case)


def test_zhang2021(saved, tmp_path):
    from jaxatt.scenarios._zhang2021_figures import LABELS, figures

    signals = dict.fromkeys(
        ("position_error", "attitude_error", "velocity_error", "rate_error", "force", "torque"), 3
    )
    trajs = {
        name: trajectory(failed=name == "ppc", envelope=12, **signals)
        if name == "ppc"
        else trajectory(**signals)
        for name in LABELS
    }
    figs = figures(trajs)
    try:
        for stem, fig in figs.items():
            fig.savefig(tmp_path / f"{stem}.png")
        for stem in ("errors_ppc", "controls_ppc", "x_position_comparison"):
            assert names_failure(saved[f"{stem}.png"]), stem
        for stem in ("errors_linear_smc", "controls_finite_time_ppf"):
            assert not names_failure(saved[f"{stem}.png"]), stem
    finally:
        for fig in figs.values():
            matplotlib.pyplot.close(fig)


def test_zhang2017(saved, tmp_path):
    from jaxatt.scenarios import zhang2017

    trajs = {
        (case, name): trajectory(
            {"rho": 3, "rho_dot": 3}, failed=(case, name) == (zhang2017.CASES[0], "pd_alpha"), u=3
        )
        for case in zhang2017.CASES
        for name in zhang2017.CONTROLLERS
    }
    zhang2017._write_figures(tmp_path, trajs)
    for k, case in enumerate(zhang2017.CASES):
        for stem in ("fig_state", "fig_control"):
            assert names_failure(saved[f"{stem}_{case}.png"]) == (k == 0), (stem, case)


def test_yue2018(saved, tmp_path):
    from jaxatt.scenarios import yue2018

    signals = {"position_norm": None, "attitude_error_angle": None, "u": 6}
    trajs = {"paper": trajectory(**signals), "tuned": trajectory(failed=True, **signals)}
    yue2018._write_figures(tmp_path, trajs)
    assert names_failure(saved["fig_yue2018.png"])


def test_flyaround(saved, tmp_path):
    from jaxatt.scenarios import flyaround

    traj = trajectory({"orbit": {"rho": 3}}, failed=True, position_norm=None, pointing_error=None)
    flyaround._write_figures(tmp_path, traj)
    assert names_failure(saved["fig_flyaround.png"])


def test_wu2018(saved, tmp_path):
    from jaxatt.scenarios import wu2018

    def batch(failed):
        return trajectory(
            {"orbit": {"rho": 3}}, (2,), failed, sigma_error=3, u=6, d_hat_translation=None
        )

    wu2018._write_figures(tmp_path, batch([1]), batch(()), None, 2)
    assert names_failure(saved["trajectories.png"])
    assert names_failure(saved["errors_inputs.png"])


def test_shi2024(saved, tmp_path):
    from jaxatt.scenarios import shi2024

    def run(failed: bool):
        traj = trajectory({"omega": 3, "eta": 2, "n": 3}, failed=failed, u=3)
        values = {
            "observer_error": np.abs(traj.signals["u"]),
            "attitude_error_vector": traj.signals["u"],
        }
        return types.SimpleNamespace(traj=traj, values=values)

    runs = {"case1_no_smoother": run(False), "case1_smoother": run(False), "case2": run(True)}
    shi2024._write_figures(tmp_path, runs, None)
    for name in ("fig3_rates.png", "fig4_attitude.png", "fig5_torque.png"):
        assert names_failure(saved[name]), name
    assert not names_failure(saved["fig2_observer_error.png"])
    assert not names_failure(saved["fig6_slosh.png"])  # case 2 is not drawn there

    runs["case1_no_smoother"] = run(True)
    shi2024._write_figures(tmp_path, runs, None)
    assert names_failure(saved["fig2_observer_error.png"])


def test_duan2024(saved, tmp_path):
    from jaxatt.scenarios import duan2024

    def run(failed: bool):
        return trajectory({"x": 2 * duan2024.AGENTS}, failed=failed)

    trajs = {"periodic": run(False), "random": run(True)}
    exact = {
        "curve": {"h": np.linspace(0.1, 0.3, 5), "radii": np.ones((5, 2))},
        "l2_eigenvalues": [0.0, 1.0, 2.0],
    }
    metrics = {"exact_h_star": 0.2, "lmi_tau_max": 0.15}
    duan2024._write_figures(tmp_path, trajs, exact, metrics)
    assert not names_failure(saved["consensus_periodic.png"])
    assert names_failure(saved["consensus_random.png"])
