"""Actuator models applied between the commanded and the applied control."""

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._validation import check_positive
from ..numerics import safe_norm


class AbstractActuator(eqx.Module):
    """Maps the commanded control to the applied control: `applied = actuator(commanded)`."""

    @abc.abstractmethod
    def __call__(self, u: Float[Array, " m"]) -> Float[Array, " m"]:
        """The applied control."""


class Ideal(AbstractActuator):
    """The commanded control is applied exactly."""

    def __call__(self, u: Float[Array, " m"]) -> Float[Array, " m"]:
        return u


class Saturation(AbstractActuator):
    r"""Per-axis saturation $u_i \leftarrow \min(u_{\max,i}, \max(-u_{\max,i}, u_i))$.

    **Arguments:**
    - `limit`: $u_{\max}$, positive scalar or per-axis array [N m] (Chen 2022: 30 N m).

    **Gradient:** 1 inside the limits, 0 where an axis is saturated (with respect to `u`);
    with respect to `limit`, 1 on saturated axes.
    """

    limit: Float[Array, "*m"]

    def __init__(self, limit: Float[ArrayLike, "*m"]):
        self.limit = check_positive("Saturation", "limit", limit)

    def __call__(self, u: Float[Array, " m"]) -> Float[Array, " m"]:
        return jnp.clip(u, -self.limit, self.limit)


class NormSaturation(AbstractActuator):
    r"""Scale the command down to a maximum Euclidean norm, preserving its direction.

    $u \leftarrow u \min(1, u_{\max}/\|u\|)$.

    **Arguments:**
    - `max_norm`: $u_{\max} > 0$ [N m].
    """

    max_norm: Float[Array, ""]

    def __init__(self, max_norm: Float[ArrayLike, ""]):
        self.max_norm = check_positive("NormSaturation", "max_norm", max_norm)

    def __call__(self, u: Float[Array, " m"]) -> Float[Array, " m"]:
        norm = safe_norm(u)
        over = norm > self.max_norm
        scale = jnp.where(over, self.max_norm / jnp.where(over, norm, 1), 1)
        return u * scale


class Chain(AbstractActuator):
    """Apply several actuator models in order, e.g. a norm limit then a per-axis limit."""

    stages: tuple[AbstractActuator, ...]

    def __init__(self, *stages: AbstractActuator):
        if not stages or not all(isinstance(s, AbstractActuator) for s in stages):
            raise ValueError("Chain: pass one or more actuator models (Saturation, ...).")
        self.stages = tuple(stages)

    def __call__(self, u: Float[Array, " m"]) -> Float[Array, " m"]:
        for stage in self.stages:
            u = stage(u)
        return u
