"""Matplotlib figures. The only place in jaxatt that imports matplotlib.

Functions take `ax=None` and return the `Axes` (or a `Figure` for multi-panel views); they never
call `plt.show()` and never touch global rcParams (use `with jaxatt.plot.style(): ...`).
"""

from ._trajectory import (
    plot_attitude_error as plot_attitude_error,
    plot_control as plot_control,
    plot_overview as plot_overview,
    plot_rate_error as plot_rate_error,
    plot_signal as plot_signal,
    style as style,
)
