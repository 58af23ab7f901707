"""The performance-function (envelope) interface."""

import abc

import equinox as eqx
from jaxtyping import Array, Float

from .._custom_types import RealScalarLike


class AbstractPerformance(eqx.Module):
    r"""A prescribed-performance envelope $\rho(t)$, elementwise over its parameter arrays.

    Concrete envelopes implement `value(t)` and `derivative(t)` in closed form and expose
    `initial` ($\rho(0)$) and `final` ($\rho_\infty = \lim_{t\to\infty}\rho$). All parameters
    are arrays of one common shape (one envelope per component); `t` is a scalar time [s]
    measured from the start of the manoeuvre.
    """

    @abc.abstractmethod
    def value(self, t: RealScalarLike) -> Float[Array, "*k"]:
        r"""$\rho(t)$."""

    @abc.abstractmethod
    def derivative(self, t: RealScalarLike) -> Float[Array, "*k"]:
        r"""$\dot\rho(t)$."""

    @property
    @abc.abstractmethod
    def initial(self) -> Float[Array, "*k"]:
        r"""$\rho(0)$."""

    @property
    @abc.abstractmethod
    def final(self) -> Float[Array, "*k"]:
        r"""$\rho_\infty$."""

    def __call__(self, t: RealScalarLike) -> tuple[Float[Array, "*k"], Float[Array, "*k"]]:
        r"""$(\rho(t), \dot\rho(t))$."""
        return self.value(t), self.derivative(t)
