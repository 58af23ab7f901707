r"""Fast power reaching law $\dot s = -k_1 s - k_2|s|^\alpha\operatorname{sgn}(s)$."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_in_open_interval, check_positive
from ..numerics import abs_pow
from ._arrays import as_param, as_state
from ._base import AbstractFiniteTimeReachingLaw, require_sign_switching
from ._switching import AbstractSwitching, Sign


class FastPower(AbstractFiniteTimeReachingLaw):
    r"""Fast power (fast terminal attractor) reaching law, elementwise:

    $$\dot s = -k_1 s - k_2 |s|^{\alpha}\operatorname{sgn}(s),
    \qquad k_1 > 0,\ k_2 > 0,\ 0 < \alpha < 1.$$

    The linear term dominates far from 0 and the power term near 0. `sgn` is the `switching`
    field. It is the $|s| < 1$ phase of [`TwoPhasePower`][] (Chen et al. 2022 eq. (17)).

    **Gradients:** as [`Power`][]: the slope in `s` at 0 is capped (finite), and the derivative
    in $\alpha$ vanishes at `s = 0`.

    !!! cite
        X. Yu, Z. Man, "Fast terminal sliding-mode control design for nonlinear dynamical
        systems", IEEE Trans. Circuits and Systems I 49(2):261-264, 2002 (the fast terminal
        attractor $\dot s = -\alpha s - \beta s^{q/p}$ and its reaching time).
    """

    k1: Float[Array, "..."]
    k2: Float[Array, "..."]
    alpha: Float[Array, "..."]
    switching: AbstractSwitching

    def __init__(
        self,
        k1: RealScalarLike | Float[ArrayLike, "..."],
        k2: RealScalarLike | Float[ArrayLike, "..."],
        alpha: RealScalarLike | Float[ArrayLike, "..."],
        switching: AbstractSwitching = Sign(),
    ):
        r"""**Arguments:**
        - `k1`: linear gain $k_1 > 0$ [1/time]; a scalar or per-axis array.
        - `k2`: power gain $k_2 > 0$; scalar or per axis.
        - `alpha`: exponent $\alpha \in (0, 1)$; scalar or per axis.
        - `switching`: the function used for $\operatorname{sgn}$; default `Sign()`.
        """
        self.k1 = check_positive("FastPower", "k1", k1)
        self.k2 = check_positive("FastPower", "k2", k2)
        self.alpha = check_in_open_interval("FastPower", "alpha", alpha, 0.0, 1.0)
        self.switching = switching

    def rate(self, s: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        s = as_state(s)
        k1 = as_param("FastPower", "k1", self.k1, s)
        k2 = as_param("FastPower", "k2", self.k2, s)
        alpha = as_param("FastPower", "alpha", self.alpha, s)
        return -k1 * s - k2 * self.switching.signed_power(s, alpha)

    def convergence_time(self, s0: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Exact reaching time (requires `switching=Sign()`):

        $$T(s_0) = \frac{1}{k_1(1-\alpha)}\ln\Big(1 + \frac{k_1}{k_2}|s_0|^{1-\alpha}\Big).$$

        With $y = |s|^{1-\alpha}$ the law reads $\dot y = -(1-\alpha)(k_1 y + k_2)$ (Yu and
        Man 2002; Chen et al. 2022 eq. (18)). **Gradient** in `s0` at `s0 = 0` is 0 (the
        true one is infinite); in the parameters it is finite everywhere.
        """
        require_sign_switching(self, "convergence_time")
        s0 = as_state(s0)
        k1 = as_param("FastPower", "k1", self.k1, s0)
        k2 = as_param("FastPower", "k2", self.k2, s0)
        alpha = as_param("FastPower", "alpha", self.alpha, s0)
        return jnp.log1p(k1 / k2 * abs_pow(s0, 1 - alpha)) / (k1 * (1 - alpha))
