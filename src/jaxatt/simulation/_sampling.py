"""How the controller is sampled: inside the vector field, or held between samples."""

import abc
import math

import equinox as eqx


class AbstractSampling(eqx.Module):
    """Continuous evaluation or a zero-order hold; chosen by type (structure, not a number)."""

    @abc.abstractmethod
    def steps_per_sample(self, dt: float) -> int:
        """Integration steps between controller updates (0 means every solver stage)."""


class Continuous(AbstractSampling):
    """Evaluate the controller inside the vector field, at every solver stage.

    This is the setting of the papers (the control law is part of the ODE).
    """

    def steps_per_sample(self, dt: float) -> int:
        del dt
        return 0


class ZeroOrderHold(AbstractSampling):
    """Compute the control every `period` seconds and hold it in between.

    `period` must be a whole multiple of the integration step `dt`. The controller's internal
    state derivative is held too (forward Euler at the controller rate). `period` is static:
    changing it recompiles, like changing `dt`.
    """

    period: float = eqx.field(static=True)

    def __init__(self, period: float):
        period = float(period)
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"ZeroOrderHold: `period` must be positive, got period={period}.")
        self.period = period

    def steps_per_sample(self, dt: float) -> int:
        ratio = self.period / dt
        steps = round(ratio)
        if steps < 1 or abs(ratio - steps) > 1e-9 * max(1.0, ratio):
            raise ValueError(
                "ZeroOrderHold: `period` must be a whole multiple of `dt`, got "
                f"period={self.period}, dt={dt}."
            )
        return steps
