"""Simulation results."""

import equinox as eqx
import numpy as np
from jaxtyping import Array, Bool, Float, Int, PyTree

from ._status import Status


EVENT_CAPACITY = 16
"""Number of event times kept per named event (the count is always exact)."""


class EventRecord(eqx.Module):
    """The occurrences of one named discrete event (e.g. an MRP shadow switch).

    - `count`: how many times it happened over the run (exact).
    - `times`: the times [s] of the first [`EVENT_CAPACITY`][] occurrences, in order; unused
      entries are NaN.
    """

    count: Int[Array, "*batch"]
    times: Float[Array, "*batch capacity"]


class Trajectory(eqx.Module):
    """A simulated closed loop sampled at the save times.

    Every array has time as its leading axis (after any batch axes added by `vmap`).

    - `ts`: save times [s], shape (T,).
    - `states`: the closed loop's stacked states (a `ClosedLoopState` for a [`ClosedLoop`][]:
      `plant`, `reference`, `controller`, `observer`, `actuator`).
    - `signals`: recorded signals by name (see [`ClosedLoop`][]'s signals); `"u"` is the
      applied control.
    - `status`: a [`Status`][] code as an integer array (per sample when batched).
    - `failure_time`: the time [s] at which the first failure was detected: `t0` when the
      initial state already fails, otherwise the end of the first step whose state fails (a
      point of the integration grid, not necessarily a save time); `inf` when the run
      succeeded.
    - `events`: named discrete events (e.g. `"shadow_switch"`) as [`EventRecord`][]s.

    With `simulate(..., throw=True)` (the default) a failure raises instead.
    """

    ts: Float[Array, "*batch T"]
    states: PyTree[Array]
    signals: dict[str, Array]
    status: Int[Array, "*batch"]
    failure_time: Float[Array, "*batch"]
    events: dict[str, EventRecord]

    @property
    def plant_states(self) -> PyTree[Array]:
        return self.states.plant

    @property
    def controller_states(self) -> PyTree[Array]:
        return self.states.controller

    @property
    def reference_states(self) -> PyTree[Array]:
        return self.states.reference

    @property
    def observer_states(self) -> PyTree[Array]:
        return self.states.observer

    @property
    def actuator_states(self) -> PyTree[Array]:
        return self.states.actuator

    @property
    def controls(self) -> Float[Array, "..."]:
        """The applied control (after the actuator model)."""
        return self.signals["u"]

    @property
    def successful(self) -> Bool[Array, "*batch"]:
        """Boolean array: `status == Status.successful` (per sample when batched)."""
        return self.status == int(Status.successful)

    def status_names(self) -> str | list[str]:
        """The [`Status`][] name(s) of this trajectory (a list when batched)."""
        codes = np.asarray(self.status)
        if codes.ndim == 0:
            return Status(int(codes)).name
        return [Status(int(c)).name for c in codes.reshape(-1)]

    def to_numpy(self) -> dict[str, object]:
        """Plain NumPy copies, for plotting and saving: `{"ts", "states", "signals",
        "status", "failure_time", "events"}` (modules become dicts of their fields)."""

        def convert(tree):
            if tree is None:
                return None
            if isinstance(tree, eqx.Module):
                return {name: convert(getattr(tree, name)) for name in tree.__dataclass_fields__}
            if isinstance(tree, dict):
                return {k: convert(v) for k, v in tree.items()}
            if isinstance(tree, (tuple, list)):
                return [convert(v) for v in tree]
            return np.asarray(tree)

        return {
            "ts": np.asarray(self.ts),
            "states": convert(self.states),
            "signals": {k: np.asarray(v) for k, v in self.signals.items()},
            "status": np.asarray(self.status),
            "failure_time": np.asarray(self.failure_time),
            "events": convert(self.events),
        }
