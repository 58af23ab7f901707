r"""Constant-rate reaching law $\dot s = -k\operatorname{sgn}(s)$."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_positive
from ._arrays import as_param, as_state
from ._base import AbstractFiniteTimeReachingLaw, require_sign_switching
from ._switching import AbstractSwitching, Sign


class ConstantRate(AbstractFiniteTimeReachingLaw):
    r"""Constant-rate reaching law, elementwise:

    $$\dot s = -k \operatorname{sgn}(s), \qquad k > 0.$$

    `sgn` is the `switching` field (`Sign()` by default; `Saturation`/`Tanh` for the
    boundary-layer variant).

    **Gradients:** with `Sign()` the rate is piecewise constant: its derivative in `s` is 0
    and in `k` is $-\operatorname{sgn}(s)$ (0 at `s = 0`).

    !!! cite
        W. Gao, J. C. Hung, "Variable structure control of nonlinear systems: a new approach",
        IEEE Trans. Industrial Electronics 40(1):45-55, 1993 (the constant-rate reaching law).
    """

    k: Float[Array, "..."]
    switching: AbstractSwitching

    def __init__(
        self,
        k: RealScalarLike | Float[ArrayLike, "..."],
        switching: AbstractSwitching = Sign(),
    ):
        r"""**Arguments:**
        - `k`: rate $k > 0$ [units of s per unit time]; a scalar or per-axis array.
        - `switching`: the function used for $\operatorname{sgn}$; default `Sign()`.
        """
        self.k = check_positive("ConstantRate", "k", k)
        self.switching = switching

    def rate(self, s: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        s = as_state(s)
        k = as_param("ConstantRate", "k", self.k, s)
        return -k * self.switching(s)

    def convergence_time(self, s0: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Exact reaching time $T(s_0) = |s_0|/k$ (requires `switching=Sign()`).

        **Gradient** in `s0` at `s0 = 0`: $1/k$ (one side of the kink of $|s_0|$).
        """
        require_sign_switching(self, "convergence_time")
        s0 = as_state(s0)
        k = as_param("ConstantRate", "k", self.k, s0)
        return jnp.abs(s0) / k
