"""Matplotlib figures. The only place in jaxatt that imports matplotlib.

Functions take `ax=None` and return the `Axes` (or a `Figure` for multi-panel views); they never
call `plt.show()` and never touch global rcParams (use `with jaxatt.plot.style(): ...`).
"""

from ._montecarlo import (
    plot_envelope as plot_envelope,
    plot_scatter_vs_initial_error as plot_scatter_vs_initial_error,
    plot_settling_distribution as plot_settling_distribution,
)
from ._trajectory import (
    mark_failure as mark_failure,
    plot_attitude_error as plot_attitude_error,
    plot_control as plot_control,
    plot_overview as plot_overview,
    plot_rate_error as plot_rate_error,
    plot_signal as plot_signal,
    status_label as status_label,
    style as style,
)
from ._tuning import plot_loss_curve as plot_loss_curve
