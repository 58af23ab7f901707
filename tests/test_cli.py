"""The command-line front end, run in-process."""

import json

import pytest

from jaxatt import cli


def test_list_names_the_scenarios(capsys):
    assert cli.main(["list"]) == 0
    assert "rigid_body_pd" in capsys.readouterr().out


def test_demo_writes_figures_and_metrics(tmp_path, capsys):
    assert cli.main(["demo", "--short", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert str(tmp_path.resolve()) in out
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert (tmp_path / "overview.png").stat().st_size > 10_000
    assert (tmp_path / "montecarlo.png").stat().st_size > 10_000
    nominal = metrics["nominal"]
    # The PD loop settles (to |sigma_e| < 1e-2) well inside the 40 s horizon, within the limit.
    assert 0 < nominal["settling_time"] < 30
    assert nominal["peak_torque"] <= 30.0
    assert metrics["monte_carlo"]["failed_samples"] == 0


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
    figures = sorted(p.name for p in tmp_path.glob("*.png"))
    assert len(figures) == 11 and "fig5_sliding_variable_D1.png" in figures


def test_unknown_scenario_is_an_error(capsys):
    assert cli.main(["reproduce", "nope"]) == 2
    assert "unknown scenario" in capsys.readouterr().err


def test_bad_command_line_exits_with_usage():
    with pytest.raises(SystemExit):
        cli.main(["frobnicate"])
