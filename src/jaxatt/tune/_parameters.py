"""Which fields of a module are tuned, and how they are constrained."""

from collections.abc import Mapping, Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, PyTree

from .._paths import get_path, parse_path, path_selector
from ._transforms import AbstractTransform


class Parameter(eqx.Module):
    """A tuned field: the array at `path` in the module, kept in range by `transform`.

    `path` is a dotted path of attribute names (and `[k]` indices for tuples or dicts), e.g.
    `"controller.reaching_law.rho"`. Paths are strings, so two equal tuning problems are equal
    static arguments and share their compiled programs (no module-level selector functions or
    cached optimizers needed).

    !!! example
        `Parameter("controller.reaching_law.rho", Positive())`
    """

    path: str = eqx.field(static=True)
    transform: AbstractTransform

    def __init__(self, path: str, transform: AbstractTransform):
        if callable(path) and not isinstance(path, str):
            raise ValueError(
                "Parameter: `path` must be a dotted path string such as "
                "'controller.reaching_law.rho' (hashable, so equal problems share compiled "
                f"programs), got the callable {path!r}."
            )
        parse_path(path)
        if not isinstance(transform, AbstractTransform):
            raise ValueError(
                "Parameter: `transform` must be a jaxatt.tune transform (Positive(), "
                f"Interval(a, b), GreaterThan(a), Identity()), got {type(transform).__name__}."
            )
        self.path = path
        self.transform = transform

    def where(self, module: PyTree) -> Any:
        """The tuned array of `module`: also a `where` for `eqx.tree_at(p.where, module, new)`.

        Annotated `Any`, not `Array`: inside `eqx.tree_at` the field holds equinox's
        placeholder, which a runtime type checker would refuse as an array.
        """
        return get_path(module, self.path)


Parameters = Mapping[str, Parameter]


def check_parameters(template: eqx.Module, parameters: Mapping) -> None:
    """Validate a tuning configuration before anything is compiled (clear `ValueError`s)."""
    if not isinstance(parameters, Mapping) or not parameters:
        raise ValueError("tune: `parameters` must be a non-empty mapping name -> Parameter.")
    for name, parameter in parameters.items():
        if not isinstance(parameter, Parameter):
            raise ValueError(
                f"tune: parameter {name!r} must be a jaxatt.tune.Parameter(path, transform), "
                f"got {type(parameter).__name__}."
            )
        try:
            value = parameter.where(template)
        except (AttributeError, TypeError, KeyError, IndexError) as error:
            raise ValueError(
                f"tune: parameter {name!r}: its path {parameter.path!r} does not select a field "
                f"of the template ({type(error).__name__}: {error})."
            ) from None
        if not isinstance(value, jax.Array) or isinstance(value, jax.core.Tracer):
            raise ValueError(
                f"tune: parameter {name!r} ({parameter.path!r}) must select an array field of "
                f"the template, got {type(value).__name__}."
            )
        if not jnp.issubdtype(value.dtype, jnp.floating):
            raise ValueError(f"tune: parameter {name!r} must be a floating array.")
        if not np.all(np.isfinite(np.asarray(value))):
            raise ValueError(
                f"tune: parameter {name!r} has the non-finite initial value {np.asarray(value)}."
            )
        if not parameter.transform.contains(value):
            raise ValueError(
                f"tune: parameter {name!r} has initial value {np.asarray(value)} outside its "
                f"transform's range ({parameter.transform.describe()}); the transform cannot "
                "hold it."
            )


def initial_unconstrained(template: eqx.Module, parameters: Parameters) -> dict[str, Array]:
    """The unconstrained variables that reproduce the template's current gains."""
    # Strongly typed arrays: optimizer updates are strongly typed.
    return {
        name: jnp.asarray(u, dtype=u.dtype)
        for name, p in parameters.items()
        for u in (p.transform.inverse(p.where(template)),)
    }


def constrained(unconstrained: dict[str, Array], parameters: Parameters) -> dict[str, Array]:
    """Gains from unconstrained variables."""
    return {name: parameters[name].transform.forward(u) for name, u in unconstrained.items()}


def apply(template: eqx.Module, parameters: Parameters, unconstrained: dict[str, Array]) -> PyTree:
    """The template with every tuned field set from its unconstrained variable
    ([`with_gains`][] of the [`constrained`][] gains)."""
    return with_gains(template, parameters, constrained(unconstrained, parameters))


def with_gains(
    template: eqx.Module, parameters: Parameters, gains: Mapping[str, ArrayLike | Sequence]
) -> PyTree:
    """The template with the fields of the named `gains` (constrained values, e.g. a tuning
    report's `gains_after`) replaced (`eqx.tree_at`), each in the dtype of the field it
    replaces: jaxatt's constructors store strongly typed arrays, so a tuned module has the
    template's exact types and reuses its compiled programs. A name not in `parameters`, or a
    value of another shape than its field, is a `ValueError`."""
    module = template
    for name, value in gains.items():
        if name not in parameters:
            raise ValueError(
                f"with_gains: `gains` names {name!r}, which is not one of the parameters "
                f"{sorted(parameters)}."
            )
        select = path_selector(parameters[name].path)
        old = select(module)
        if np.shape(value) != old.shape:
            raise ValueError(
                f"with_gains: gain {name!r} must have the shape of "
                f"{parameters[name].path} {old.shape}, got {np.shape(value)}."
            )
        module = eqx.tree_at(select, module, jnp.asarray(value, dtype=old.dtype))
    return module
