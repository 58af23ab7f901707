r"""Two-phase power reaching law of Chen, Zhu and Tao (2022)."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_greater_than, check_in_open_interval, check_positive
from ..numerics import abs_pow
from ._arrays import as_param, as_state
from ._base import AbstractFiniteTimeReachingLaw, require_sign_switching
from ._switching import AbstractSwitching, Sign


class TwoPhasePower(AbstractFiniteTimeReachingLaw):
    r"""Two-phase power reaching law, elementwise (Chen et al. 2022 eqs. (15)-(16)):

    $$\dot s = -\rho s - \eta |s|^{a(s)}\operatorname{sgn}(s), \qquad
    a(s) = \begin{cases} \beta = p_1/q_1 > 1, & |s| \ge 1,\\
    \alpha = q_2/p_2 \in (0, 1), & |s| < 1, \end{cases}$$

    with $\rho, \eta > 0$. Far from the surface the $|s|^\beta$ term gives a fixed-time
    (initial-condition independent) bound, eq. (23); near it $|s|^\alpha$ gives finite time.
    `sgn` is the `switching` field. The law is continuous at $|s| = 1$ (both powers equal 1)
    but its slope jumps there from $-\rho-\eta\beta$ to $-\rho-\eta\alpha$.

    **Gradients:** in `s`, as [`Power`][] at `s = 0` (capped, finite) and one-sided at
    $|s| = 1$ (the $|s| \ge 1$ branch); in $\alpha$/$\beta$ they are
    $-\eta\,\mathrm{sig}^{a}(s)\ln|s|$ on their branch, hence 0 at `s = 0` and at $|s| = 1$.

    !!! cite
        Chen Q., Zhu J., Tao M., "Two-phase power reaching law based spacecraft attitude
        control", Control and Decision 37(5):1145-1152, 2022, DOI 10.13195/j.kzyjc.2020.1304,
        eqs. (15)-(23).

    !!! example
        ```python
        law = TwoPhasePower(rho=1.2, eta=1.2, beta=odd_ratio(31, 11), alpha=odd_ratio(5, 9))
        law.convergence_time(jnp.array([4.0, 2.75, 1.0895]))  # [1.5819, 1.5497, 1.3340]
        law.convergence_time_bound()  # 1.6173, eq. (23)
        ```
    """

    rho: Float[Array, "..."]
    eta: Float[Array, "..."]
    beta: Float[Array, "..."]
    alpha: Float[Array, "..."]
    switching: AbstractSwitching

    def __init__(
        self,
        rho: RealScalarLike | Float[ArrayLike, "..."],
        eta: RealScalarLike | Float[ArrayLike, "..."],
        beta: RealScalarLike | Float[ArrayLike, "..."],
        alpha: RealScalarLike | Float[ArrayLike, "..."],
        switching: AbstractSwitching = Sign(),
    ):
        r"""**Arguments:**
        - `rho`: linear gain $\rho > 0$ [1/time]; a scalar or per-axis array.
        - `eta`: power gain $\eta > 0$; scalar or per axis.
        - `beta`: exponent for $|s| \ge 1$, $\beta = p_1/q_1 > 1$ (the paper uses 31/11).
        - `alpha`: exponent for $|s| < 1$, $\alpha = q_2/p_2 \in (0, 1)$ (the paper: 5/9).
        - `switching`: the function used for $\operatorname{sgn}$; default `Sign()`.

        The paper asks for ratios of odd integers; any real value in range is accepted (see
        [`odd_ratio`][]).
        """
        self.rho = check_positive("TwoPhasePower", "rho", rho)
        self.eta = check_positive("TwoPhasePower", "eta", eta)
        self.beta = check_greater_than("TwoPhasePower", "beta", beta, 1.0)
        self.alpha = check_in_open_interval("TwoPhasePower", "alpha", alpha, 0.0, 1.0)
        self.switching = switching

    def _params(self, s: Array) -> tuple[Array, Array, Array, Array]:
        return (
            as_param("TwoPhasePower", "rho", self.rho, s),
            as_param("TwoPhasePower", "eta", self.eta, s),
            as_param("TwoPhasePower", "beta", self.beta, s),
            as_param("TwoPhasePower", "alpha", self.alpha, s),
        )

    def rate(self, s: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        s = as_state(s)
        rho, eta, beta, alpha = self._params(s)
        exponent = jnp.where(jnp.abs(s) >= 1, beta, alpha)  # eq. (16)
        return -rho * s - eta * self.switching.signed_power(s, exponent)

    def time_to_unit(self, s0: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Time for $|s|$ to fall from $|s_0| \ge 1$ to 1, eq. (20); 0 when $|s_0| < 1$:

        $$t_2 = \frac{1}{\rho(\beta-1)}
        \ln\frac{1 + \rho/\eta}{1 + (\rho/\eta)|s_0|^{1-\beta}}.$$

        Exact (requires `switching=Sign()`). **Gradients** are finite; at $|s_0| = 1$ the
        derivative in `s0` is the one-sided value $1/(\rho+\eta)$ from the $|s_0| \ge 1$ side.
        """
        require_sign_switching(self, "time_to_unit")
        s0 = as_state(s0)
        rho, eta, beta, _ = self._params(s0)
        x = jnp.abs(s0)
        outer = x >= 1
        x_outer = jnp.where(outer, x, 1)  # double where: keeps x**(1-beta) at x=0 out of grads
        ratio = rho / eta
        t2 = (jnp.log1p(ratio) - jnp.log1p(ratio * abs_pow(x_outer, 1 - beta))) / (rho * (beta - 1))
        return jnp.where(outer, t2, 0)

    def convergence_time(self, s0: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        r"""Exact reaching time, Chen et al. (2022) eqs. (18) and (22) (`switching=Sign()`):

        $$T(s_0) = \begin{cases}
        \dfrac{1}{\rho(1-\alpha)}\ln\Big(1 + \dfrac{\rho}{\eta}|s_0|^{1-\alpha}\Big),
        & |s_0| < 1 \quad (18),\\[2ex]
        \dfrac{1}{\rho}\ln\Big(1+\dfrac{\rho}{\eta}\Big)
        \Big(\dfrac{1}{\beta-1} + \dfrac{1}{1-\alpha}\Big)
        - \dfrac{1}{\rho(\beta-1)}\ln\Big(1 + \dfrac{\rho}{\eta}|s_0|^{1-\beta}\Big),
        & |s_0| \ge 1 \quad (22),
        \end{cases}$$

        where (22) = eq. (20) (time to $|s| = 1$, [`time_to_unit`][]) + eq. (21) (from 1 to 0).
        With $y = |s|^{1-a}$ each phase reads $\dot y = -(1-a)(\rho y + \eta)$, which is how
        these follow. $T$ is continuous at $|s_0| = 1$ and increases to the bound (23).

        **Gradients** are finite everywhere (0 in `s0` at `s0 = 0`, where the true one is
        infinite).
        """
        require_sign_switching(self, "convergence_time")
        s0 = as_state(s0)
        rho, eta, beta, alpha = self._params(s0)
        x = jnp.abs(s0)
        inner = x < 1
        x_inner = jnp.where(inner, x, 0)
        ratio = rho / eta
        t1 = jnp.log1p(ratio * abs_pow(x_inner, 1 - alpha)) / (rho * (1 - alpha))  # (18)
        t_unit_to_zero = jnp.log1p(ratio) / (rho * (1 - alpha))  # (21)
        return jnp.where(inner, t1, self.time_to_unit(s0) + t_unit_to_zero)

    def convergence_time_bound(self) -> Float[Array, "..."]:
        r"""Fixed-time bound, Chen et al. (2022) eq. (23):

        $$\bar t_3 = \frac{1}{\rho}\ln\Big(1 + \frac{\rho}{\eta}\Big)
        \Big(\frac{1}{\beta-1} + \frac{1}{1-\alpha}\Big) = \sup_{s_0} T(s_0).$$

        It is the exact supremum of [`convergence_time`][] over $s_0$ (approached as
        $|s_0| \to \infty$, never attained). Requires `switching=Sign()`. Shape: the
        broadcast shape of the parameters.
        """
        require_sign_switching(self, "convergence_time_bound")
        rho, eta, beta, alpha = jnp.broadcast_arrays(self.rho, self.eta, self.beta, self.alpha)
        return jnp.log1p(rho / eta) / rho * (1 / (beta - 1) + 1 / (1 - alpha))
