r"""The reaching-law interfaces.

A reaching law prescribes the dynamics $\dot s = r(s)$ of a sliding variable, applied
elementwise (per axis) to a vector `s`. A sliding-mode controller takes a law as a field and
cancels everything else in $\dot s$, so "M1/M2/M3" of a paper are three law instances.
"""

import abc

import equinox as eqx
from jaxtyping import Array, ArrayLike, Float

from ._switching import AbstractSwitching, Sign


class AbstractReachingLaw(eqx.Module):
    r"""Reaching dynamics $\dot s = r(s)$, elementwise.

    Every law has a `switching` field (an [`AbstractSwitching`][]) used wherever its paper
    writes $\operatorname{sgn}(s)$; `Sign()` gives the paper's law, `Saturation(width)` or
    `Tanh(width)` its boundary-layer variant.
    """

    switching: eqx.AbstractVar[AbstractSwitching]

    def __check_init__(self):
        if not isinstance(self.switching, AbstractSwitching):
            raise TypeError(
                f"{type(self).__name__}: `switching` must be a jaxatt.reaching switching "
                "function (Sign(), Saturation(width), Tanh(width)), got "
                f"{type(self.switching).__name__} {self.switching!r}."
            )

    @abc.abstractmethod
    def rate(self, s: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Right-hand side $\dot s = r(s)$ of the reaching dynamics.

        **Arguments:**
        - `s`: sliding variable, a scalar or an array (the law acts on each component); gains
          must broadcast to its shape.

        **Returns:** $\dot s$, with the shape and dtype of `s`.
        """


class AbstractFiniteTimeReachingLaw(AbstractReachingLaw):
    r"""A reaching law whose time to reach $s = 0$ is known in closed form.

    The closed forms hold for the discontinuous law (`switching=Sign()`) without disturbance;
    with a boundary layer the law reaches the layer in finite time and then converges only
    asymptotically, so `convergence_time` raises a `ValueError` for any other switching.
    """

    @abc.abstractmethod
    def convergence_time(self, s0: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Time $T(s_0)$ for $\dot s = r(s)$, $s(0) = s_0$ to reach $s = 0$ [units of time].

        Elementwise; each law's docstring says whether the value is exact or a bound.

        **Arguments:**
        - `s0`: initial sliding variable, a scalar or an array.

        **Returns:** $T(s_0) \ge 0$, with the shape and dtype of `s0` ($T(0) = 0$).
        """


def require_sign_switching(law: AbstractReachingLaw, method: str) -> None:
    """Raise unless `law.switching` is `Sign()` (a static, trace-time type check)."""
    if not isinstance(law.switching, Sign):
        name = type(law).__name__
        raise ValueError(
            f"{name}.{method}: the closed-form time holds only for the discontinuous law "
            f"(switching=Sign()), got switching={type(law.switching).__name__}. With a "
            "boundary layer the law reaches the layer in finite time but s = 0 only "
            "asymptotically; build the law with switching=Sign() to ask for this time."
        )
