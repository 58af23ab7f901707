r"""Actuator models between the commanded and the applied control, possibly with state."""

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, PyTree

from .._custom_types import RealScalarLike
from .._validation import check_positive, check_positive_scalar, describe, is_traced
from ..numerics import clip, safe_norm


def _check_per_axis(where: str, name: str, value) -> Array:
    """A positive scalar or a 1-D array of positive values (one per command axis)."""
    arr = check_positive(where, name, value)
    if arr.ndim > 1:
        raise ValueError(
            f"{where}: `{name}` must be a scalar or a 1-D array (one value per command axis), "
            f"got shape {arr.shape} ({name}={describe(arr) if not is_traced(arr) else 'traced'})."
        )
    return arr


def _check_matches_command(where: str, name: str, value: ArrayLike, command) -> None:
    """A per-axis `value` must have one entry per axis of the command (checked when the loop is
    traced: the command's shape is only known then, before anything is compiled)."""
    shape = jnp.shape(command)
    if jnp.ndim(value) == 1 and (len(shape) == 0 or shape[-1] != jnp.shape(value)[0]):
        raise ValueError(
            f"{where}: `{name}` has shape {jnp.shape(value)} (one value per axis) but the "
            f"controller's command has shape {shape}; give a scalar or one value per axis."
        )


def _nan_unless_positive(limit: Float[ArrayLike, "*m"]) -> Float[Array, "*m"]:
    """`limit` where it is positive, NaN elsewhere. The constructors refuse a non-positive
    limit, but one reached by tracing (a batch of sampled limits, a tuning step) cannot be
    refused: a negative one would turn the command around (the run would look plausible),
    so it makes the applied control NaN, which the loop reports as a failed sample."""
    limit = jnp.asarray(limit)
    return jnp.where(limit > 0, limit, jnp.nan)


class AbstractActuator(eqx.Module):
    r"""Maps the commanded control to the applied one, with an optional state of its own.

    **Required:** `__call__(t, command, state) -> (applied, state_dot)`.

    **Optional hooks** (defaults: no state, nothing to do): `init(t0, command) -> state` (the
    actuator's state at `t0`, given the first command), `update(t, state) -> state` after each
    completed step, `signals(t, command, state) -> dict` recorded at the save times.
    Actuator states are integrated with the plant in the closed loop's `actuator` slot.
    """

    @abc.abstractmethod
    def __call__(
        self, t: RealScalarLike, command: Float[Array, "..."], state: PyTree[Array]
    ) -> tuple[Float[Array, "..."], PyTree[Array]]:
        """The applied control and the derivative of the actuator's state."""

    def init(self, t0: RealScalarLike, command: Float[Array, "..."]) -> PyTree[Array]:
        """The actuator's state at `t0` (default: none)."""
        del t0, command
        return None

    def update(self, t: RealScalarLike, state: PyTree[Array]) -> PyTree[Array]:
        """Discrete map after each completed step (default: none)."""
        del t
        return state

    def signals(
        self, t: RealScalarLike, command: Float[Array, "..."], state: PyTree[Array]
    ) -> dict[str, Array]:
        """Named signals recorded at the save times (default: none)."""
        del t, command, state
        return {}


class Ideal(AbstractActuator):
    """The commanded control is applied exactly."""

    def __call__(self, t, command, state):
        del t, state
        return command, None


class Saturation(AbstractActuator):
    r"""Per-axis saturation $u_i \leftarrow \min(u_{\max,i}, \max(-u_{\max,i}, u_i))$.

    **Arguments:**
    - `limit`: $u_{\max}$, positive scalar or per-axis array [N m] (Chen 2022: 30 N m).

    **Gradient:** 1 inside the limits, 0 where an axis is saturated (with respect to `u`);
    with respect to `limit`, 1 on saturated axes.

    A limit that is not positive at run time (traced, so not refused here: a sampled or tuned
    limit) makes the applied control NaN, so the sample is reported as failed.
    """

    limit: Float[Array, "*m"]

    def __init__(self, limit: Float[ArrayLike, "*m"]):
        self.limit = _check_per_axis("Saturation", "limit", limit)

    def __call__(self, t, command, state):
        del t, state
        _check_matches_command("Saturation", "limit", self.limit, command)
        limit = _nan_unless_positive(self.limit)
        return clip(command, -limit, limit), None


