"""How the controller is sampled: inside the vector field, or held between samples."""

import abc
import math

import equinox as eqx

from .._validation import check_flag, is_real_scalar


def whole_steps(span: float, dt: float, magnitude: float = 0.0) -> int | None:
    """`span / dt` as a whole number of steps, or `None` where it is not one.

    The ratio of two floats carries rounding: a relative 1e-9 is forgiven (e.g. `0.3 / 0.1` is
    2.9999999999999996), and so is the rounding of the inputs themselves (a few units in the
    last place of `span`, or of `magnitude`, the largest time `span` was computed from), but
    never more than 1e-3 of a step otherwise. Without that cap, from 5e8 steps on
    a relative 1e-9 exceeded half a step and every horizon was accepted, silently rounded to
    the nearest whole step.
    """
    ratio = span / dt
    steps = round(ratio)
    rounding = 4 * math.ulp(max(abs(span), magnitude)) / dt
    tolerance = max(min(1e-9 * max(1.0, ratio), 1e-3), rounding)
    if steps < 1 or abs(ratio - steps) > tolerance:
        return None
    return steps


class AbstractSampling(eqx.Module):
    """Continuous evaluation or a zero-order hold; chosen by type (structure, not a number)."""

    @abc.abstractmethod
    def steps_per_sample(self, dt: float) -> int:
        """Integration steps between controller updates (0 means every solver stage)."""

    @property
    @abc.abstractmethod
    def delay(self) -> bool:
        """Whether a command computed at a sample instant is applied one period later."""


class Continuous(AbstractSampling):
    """Evaluate the controller (and the observer) inside the vector field, at every solver stage.

    This is the setting of the papers (the control law is part of the ODE). Discrete updates
    of the controller's and observer's states run after every completed step.
    """

    def steps_per_sample(self, dt: float) -> int:
        del dt
        return 0

    @property
    def delay(self) -> bool:
        return False


class ZeroOrderHold(AbstractSampling):
    r"""Run the flight software every `period` seconds and hold its outputs in between.

    At each sample instant $t_k = t_0 + k\,T$ the controller's and the observer's discrete
    updates run (for $k \ge 1$; `init` covers $t_0$), then the command and the derivatives of
    their continuous states are computed and held over $[t_k, t_{k+1})$ (their continuous
    states thus advance by forward Euler at the controller rate, as on a flight computer).

    **Arguments:**
    - `period`: $T > 0$ [s], a whole multiple of the integration step `dt` (the horizon need
      not be a multiple of $T$: the last hold ends at `t1`; a period longer than the horizon
      holds the command computed at `t0` throughout). Static: changing it recompiles, like
      changing `dt`.
    - `delay`: apply each command one period late: the command computed at $t_k$ acts over
      $[t_{k+1}, t_{k+2})$, and over the first period the actuator receives zeros (a
      stateful actuator, e.g. a [`FirstOrderLag`][], starts from that zero command). This is
      the timing of Basilisk's examples, where the flight software reads the sensors at
      $t_k$ and its command message reaches the actuator at the next task update. Default
      False (the command acts at once).
    """

    period: float = eqx.field(static=True)
    delayed: bool = eqx.field(static=True)

    def __init__(self, period: float, *, delay: bool = False):
        if not is_real_scalar(period):
            raise ValueError(f"ZeroOrderHold: `period` must be a number [s], got {period!r}.")
        period = float(period)
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"ZeroOrderHold: `period` must be positive, got period={period}.")
        self.period = period
        self.delayed = check_flag("ZeroOrderHold", "delay", delay)

    @property
    def delay(self) -> bool:
        return self.delayed

    def steps_per_sample(self, dt: float) -> int:
        steps = whole_steps(self.period, dt)
        if steps is None:
            raise ValueError(
                "ZeroOrderHold: `period` must be a whole multiple of `dt`, got "
                f"period={self.period}, dt={dt}."
            )
        return steps
