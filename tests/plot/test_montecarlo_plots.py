"""Monte Carlo figures: they return Axes, draw something, and cope with inf/NaN samples."""

import matplotlib


matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402

from jaxatt import plot  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def _legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_plot_envelope_draws_median_and_band_and_skips_nonfinite():
    ts = np.linspace(0.0, 1.0, 11)
    values = np.exp(-np.outer(np.linspace(1.0, 3.0, 20), ts))
    values[3] = np.nan  # a failed sample
    values[4, 5:] = np.inf
    ax = plot.plot_envelope(ts, values, label="M1", log=True)
    assert isinstance(ax, Axes)
    (line,) = ax.get_lines()
    expected = np.median(np.delete(values, [3, 4], axis=0), axis=0)
    # Both samples are left out at every time, also before the inf sample diverges.
    np.testing.assert_allclose(line.get_ydata(), expected, rtol=1e-12)
    assert len(ax.collections) == 1  # the quantile band
    assert ax.get_yscale() == "log"
    assert _legend_texts(ax)[0] == "M1 (2 of 20 failed or non-finite, excluded)"


def _band_edges_at(ax, t):
    vertices = ax.collections[0].get_paths()[0].vertices
    at_t = vertices[np.isclose(vertices[:, 0], t), 1]
    return at_t.min(), at_t.max()


def test_plot_envelope_states_and_excludes_diverged_and_failed_samples():
    # Samples 0 and 1 decay, 2 diverges to inf after t = 0.5, 3 fails (NaN after t = 0.3).
    ts = np.linspace(0.0, 1.0, 11)
    values = np.vstack([np.exp(-5 * ts), np.exp(-6 * ts), 0.5 * np.exp(3 * ts), np.exp(-4 * ts)])
    values[2, ts > 0.5] = np.inf
    values[3, ts > 0.3] = np.nan
    ax = plot.plot_envelope(ts, values, label="M1", log=True)
    assert _legend_texts(ax) == ["M1 (2 of 4 failed or non-finite, excluded)", "M1 5-95 %"]
    kept = values[:2]
    # The statistics are over the same two samples at every time, t = 0 included.
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), np.median(kept, axis=0))
    low, high = np.quantile(kept, [0.05, 0.95], axis=0)
    for k in (0, 10):
        np.testing.assert_allclose(_band_edges_at(ax, ts[k]), (low[k], high[k]))


def test_plot_envelope_excludes_unsuccessful_samples_with_finite_values():
    ts = np.linspace(0.0, 1.0, 5)
    values = np.vstack([np.exp(-ts), np.exp(-2 * ts), np.full(5, 10.0)])
    # Sample 2 violated a constraint: its values stay finite, but it did not succeed.
    ax = plot.plot_envelope(ts, values, successful=np.array([True, True, False]))
    assert _legend_texts(ax)[0] == "median (1 of 3 failed or non-finite, excluded)"
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), np.median(values[:2], axis=0))
    # Nothing excluded: the legend is the plain label.
    ax = plot.plot_envelope(ts, values, label="M2", successful=np.ones(3, bool))
    assert _legend_texts(ax)[0] == "M2"
    # Every sample excluded: nothing is drawn, and the legend says so.
    ax = plot.plot_envelope(ts, values, label="M3", successful=np.zeros(3, bool))
    assert _legend_texts(ax)[0] == "M3 (3 of 3 failed or non-finite, excluded)"
    assert np.isnan(ax.get_lines()[0].get_ydata()).all()
    with pytest.raises(ValueError, match="successful"):
        plot.plot_envelope(ts, values, successful=np.ones(2, bool))


def test_plot_envelope_accepts_batched_times_and_rejects_bad_shapes():
    ts = np.tile(np.linspace(0.0, 1.0, 5), (3, 1))
    fig, ax = plt.subplots()
    assert plot.plot_envelope(ts, np.ones((3, 5)), ax=ax) is ax
    with pytest.raises(ValueError, match="values"):
        plot.plot_envelope(ts[0], np.ones((3, 4)))
    with pytest.raises(ValueError, match="quantiles"):
        plot.plot_envelope(ts[0], np.ones((3, 5)), quantiles=(0.9, 0.1))


@pytest.mark.parametrize("quantiles", [(0.05, 0.5, 0.95), 0.9])
def test_plot_envelope_names_quantiles_that_are_not_a_pair(quantiles, no_jaxtyping):
    # Regression (audit): "too many values to unpack", "'float' object is not iterable".
    with pytest.raises(ValueError, match=r"plot_envelope: `quantiles` must be \(low, high\)"):
        plot.plot_envelope(np.linspace(0.0, 1.0, 5), np.ones((3, 5)), quantiles=quantiles)


