"""Time-history figures: every drawn component is labelled as what it is."""

import matplotlib


matplotlib.use("Agg")

import jax.numpy as jnp  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from jaxatt import plot  # noqa: E402
from jaxatt.simulation import Trajectory  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    plt.close("all")


def _trajectory(u_components: int) -> Trajectory:
    ts = jnp.linspace(0.0, 1.0, 5)
    signals = {
        "u": jnp.outer(ts, jnp.arange(1.0, u_components + 1)),
        "rate_error": jnp.zeros((5, 3)),
    }
    return Trajectory(ts, (), signals, jnp.array(0), jnp.array(jnp.inf), {})


def test_plot_control_of_a_six_component_control_is_refused_not_cut_to_three():
    # Regression (audit): a 6-DOF control (force, then torque) was drawn as its first three
    # components, the force, labelled u_x, u_y, u_z on a "torque [N m]" axis.
    ax = plot.plot_control(_trajectory(3))
    assert len(ax.get_lines()) == 3
    with pytest.raises(ValueError, match=r"plot_control: .*6 components.*plot_signal"):
        plot.plot_control(_trajectory(6))
    # plot_signal draws all six.
    assert len(plot.plot_signal(_trajectory(6), "u").get_lines()) == 6


def test_plot_signal_labels_must_match_the_drawn_components():
    # Regression (audit): zip() dropped the components without a label, silently.
    with pytest.raises(ValueError, match=r"plot_signal: `labels` must have 6 entries.*got 3"):
        plot.plot_signal(_trajectory(6), "u", labels=["a", "b", "c"])
    ax = plot.plot_signal(_trajectory(6), "u", labels=list("abc"), components=slice(3, 6))
    assert [line.get_label() for line in ax.get_lines()] == ["a", "b", "c"]


def test_a_failed_trajectory_is_marked_with_its_status_and_time():
    # Audit (stop 49): a trajectory that failed (simulate(..., throw=False)) was drawn as an
    # ordinary one: nothing in the figure said its samples after the failure are not physical.
    from jaxatt.simulation import Status

    ok = _trajectory(3)
    labels = [line.get_label() for line in plot.plot_signal(ok, "u").get_lines()]
    assert labels == ["u[0]", "u[1]", "u[2]"]
    failed = Trajectory(
        ok.ts, (), ok.signals, jnp.array(int(Status.nonfinite_state)), jnp.array(0.5), {}
    )
    ax = plot.plot_control(failed)
    marks = [line for line in ax.get_lines() if line.get_label().startswith("nonfinite_state")]
    assert len(marks) == 1 and marks[0].get_label() == "nonfinite_state at t = 0.5 s"
    assert list(marks[0].get_xdata()) == [0.5, 0.5]
    assert "nonfinite_state at t = 0.5 s" in [t.get_text() for t in ax.get_legend().get_texts()]


def test_status_label_names_a_failed_run_and_adds_nothing_to_a_successful_one():
    from jaxatt.simulation import Status

    assert plot.status_label(jnp.array(0), jnp.array(jnp.inf)) == ""
    assert (
        plot.status_label(jnp.array(int(Status.constraint_violated)), jnp.array(1.25))
        == " (constraint_violated at t = 1.25 s)"
    )


def test_mark_failure_refuses_a_batch_and_draws_nothing_for_a_successful_run():
    from jaxatt.simulation import Status

    fig, ax = plt.subplots()
    plot.mark_failure(ax, _trajectory(3))
    assert ax.get_lines() == []
    ok = _trajectory(3)
    batch = Trajectory(
        jnp.stack([ok.ts, ok.ts]),
        (),
        {k: jnp.stack([v, v]) for k, v in ok.signals.items()},
        jnp.array([0, int(Status.nonfinite_state)]),
        jnp.array([jnp.inf, 0.5]),
        {},
    )
    with pytest.raises(ValueError, match=r"mark_failure: `traj` must be a single trajectory"):
        plot.mark_failure(ax, batch)
