"""Simulation results."""

import equinox as eqx
import jax.numpy as jnp
import jax.tree_util as jtu
import numpy as np
from jaxtyping import Array, Float, PyTree

from ._closed_loop import ClosedLoopState


class RESULTS(eqx.Enumeration):
    """Outcome of a simulation, carried in `Trajectory.result` (batched under `vmap`)."""

    successful = ""
    nonfinite_state = (
        "The closed-loop state became NaN or infinite: the loop diverged or the step `dt` is too "
        "large for its fastest dynamics. Reduce `dt`, or check gains and initial conditions."
    )
    constraint_violated = (
        "The controller reported leaving its admissible set (its `diagnostics` signal "
        "`violation` was True at a saved time), e.g. a barrier function was crossed. The "
        "trajectory is returned, but the controller's guarantees do not hold on it."
    )


class Trajectory(eqx.Module):
    """A simulated closed loop sampled at the save times.

    Every array has time as its leading axis (after any batch axes added by `vmap`).

    - `ts`: save times [s], shape (T,).
    - `states`: a [`ClosedLoopState`][] of stacked plant, reference and controller states.
    - `signals`: recorded signals by name (see [`ClosedLoop.signals`][]): at least `"u"`
      (applied control), `"u_cmd"`, `"attitude_error"`, `"rate_error"`, `"disturbance"`.
    - `result`: a [`RESULTS`][] member: `RESULTS.successful`, `nonfinite_state`, or
      `constraint_violated` (a controller's `diagnostics()["violation"]` was True at a saved
      time). With `simulate(..., throw=True)` (the default) a failure raises instead.
    """

    ts: Float[Array, " T"]
    states: ClosedLoopState
    signals: dict[str, Array]
    result: RESULTS

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
    def controls(self) -> Float[Array, "T m"]:
        """The applied control (after the actuator model)."""
        return self.signals["u"]

    @property
    def successful(self) -> Array:
        """Boolean array: `result == RESULTS.successful` (per sample when batched)."""
        return self.result == RESULTS.successful

    def to_numpy(self) -> dict[str, object]:
        """Plain NumPy copies, for plotting and saving: `{"ts", "plant", "reference",
        "controller", "signals", "result"}` (states keep their field names as dicts)."""

        def convert(tree):
            if tree is None:
                return None
            if isinstance(tree, eqx.Module):
                return {name: convert(getattr(tree, name)) for name in tree.__dataclass_fields__}
            return np.asarray(tree)

        return {
            "ts": np.asarray(self.ts),
            "plant": convert(self.states.plant),
            "reference": convert(self.states.reference),
            "controller": convert(self.states.controller),
            "signals": {k: np.asarray(v) for k, v in self.signals.items()},
            "result": np.asarray(self.result._value),
        }


def all_finite(tree: PyTree[Array]) -> Array:
    leaves = [jnp.all(jnp.isfinite(leaf)) for leaf in jtu.tree_leaves(tree)]
    return jnp.all(jnp.stack(leaves)) if leaves else jnp.array(True)