@pytest.mark.parametrize("kind", ["cdf", "hist"])
def test_plot_settling_distribution_counts_unsettled_in_the_legend(kind):
    results = {
        "M1": np.array([1.0, 2.0, np.inf, 3.0]),
        "M2": np.array([2.0, 2.5, 3.5, 4.0]),
        "M3": np.full(4, np.inf),
    }
    ax = plot.plot_settling_distribution(results, kind=kind)
    assert isinstance(ax, Axes)
    assert _legend_texts(ax) == ["M1 (1 not settled)", "M2", "M3 (4 not settled)"]
    if kind == "cdf":
        line = ax.get_lines()[0]
        # The CDF of M1 ends at 3/4: one of its four samples never settled.
        assert line.get_ydata()[-1] == pytest.approx(0.75)
        np.testing.assert_allclose(ax.get_lines()[1].get_ydata()[-1], 1.0)
    else:
        assert len(ax.patches) >= 2
    with pytest.raises(ValueError, match="kind"):
        plot.plot_settling_distribution(results, kind="box")


def test_plot_scatter_vs_initial_error_marks_unsettled_samples():
    angle = np.radians([10.0, 20.0, 30.0, 40.0])
    values = np.array([1.0, 2.0, np.inf, np.nan])
    ax = plot.plot_scatter_vs_initial_error(angle, values, label="M1")
    assert isinstance(ax, Axes)
    finite, crosses = ax.collections
    np.testing.assert_allclose(finite.get_offsets()[:, 0], [10.0, 20.0])
    assert len(crosses.get_offsets()) == 2
    assert _legend_texts(ax) == ["M1 (2 not settled)"]
    with pytest.raises(ValueError, match="same length"):
        plot.plot_scatter_vs_initial_error(angle, values[:3])


def test_plot_scatter_vs_initial_error_counts_unsuccessful_samples_as_failed():
    angle = np.radians([10.0, 20.0, 30.0, 40.0])
    values = np.array([1.0, 2.0, np.inf, 1.5])  # sample 3 failed with a finite value
    ax = plot.plot_scatter_vs_initial_error(
        angle, values, label="M1", successful=np.array([True, True, True, False])
    )
    finite, crosses = ax.collections
    np.testing.assert_allclose(finite.get_offsets()[:, 0], [10.0, 20.0])
    np.testing.assert_allclose(crosses.get_offsets()[:, 0], [30.0, 40.0])
    assert _legend_texts(ax) == ["M1 (1 failed, 1 not settled)"]


def test_a_status_array_is_not_read_as_the_successful_mask():
    # Regression (audit): `successful` was cast with astype(bool), so passing the status codes
    # (0 = successful) counted every success as failed and every failure as a success.
    ts = np.linspace(0.0, 1.0, 5)
    values = np.vstack([np.exp(-ts), np.exp(-2 * ts), np.full(5, 10.0)])
    status = np.array([0, 0, 2])
    with pytest.raises(ValueError, match=r"plot_envelope: `successful` must be a boolean mask"):
        plot.plot_envelope(ts, values, successful=status)
    with pytest.raises(ValueError, match=r"plot_scatter_vs_initial_error: `successful` must be"):
        plot.plot_scatter_vs_initial_error(np.ones(3), np.ones(3), successful=status)
    ax = plot.plot_envelope(ts, values, successful=status == 0)
    assert _legend_texts(ax)[0] == "median (1 of 3 failed or non-finite, excluded)"


def test_plot_settling_distribution_names_a_missing_or_per_component_metric():
    import jax.numpy as jnp

    from jaxatt.montecarlo import MonteCarloResult

    result = MonteCarloResult(
        metrics={"settling_time": jnp.array([1.0, 2.0]), "peak": jnp.ones((2, 3))},
        status=jnp.array([0, 1]),
        failure_time=jnp.array([jnp.inf, 0.5]),
    )
    # Regression (audit): a bare KeyError, and NumPy's broadcasting error for a metric with
    # one value per component.
    with pytest.raises(ValueError, match=r"`metric` 'nope' is not a metric of 'M1'"):
        plot.plot_settling_distribution({"M1": result}, metric="nope")
    with pytest.raises(ValueError, match=r"'peak' of 'M1' must have one value per sample"):
        plot.plot_settling_distribution({"M1": result}, metric="peak")
    # Plain values of shape (n, 3) were read as 3n samples: the CDF's fractions were a third.
    with pytest.raises(ValueError, match=r"the values of 'M1' must have shape \(n,\)"):
        plot.plot_settling_distribution({"M1": np.ones((4, 3))})
    ax = plot.plot_settling_distribution({"M1": result})
    assert _legend_texts(ax) == ["M1 (1 failed)"]
