"""The command-line front end, run in-process."""

import json

import numpy as np
import pytest

from jaxatt import cli


# In-process commands share compiled programs: the demo's Chen reproduction and tuning step are
# the ones `reproduce chen2022 --short` and `tune` use (the module runs on one xdist worker,
# tests/conftest.py).


def test_list_names_the_scenarios(capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "rigid_body_pd" in out and "Chen 2022" in out and "yu2022" in out


def test_version_names_jaxatt_and_the_versions_its_numbers_depend_on(capsys, monkeypatch):
    import jax
    import jaxlib

    import jaxatt

    # ... and the XLA options, which change the numbers' rounding (for a bug report).
    for flags, said in (("", "XLA_FLAGS unset"), (" --xla_a=1 ", "XLA_FLAGS `--xla_a=1`")):
        monkeypatch.setenv("XLA_FLAGS", flags)
        with pytest.raises(SystemExit) as stop:
            cli.main(["--version"])
        assert stop.value.code == 0
        out = capsys.readouterr().out.strip()
        assert out.startswith(f"jaxatt {jaxatt.__version__} (")
        assert f"jax {jax.__version__}," in out and f"jaxlib {jaxlib.__version__}," in out
        assert out.endswith(f"; {said})")


def test_demo_runs_the_whole_workflow_and_reports_measured_numbers(tmp_path, capsys):
    assert cli.main(["demo", "--short", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert str((tmp_path / "report.md").resolve()) in out
    summary = json.loads((tmp_path / "summary.json").read_text())
    report = (tmp_path / "report.md").read_text()
    # The reproduction, the Monte Carlo and the tuning all ran and their numbers are reported.
    assert set(summary["chen2022"]) == {"D1", "D2"}
    for name in ("M1", "M2", "M3"):
        assert summary["monte_carlo"][name]["count"] == 16
        assert summary["monte_carlo"][name]["failed"] == 0
    tuned = summary["tuning"]
    before = tuned["held_out_before"]["mean_settling_time"]
    after = tuned["held_out_after"]["mean_settling_time"]
    assert f"{before:.3g}" in report and f"{after:.3g}" in report
    assert tuned["gains_after"] != tuned["gains_before"]
    # What the numbers were computed with (JAX's random bits and XLA's rounding move them).
    import jax

    assert summary["versions"]["jax"] == jax.__version__
    assert f"jax {jax.__version__}," in report
    for name in (
        "montecarlo_cdf.png",
        "chen2022/fig5_sliding_variable_D1.png",
        "tuning/loss.png",
        "tuning/settling_cdf.png",
    ):
        assert (tmp_path / name).stat().st_size > 1000, name
    tuning_report = (tmp_path / "tuning" / "report.md").read_text()
    assert "| rho |" in tuning_report and "reduced by" in tuning_report
    # --short skips the check at the paper's step: null in the file (it was left out), and
    # the report says it was not run.
    tuning_json = json.loads((tmp_path / "tuning" / "tuning.json").read_text())
    assert tuning_json["validation_dt_1e-3"] is None
    assert "| (not run: validate_at_paper_step=False) | 1e-3 |" in tuning_report
    # Every report records the versions, the tuning's too (the stage's own files).
    assert tuning_json["versions"] == summary["versions"]
    assert f"jax {jax.__version__}," in tuning_report


def test_scenario_rigid_body_pd_reproduces(tmp_path, capsys):
    assert cli.main(["reproduce", "rigid_body_pd", "--short", "--out", str(tmp_path)]) == 0
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert (tmp_path / "overview.png").stat().st_size > 10_000
    nominal = metrics["nominal"]
    # The PD loop settles (to |sigma_e| < 1e-2) well inside the 40 s horizon, within the limit.
    assert 0 < nominal["settling_time"] < 30
    assert nominal["peak_torque"] <= 30.0
    assert metrics["monte_carlo"]["failed_samples"] == 0


def test_small_loop_kernels_give_the_reproduction_the_same_metrics(tmp_path):
    # Two new processes (XLA reads the option once, before its backend starts), both started
    # without the threshold (`.ci/run` sets it for the suite): one under XLA's default, one
    # with the flag; equal to rounding (the PD loop's metrics are smooth functions of the
    # states; 1e-9 relative leaves room for interpolated crossings).
    import os
    import subprocess
    import sys

    from jaxatt._small_loops import without_threshold

    env = dict(os.environ, XLA_FLAGS=without_threshold(os.environ.get("XLA_FLAGS", "")))
    command = [sys.executable, "-m", "jaxatt", "reproduce", "rigid_body_pd", "--short"]
    runs = {}
    for name, extra in (("a", []), ("b", ["--small-loop-kernels"])):
        runs[name] = subprocess.run(
            [*command, *extra, "--out", str(tmp_path / name)],
            capture_output=True,
            text=True,
            timeout=300,
            env=env,
        )
        assert runs[name].returncode == 0, runs[name].stderr[-3000:]
    said = "[jaxatt] XLA:CPU compiles loops of under 1000000 bytes per iteration as one kernel"
    assert said in runs["b"].stdout and said not in runs["a"].stdout
    a, b = (json.loads((tmp_path / k / "metrics.json").read_text()) for k in "ab")
    for key in ("settling_time", "peak_torque"):
        np.testing.assert_allclose(b["nominal"][key], a["nominal"][key], rtol=1e-9)
    assert b["monte_carlo"]["failed_samples"] == a["monte_carlo"]["failed_samples"] == 0


def test_small_loop_kernels_under_a_jaxlib_that_aborts_on_them_is_a_usage_error(
    tmp_path, capsys, monkeypatch
):
    # jaxlib before 0.7.2 aborts the process on some folded loops (tests/simulation/
    # test_small_loop_kernels.py): the flag is refused with exit status 2 and nothing runs.
    from jaxatt import _small_loops

    monkeypatch.setattr(_small_loops, "jaxlib_version", lambda: (0, 6, 2))
    out = tmp_path / "out"
    args = ["reproduce", "rigid_body_pd", "--short", "--small-loop-kernels", "--out", str(out)]
    assert cli.main(args) == cli.EXIT_USAGE == 2
    err = capsys.readouterr().err
    assert "jaxatt: --small-loop-kernels: enable_small_loop_kernels: jaxlib 0.6.2 aborts" in err
    assert not out.exists()


def test_tune_command_writes_a_report_and_resumes(tmp_path, capsys):
    # The demo's --short sizes (4 training, 16 held-out samples): the same compiled programs.
    args = [
        "tune",
        "chen2022",
        "--samples",
        "4",
        "--steps",
        "2",
        "--validation-samples",
        "16",
        "--out",
        str(tmp_path),
    ]
    assert cli.main(args) == 0
    first = json.loads((tmp_path / "tuning.json").read_text())
    assert len(first["losses"]) == 2 and (tmp_path / "checkpoint.eqx").exists()
    assert first["settings"]["validation_samples"] == 16
    assert set(first["validation_dt_1e-3"]) == {"before", "after"}  # run at the paper's step
    # Resuming a finished run does no further steps and reports the same gains.
    assert cli.main(args + ["--resume"]) == 0
    again = json.loads((tmp_path / "tuning.json").read_text())
    assert again["gains_after"] == first["gains_after"]
    # Regression (stop 47's note): resuming from another run's checkpoint (here another
    # training batch: --samples 5) was a ValueError traceback, exit 1. Now a usage error before
    # the loop is compiled (drawing the 5 initial states compiles two small programs), with
    # the checkpoint left as it was.
    from .helpers import compile_count

    saved = (tmp_path / "checkpoint.eqx").read_bytes()
    compiled = compile_count("_loss_and_grad")
    other = [v if v != "4" else "5" for v in args] + ["--resume"]
    assert cli.main(other) == cli.EXIT_USAGE == 2
    err = capsys.readouterr().err
    assert "was written for another tuning problem" in err and "nothing was run" in err
    assert compile_count("_loss_and_grad") == compiled
    assert (tmp_path / "checkpoint.eqx").read_bytes() == saved
    # An Adam run's checkpoint is not continued by L-BFGS (its state is another optimizer's).
    assert cli.main(args + ["--resume", "--optimizer", "lbfgs"]) == cli.EXIT_USAGE
    err = capsys.readouterr().err
    assert "other parameters or optimizer?" in err and "nothing was run" in err
    assert "with the same --samples and --optimizer" in err
    assert compile_count("_loss_and_grad") == compiled
    assert (tmp_path / "checkpoint.eqx").read_bytes() == saved


def test_reproduce_chen2022_short_writes_figures_and_metrics(tmp_path, capsys):
    assert cli.main(["reproduce", "chen2022", "--short", "--out", str(tmp_path)]) == 0
    assert str(tmp_path.resolve()) in capsys.readouterr().out
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    for case in ("D1", "D2"):
        for name in ("M1", "M2", "M3"):
            entry = metrics[case][name]
            for key in ("s_settle_time", "ev_settle_time", "peak_torque", "effort", "chattering"):
                assert key in entry
            assert len(entry["s_i_settle_time"]) == 3
            assert entry["peak_torque"] <= 30.0
    import jax

    assert metrics["versions"]["jax"] == jax.__version__  # what computed these numbers
    figures = sorted(p.name for p in tmp_path.glob("*.png"))
    assert len(figures) == 11 and "fig5_sliding_variable_D1.png" in figures


def test_tune_optimizer_choices_are_the_problems_and_others_are_refused(capsys):
    import optax

    from jaxatt.scenarios import OPTIMIZERS, select_optimizer

    assert cli.TUNE_OPTIMIZERS == OPTIMIZERS == ("default", "lbfgs")
    with pytest.raises(SystemExit) as error:
        cli.main(["tune", "chen2022", "--optimizer", "sgd"])
    assert error.value.code == cli.EXIT_USAGE
    assert "--optimizer: invalid choice: 'sgd'" in capsys.readouterr().err
    with pytest.raises(ValueError, match=r"problem: `optimizer` must be one of .*'sgd'"):
        select_optimizer("problem", "sgd", optax.adam(0.1), "adam(0.1)")


def test_unknown_scenario_is_an_error(capsys):
    assert cli.main(["reproduce", "nope"]) == 2
    assert "unknown scenario" in capsys.readouterr().err
    assert cli.main(["tune", "nope"]) == 2
    assert "no tuning problem" in capsys.readouterr().err


def test_bad_command_line_exits_with_usage(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["frobnicate"])
    # argparse's usage error: exit status 2 and the usage line on stderr (a bare SystemExit
    # would also have passed on sys.exit(0) after, say, printing the help).
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage:") and "invalid choice: 'frobnicate'" in err


def test_a_settled_fraction_short_of_all_never_prints_as_100_percent():
    # Regression (audit): '{:.1f} %' printed 9999 of 10000 settled as '100.0 % settled'.
    stats = {"mean_settling_time": 2.5, "settled_fraction": 0.9999, "failed": 1}
    assert cli._settling(stats) == "2.500 s, 99.99 % settled, 1 failed"
    stats = {"mean_settling_time": None, "settled_fraction": 1e-4, "failed": 0}
    assert cli._settling(stats) == "no mean, 0.01 % settled"
    assert cli._settling({"mean_settling_time": 1.0, "settled_fraction": 1.0}) == (
        "1.000 s, 100.0 % settled"
    )


@pytest.mark.parametrize("option, value", [("--samples", "0"), ("--steps", "-1")])
def test_tune_sizes_must_be_positive_on_the_command_line(option, value, tmp_path, capsys):
    # Regression (audit): a traceback from deep inside the problem (attitudes_within,
    # tune), after the output folder was made; for shi2024, --steps 0 failed only after the
    # starting gains' whole loop had been compiled and simulated.
    with pytest.raises(SystemExit) as info:
        cli.main(["tune", "chen2022", option, value, "--out", str(tmp_path / "out")])
    assert info.value.code == 2
    assert (
        f"argument {option}: must be a positive integer, got {value!r}" in capsys.readouterr().err
    )
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["chen2022", "zhang2021", "zhang2021-finite-time", "shi2024"])
def test_tune_resume_without_a_checkpoint_is_an_error_before_anything_runs(name, tmp_path, capsys):
    # Regression (review): `jaxatt tune NAME --resume` with no checkpoint in the output folder
    # (a mistyped --out, a deleted folder) started a fresh run quietly, exit 0: a run the user
    # thought continued could be published as one.
    from .helpers import compile_count

    out = tmp_path / "run"
    compiled = compile_count()
    assert cli.main(["tune", name, "--resume", "--out", str(out)]) == cli.EXIT_USAGE == 2
    err = capsys.readouterr().err
    assert f"jaxatt: tune {name} --resume: no checkpoint to resume from in {out.resolve()}" in err
    assert "checkpoint" in err.split("looked for ")[1] and "nothing was run" in err
    assert compile_count() == compiled and not out.exists()  # nothing compiled, nothing made


def _stopped_report(tune_module):
    """A stand-in `tune` that stops at step 3 of a run, as `on_nonfinite="stop"` does."""

    def fake_tune(template, parameters, objective, inputs, *, steps, **kwargs):
        gains = {k: np.asarray(p.where(template)) for k, p in parameters.items()}
        return tune_module.TuneResult(
            module=template,
            gains=gains,
            initial_gains=gains,
            losses=np.array([3.0, 2.0]),
            steps=2,
            stopped="tune: at step 3, the loss is inf (stand-in).",
        )

    return fake_tune


@pytest.mark.parametrize("name", ["zhang2021", "zhang2021-finite-time"])
def test_a_tuning_run_that_stopped_early_exits_non_zero_with_its_report(
    name, tmp_path, capsys, monkeypatch
):
    # Regression (review): a Zhang 2021 run that stopped at a non-finite loss (`stopped` in
    # its report) exited 0, so a script or CI job took a failed tuning for a success. The
    # tuning and the held-out evaluation are stood in (no simulation).
    from jaxatt import tune
    from jaxatt.scenarios import zhang2021_hover as hover

    aux = {f"settle_time_{g}": np.full(2, 10.0) for g in hover.GROUPS} | {
        "objective_time": np.full(2, 40.0),
        "peak_force": np.ones(2),
        "peak_torque": np.ones(2),
        "envelope_usage": np.full(2, 0.5),
        "status": np.zeros(2, int),
    }
    monkeypatch.setattr(tune, "tune", _stopped_report(tune))
    monkeypatch.setattr(tune, "evaluate", lambda module, objective, inputs: (None, aux))
    args = ["tune", name, "--samples", "2", "--validation-samples", "2", "--steps", "5"]
    assert cli.main(args + ["--out", str(tmp_path)]) == cli.EXIT_STOPPED == 3
    captured = capsys.readouterr()
    assert f"jaxatt: tune {name} did not complete: tune: at step 3" in captured.err
    assert "the report and the checkpoint hold the last good step" in captured.err
    # The report is still written, and says so.
    report = json.loads((tmp_path / "tuning.json").read_text())
    assert report["stopped"].startswith("tune: at step 3")
    assert "**Stopped early:**" in (tmp_path / "report.md").read_text()
    assert str((tmp_path / "report.md").resolve()) in captured.out


@pytest.mark.parametrize("name", ["chen2022", "shi2024"])
def test_a_tuning_run_that_raised_on_a_nonfinite_step_exits_non_zero(
    name, tmp_path, capsys, monkeypatch
):
    # The problems that let `tune.NonFiniteLossError` propagate (no report): a clean message
    # on stderr and exit status 3, not a traceback that reads like a crash (status 1).
    from jaxatt import tune

    def fake_tune(*args, **kwargs):
        raise tune.NonFiniteLossError(3, float("inf"), [], {"k": np.array(1.0)}, (1, 4), True)

    monkeypatch.setattr(tune, "tune", fake_tune)
    monkeypatch.setattr(tune, "evaluate", lambda module, objective, inputs: (None, {}))
    args = ["tune", name, "--samples", "1", "--validation-samples", "1", "--steps", "5"]
    assert cli.main(args + ["--out", str(tmp_path)]) == cli.EXIT_STOPPED
    err = capsys.readouterr().err
    assert f"jaxatt: tune {name} did not complete: tune: at step 3, the loss is inf" in err
    assert f"the checkpoint in {tmp_path.resolve()} holds the last good step" in err


def test_a_demo_whose_tuning_raised_exits_non_zero(tmp_path, capsys, monkeypatch):
    # Regression (stop 47's note): a non-finite tuning step in `jaxatt demo` was a traceback,
    # exit status 1, as for a crash. The demo is stood in (its tuning stage raising).
    from jaxatt import tune
    from jaxatt.scenarios import demo

    def fake_run(out, **kwargs):
        gains = {"rho": np.array(1.0)}
        raise tune.NonFiniteLossError(2, float("nan"), ["rho"], gains, (0, 4), True)

    monkeypatch.setattr(demo, "run", fake_run)
    assert cli.main(["demo", "--short", "--out", str(tmp_path)]) == cli.EXIT_STOPPED == 3
    err = capsys.readouterr().err
    assert "jaxatt: demo did not complete: its tuning stage stopped: tune: at step 2" in err
    assert f"no summary.json or report.md was written in {tmp_path.resolve()}" in err


def test_the_exit_statuses_are_in_the_help(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["tune", "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "exit status:" in out and "3  tune: the run did not complete" in out
    assert "2  bad command line, unknown NAME, tune --resume without a checkpoint" in out
    assert "--small-loop-kernels under a jaxlib older than 0.7.2" in out
