r"""Power-rate reaching law $\dot s = -k|s|^\alpha\operatorname{sgn}(s)$."""

from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_in_open_interval, check_positive
from ..numerics import abs_pow
from ._arrays import as_param, as_state
from ._base import AbstractFiniteTimeReachingLaw, require_sign_switching
from ._switching import AbstractSwitching, Sign


class Power(AbstractFiniteTimeReachingLaw):
    r"""Power-rate reaching law, elementwise:

    $$\dot s = -k |s|^{\alpha} \operatorname{sgn}(s), \qquad k > 0,\ 0 < \alpha < 1.$$

    `sgn` is the `switching` field.

    **Gradients:** with `Sign()` the power is [`jaxatt.numerics.sig_pow`][]: the slope in `s`
    at `s = 0` is capped at $k\alpha\sqrt{\varepsilon}^{\,\alpha-1}$ (the true one is
    infinite); the derivative in $\alpha$ is $-k\,\mathrm{sig}^\alpha(s)\ln|s|$, 0 at `s = 0`.

    !!! cite
        W. Gao, J. C. Hung, "Variable structure control of nonlinear systems: a new approach",
        IEEE Trans. Industrial Electronics 40(1):45-55, 1993 (the power-rate reaching law).
    """

    k: Float[Array, "..."]
    alpha: Float[Array, "..."]
    switching: AbstractSwitching

    def __init__(
        self,
        k: RealScalarLike | Float[ArrayLike, "..."],
        alpha: RealScalarLike | Float[ArrayLike, "..."],
        switching: AbstractSwitching = Sign(),
    ):
        r"""**Arguments:**
        - `k`: gain $k > 0$; a scalar or per-axis array.
        - `alpha`: exponent $\alpha \in (0, 1)$; scalar or per axis.
        - `switching`: the function used for $\operatorname{sgn}$; default `Sign()`.
        """
        self.k = check_positive("Power", "k", k)
        self.alpha = check_in_open_interval("Power", "alpha", alpha, 0.0, 1.0)
        self.switching = switching

    def rate(self, s: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        s = as_state(s)
        k = as_param("Power", "k", self.k, s)
        alpha = as_param("Power", "alpha", self.alpha, s)
        return -k * self.switching.signed_power(s, alpha)

    def convergence_time(self, s0: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Exact reaching time (requires `switching=Sign()`):

        $$T(s_0) = \frac{|s_0|^{1-\alpha}}{k(1-\alpha)}.$$

        Integrate $\frac{d}{dt}|s|^{1-\alpha} = -k(1-\alpha)$. **Gradient** in `s0` at
        `s0 = 0` is 0 (the true one is infinite); in the parameters it is finite everywhere.
        """
        require_sign_switching(self, "convergence_time")
        s0 = as_state(s0)
        k = as_param("Power", "k", self.k, s0)
        alpha = as_param("Power", "alpha", self.alpha, s0)
        return abs_pow(s0, 1 - alpha) / (k * (1 - alpha))
