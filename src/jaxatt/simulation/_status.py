"""Per-sample outcome codes of a simulation, returned to the host as integers.

A simulation's status is an integer array (one entry per sample under `vmap`), not a host
callback inside the compiled program: programs stay free of callbacks (so they can be cached
across processes), one failing sample never aborts a batch, and `simulate(..., throw=True)`
raises on the host after the program has returned.
"""

import enum

import numpy as np
from jaxtyping import ArrayLike


class Status(enum.IntEnum):
    """Outcome of one simulated closed loop (`Trajectory.status`).

    The first failure of a run is kept (a later one does not overwrite it), together with the
    time at which it was detected (`Trajectory.failure_time`). Every condition is checked on the
    initial state (a failure there is timed `t0`) and after every completed integration step
    (timed at the step's end), not only at the saved times.
    """

    successful = 0
    nonfinite_state = 1
    constraint_violated = 2
    invalid_plant = 3

    @property
    def message(self) -> str:
        """What the status means, in a sentence."""
        return _MESSAGES[self]


_MESSAGES = {
    Status.successful: "The simulation succeeded.",
    Status.nonfinite_state: (
        "The closed-loop state became NaN or infinite: the loop diverged or the step `dt` is too "
        "large for its fastest dynamics. Reduce `dt`, or check gains and initial conditions "
        "(and sampled or tuned actuator limits: one that is not positive makes the control NaN)."
    ),
    Status.constraint_violated: (
        "The controller left its admissible set (its `admissible` check failed after a "
        "completed step), e.g. a barrier function was crossed. The trajectory is returned, but "
        "the controller's guarantees do not hold on it."
    ),
    Status.invalid_plant: (
        "The plant's parameters left their valid set during the run (its `valid` check failed "
        "after a completed step), e.g. a time-varying inertia J0 + dJ(t) stopped being "
        "positive definite. The motion after that time is not physical."
    ),
}


def status_names(codes: ArrayLike) -> list[str] | str:
    """The [`Status`][] names of integer codes (a list for an array, a string for a scalar)."""
    codes = np.asarray(codes)
    if codes.ndim == 0:
        return Status(int(codes)).name
    return [Status(int(c)).name for c in codes.reshape(-1)]


class SimulationFailed(RuntimeError):
    """Raised by `simulate(..., throw=True)` when the run did not succeed.

    `status` is the [`Status`][] of the (first) failing sample and `failure_time` the time [s]
    at which the failure was detected.
    """

    def __init__(self, status: Status, failure_time: float, detail: str = ""):
        self.status = status
        self.failure_time = failure_time
        super().__init__(
            f"simulate: {status.name} at t = {failure_time:.6g} s. {status.message}{detail}"
        )