class NormSaturation(AbstractActuator):
    r"""Scale the command down to a maximum Euclidean norm, preserving its direction.

    $u \leftarrow u \min(1, u_{\max}/\|u\|)$.

    **Arguments:**
    - `max_norm`: $u_{\max} > 0$ [N m], a scalar (a per-axis limit is [`Saturation`][]). One
      that is not positive at run time (traced) makes the applied control NaN, as in
      [`Saturation`][].
    """

    max_norm: Float[Array, ""]

    def __init__(self, max_norm: Float[ArrayLike, ""]):
        self.max_norm = check_positive_scalar("NormSaturation", "max_norm", max_norm)

    def __call__(self, t, command, state):
        del t, state
        norm = safe_norm(command)
        max_norm = _nan_unless_positive(self.max_norm)
        over = ~(norm <= max_norm)  # a NaN limit scales by NaN
        scale = jnp.where(over, max_norm / jnp.where(over, norm, 1), 1)
        return command * scale, None


class FirstOrderLag(AbstractActuator):
    r"""Actuator dynamics $\tau\,\dot u = u_{\mathrm{cmd}} - u$: the applied control lags the
    command with time constant $\tau$ (a reaction wheel's torque loop, a thruster valve).

    The applied control $u$ is the actuator's state, integrated with the plant; it starts at
    the first command (`init`), so a constant command is applied exactly.

    **Arguments:**
    - `time_constant`: $\tau > 0$ [s], scalar or per axis. One that is not positive at run
      time (traced: sampled or tuned) makes the state's derivative NaN, so the sample fails
      (a negative one would make the lag grow exponentially, plausibly for a while).
    """

    time_constant: Float[Array, "*m"]

    def __init__(self, time_constant: Float[ArrayLike, "*m"]):
        self.time_constant = _check_per_axis("FirstOrderLag", "time_constant", time_constant)

    def init(self, t0, command):
        del t0
        _check_matches_command("FirstOrderLag", "time_constant", self.time_constant, command)
        return jnp.asarray(command)

    def __call__(self, t, command, state):
        del t
        _check_matches_command("FirstOrderLag", "time_constant", self.time_constant, command)
        return state, (command - state) / _nan_unless_positive(self.time_constant)


class Chain(AbstractActuator):
    """Apply several actuator models in order, e.g. a lag, then a norm limit, then a per-axis
    limit. The state is the tuple of the stages' states."""

    stages: tuple[AbstractActuator, ...]

    def __init__(self, *stages: AbstractActuator):
        if not stages or not all(isinstance(s, AbstractActuator) for s in stages):
            raise ValueError("Chain: pass one or more actuator models (Saturation, ...).")
        self.stages = tuple(stages)

    def init(self, t0, command):
        states = []
        for stage in self.stages:
            state = stage.init(t0, command)
            states.append(state)
            command, _ = stage(t0, command, state)
        return tuple(states)

    def __call__(self, t, command, state):
        derivatives = []
        for stage, stage_state in zip(self.stages, state):
            command, derivative = stage(t, command, stage_state)
            derivatives.append(derivative)
        return command, tuple(derivatives)

    def update(self, t, state):
        return tuple(stage.update(t, s) for stage, s in zip(self.stages, state))

    def signals(self, t, command, state):
        out = {}
        for stage, stage_state in zip(self.stages, state):
            for name, value in stage.signals(t, command, stage_state).items():
                if name in out:  # `dict.update` kept the last stage's value, silently
                    raise ValueError(
                        f"Chain: two stages record the signal {name!r} (e.g. two EnergyMeter "
                        f"stages); keep one, or wrap the chain in one EnergyMeter."
                    )
                out[name] = value
            command, _ = stage(t, command, stage_state)
        return out
