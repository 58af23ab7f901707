"""rigid_body_pd's Monte Carlo summary (hand-made batch metrics, no simulation)."""

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
