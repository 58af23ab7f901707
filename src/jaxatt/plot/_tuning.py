"""Figures of a tuning run."""

import matplotlib.pyplot as plt
import numpy as np
from jaxtyping import ArrayLike, Float
from matplotlib.axes import Axes


def plot_loss_curve(
    losses: Float[ArrayLike, " steps"], *, ax: Axes | None = None, label: str | None = None
) -> Axes:
    """The objective at each optimizer step (evaluated before that step's update)."""
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 3))
    losses = np.asarray(losses)
    ax.plot(np.arange(1, len(losses) + 1), losses, marker="o", ms=3, lw=1.2, label=label)
    ax.set_xlabel("optimizer step")
    ax.set_ylabel("objective")
    if label is not None:
        ax.legend()
    return ax
