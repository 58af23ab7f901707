"""rigid_body_pd's Monte Carlo summary (hand-made batch metrics, no simulation); what
`reproduce` returns and writes for a time that never comes (a 1 s run)."""

import json
import math

import numpy as np

from jaxatt.scenarios import rigid_body_pd


def test_monte_carlo_summary_counts_failed_samples_at_their_worst():
    """Sample 2 failed (its metrics hold NaN), sample 1 never settled (inf): the maxima are
    infinite, not NaN (np.max let the failed sample's NaN hide the unsettled inf)."""
    metrics = {
        "settling_time": np.array([10.0, np.inf, np.nan, 20.0]),
        "peak_torque": np.array([0.1, 0.2, np.nan, 0.3]),
    }
    summary = rigid_body_pd.monte_carlo_summary(metrics, np.array([True, True, False, True]))
    assert summary["samples"] == 4 and summary["failed_samples"] == 1
    assert summary["settled_fraction"] == 0.5
    assert summary["settling_time_mean"] == 15.0
    assert summary["settling_time_max"] == math.inf
    assert summary["peak_torque_max"] == math.inf
    ok = rigid_body_pd.monte_carlo_summary(
        {"settling_time": np.array([10.0, 20.0]), "peak_torque": np.array([0.1, 0.3])},
        np.array([True, True]),
    )
    assert ok["settling_time_max"] == 20.0 and ok["peak_torque_max"] == 0.3


def test_a_time_that_never_comes_is_the_same_in_the_returned_dict_and_the_file(
    tmp_path, monkeypatch
):
    # Regression (review): `reproduce` returned `inf` for a settling time that never came while
    # metrics.json held `null`, so a notebook reading the dict and a script reading the file
    # saw different things. A 1 s horizon (nothing settles to 1e-2 in it), 16 samples.
    monkeypatch.setattr(rigid_body_pd, "HORIZON", 1.0)
    metrics = rigid_body_pd.reproduce(tmp_path, short=True)
    assert metrics == json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["horizon"] == 1.0
    assert metrics["nominal"]["settling_time"] is None  # never, within the horizon
    assert metrics["monte_carlo"]["settled_fraction"] == 0.0
    assert metrics["monte_carlo"]["settling_time_max"] is None
