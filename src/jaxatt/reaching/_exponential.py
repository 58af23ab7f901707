r"""Exponential reaching law $\dot s = -k_1 s - k_2\operatorname{sgn}(s)$."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_positive
from ._arrays import as_param, as_state
from ._base import AbstractFiniteTimeReachingLaw, require_sign_switching
from ._switching import AbstractSwitching, Sign


class Exponential(AbstractFiniteTimeReachingLaw):
    r"""Exponential reaching law, elementwise:

    $$\dot s = -k_1 s - k_2 \operatorname{sgn}(s), \qquad k_1 > 0,\ k_2 > 0.$$

    `sgn` is the `switching` field. This is law "M2" of Chen et al. (2022).

    **Gradients:** with `Sign()` the derivative in `s` is $-k_1$ (the sign term is flat), and
    `k2` receives the gradient $-\operatorname{sgn}(s)$ (0 at `s = 0`).

    !!! cite
        Chen Q., Zhu J., Tao M., "Two-phase power reaching law based spacecraft attitude
        control", Control and Decision 37(5):1145-1152, 2022, eq. (24); the law is due to
        W. Gao, J. C. Hung, IEEE Trans. Industrial Electronics 40(1):45-55, 1993.
    """

    k1: Float[Array, "..."]
    k2: Float[Array, "..."]
    switching: AbstractSwitching

    def __init__(
        self,
        k1: RealScalarLike | Float[ArrayLike, "..."],
        k2: RealScalarLike | Float[ArrayLike, "..."],
        switching: AbstractSwitching = Sign(),
    ):
        r"""**Arguments:**
        - `k1`: proportional gain $k_1 > 0$ [1/time]; a scalar or per-axis array.
        - `k2`: switching gain $k_2 > 0$ [units of s per unit time]; scalar or per axis.
        - `switching`: the function used for $\operatorname{sgn}$; default `Sign()`.
        """
        self.k1 = check_positive("Exponential", "k1", k1)
        self.k2 = check_positive("Exponential", "k2", k2)
        self.switching = switching

    def rate(self, s: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        s = as_state(s)
        k1 = as_param("Exponential", "k1", self.k1, s)
        k2 = as_param("Exponential", "k2", self.k2, s)
        return -k1 * s - k2 * self.switching(s)

    def convergence_time(self, s0: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Exact reaching time (requires `switching=Sign()`):

        $$T(s_0) = \frac{1}{k_1}\ln\Big(1 + \frac{k_1 |s_0|}{k_2}\Big).$$

        Solving $\frac{d}{dt}|s| = -k_1|s| - k_2$ gives it. **Gradients** are finite everywhere;
        in `s0` at `s0 = 0` it is $1/k_2$ (one side of the kink of $|s_0|$, as
        [`ConstantRate`][jaxatt.reaching.ConstantRate]'s $1/k$).
        """
        require_sign_switching(self, "convergence_time")
        s0 = as_state(s0)
        k1 = as_param("Exponential", "k1", self.k1, s0)
        k2 = as_param("Exponential", "k2", self.k2, s0)
        return jnp.log1p(k1 * jnp.abs(s0) / k2) / k1
