"""Which fields of a module are tuned, and how they are constrained."""

from collections.abc import Callable, Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax._src.lax.lax import _convert_element_type  # keeps weak types (see `_like`)
from jaxtyping import Array, PyTree

from ._transforms import AbstractTransform


class Parameter(eqx.Module):
    """A tuned field: `where(module)` selects the array, `transform` keeps it in range.

    !!! example
        `Parameter(lambda loop: loop.controller.reaching_law.rho, Positive())`
    """

    where: Callable = eqx.field(static=True)
    transform: AbstractTransform


Parameters = Mapping[str, Parameter]


def check_parameters(template: eqx.Module, parameters: Mapping) -> None:
    """Validate a tuning configuration before anything is compiled (clear `ValueError`s)."""
    if not isinstance(parameters, Mapping) or not parameters:
        raise ValueError("tune: `parameters` must be a non-empty mapping name -> Parameter.")
    for name, parameter in parameters.items():
        if not isinstance(parameter, Parameter):
            raise ValueError(
                f"tune: parameter {name!r} must be a jaxatt.tune.Parameter(where, transform), "
                f"got {type(parameter).__name__}."
            )
        try:
            value = parameter.where(template)
        except (AttributeError, TypeError, KeyError, IndexError) as error:
            raise ValueError(
                f"tune: parameter {name!r}: its `where` does not select a field of the "
                f"template ({type(error).__name__}: {error})."
            ) from None
        if not isinstance(value, jax.Array) or isinstance(value, jax.core.Tracer):
            raise ValueError(
                f"tune: parameter {name!r} must select an array field of the template, got "
                f"{type(value).__name__}."
            )
        if not jnp.issubdtype(value.dtype, jnp.floating):
            raise ValueError(f"tune: parameter {name!r} must be a floating array.")
        if not parameter.transform.contains(value):
            raise ValueError(
                f"tune: parameter {name!r} has initial value {np.asarray(value)} outside its "
                f"transform's range ({parameter.transform.describe()}); the transform cannot "
                "hold it."
            )


def initial_unconstrained(template: eqx.Module, parameters: Parameters) -> dict[str, Array]:
    """The unconstrained variables that reproduce the template's current gains."""
    # Strongly typed arrays: optimizer updates are strongly typed, and a weak-typed start would
    # compile the step twice.
    return {
        name: jnp.asarray(u, dtype=u.dtype)
        for name, p in parameters.items()
        for u in (p.transform.inverse(p.where(template)),)
    }


def constrained(unconstrained: dict[str, Array], parameters: Parameters) -> dict[str, Array]:
    """Gains from unconstrained variables."""
    return {name: parameters[name].transform.forward(u) for name, u in unconstrained.items()}


def apply(template: eqx.Module, parameters: Parameters, unconstrained: dict[str, Array]) -> PyTree:
    """The template with every tuned field replaced (`eqx.tree_at`)."""
    module = template
    for name, value in constrained(unconstrained, parameters).items():
        old = parameters[name].where(module)
        module = eqx.tree_at(parameters[name].where, module, _like(value, old))
    return module


def _like(value: Array, old: Array) -> Array:
    """`value` with the dtype *and weak type* of `old`.

    Gains built from Python floats are weakly typed; a tuned module whose gains are strongly
    typed would not match the template's compiled programs and would compile them again.
    `lax.convert_element_type` always returns a strong type, hence the private converter.
    """
    weak = bool(jax.typeof(old).weak_type)
    return _convert_element_type(value, old.dtype, weak_type=weak)
