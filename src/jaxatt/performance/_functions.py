r"""The performance functions of Zhang et al. (2021): exponential (20), coth (19) and the
finite-time function (36) in closed form."""

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_in_open_interval, check_positive, is_traced
from ..numerics import maximum
from ._base import AbstractPerformance


def _common_shape(where: str, **arrays: Array) -> tuple[Array, ...]:
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
    except ValueError:
        shapes = ", ".join(f"{k}{v.shape}" for k, v in arrays.items())
        raise ValueError(
            f"{where}: the parameters must broadcast together, got {shapes}."
        ) from None
    return tuple(jnp.broadcast_to(a, shape) for a in arrays.values())


def _split_infinity(t: RealScalarLike) -> tuple[Array, Array]:
    r"""`(t == +inf, t with +inf replaced by 0)`. The envelopes evaluate their closed forms at the
    finite copy and select the limit ($\rho_\infty$, $\dot\rho = 0$) at $t = \infty$: the closed
    forms' gradients in the parameters there are $\infty \cdot 0$, NaN (e.g. $-t e^{-\alpha t}$
    in the exponential's rate), where the limit's are those of $\rho_\infty$."""
    at_infinity = jnp.isposinf(t)
    return at_infinity, jnp.where(at_infinity, 0.0, t)


def _check_final_below_initial(where: str, initial: Array, final: Array) -> None:
    if is_traced(initial) or is_traced(final):
        return
    bad = ~(np.asarray(final) < np.asarray(initial))
    if np.any(bad):
        raise ValueError(
            f"{where}: the envelope must shrink, `final` (rho_inf) < `initial` (rho_0), got "
            f"initial={np.asarray(initial)} and final={np.asarray(final)}."
        )


class ExponentialPerformance(AbstractPerformance):
    r"""$\rho(t) = (\rho_0 - \rho_\infty)e^{-\alpha t} + \rho_\infty$ (Zhang et al. 2021, eq. 20).

    $\dot\rho = -\alpha(\rho_0 - \rho_\infty)e^{-\alpha t}$. A larger rate $\alpha$ shrinks the
    envelope faster, forcing faster convergence at the price of larger control when the error
    nears the envelope (the paper's "too large an $\alpha$ loses control").

    **Arguments** (arrays of one broadcast shape, one envelope each):
    - `initial`: $\rho_0 > \rho_\infty$;
    - `final`: $\rho_\infty > 0$;
    - `rate`: $\alpha > 0$ [1/s].
    """

    initial_value: Float[Array, "*k"]
    final_value: Float[Array, "*k"]
    rate: Float[Array, "*k"]

    def __init__(self, initial: ArrayLike, final: ArrayLike, rate: ArrayLike):
        where = "ExponentialPerformance"
        initial = check_positive(where, "initial", initial)
        final = check_positive(where, "final", final)
        rate = check_positive(where, "rate", rate)
        _check_final_below_initial(where, initial, final)
        self.initial_value, self.final_value, self.rate = _common_shape(
            where, initial=initial, final=final, rate=rate
        )

    @property
    def initial(self):
        return self.initial_value

    @property
    def final(self):
        return self.final_value

    def _decay(self, t: RealScalarLike) -> Float[Array, "*k"]:
        r"""$e^{-\alpha t}$, and 0 at $t = \infty$ (see `_split_infinity`)."""
        at_infinity, t = _split_infinity(t)
        return jnp.where(at_infinity, 0.0, jnp.exp(-self.rate * t))

    def value(self, t: RealScalarLike) -> Float[Array, "*k"]:
        return (self.initial_value - self.final_value) * self._decay(t) + self.final_value

    def derivative(self, t: RealScalarLike) -> Float[Array, "*k"]:
        return -self.rate * (self.initial_value - self.final_value) * self._decay(t)


class CothPerformance(AbstractPerformance):
    r"""$\rho(t) = \coth(l_1 t + l_2) - 1 + \rho_\infty$, Zhang et al. (2021) eq. (19).

    $\rho(0) = \coth l_2 - 1 + \rho_\infty$ and $\dot\rho = -l_1/\sinh^2(l_1 t + l_2)$; the
    decay is algebraic at first and exponential ($\approx 2e^{-2(l_1 t + l_2)}$) later.

    **Arguments:** `l1` $> 0$ [1/s], `l2` $> 0$, `final` $\rho_\infty > 0$ (broadcast together).
    """

    l1: Float[Array, "*k"]
    l2: Float[Array, "*k"]
    final_value: Float[Array, "*k"]

    def __init__(self, l1: ArrayLike, l2: ArrayLike, final: ArrayLike):
        where = "CothPerformance"
        self.l1, self.l2, self.final_value = _common_shape(
            where,
            l1=check_positive(where, "l1", l1),
            l2=check_positive(where, "l2", l2),
            final=check_positive(where, "final", final),
        )

    @property
    def initial(self):
        return self.value(0.0)

    @property
    def final(self):
        return self.final_value

    def value(self, t: RealScalarLike) -> Float[Array, "*k"]:
        at_infinity, t = _split_infinity(t)
        excess = jnp.where(at_infinity, 0.0, 1.0 / jnp.tanh(self.l1 * t + self.l2) - 1.0)
        return excess + self.final_value

    def derivative(self, t: RealScalarLike) -> Float[Array, "*k"]:
        r"""$\dot\rho = -l_1/\sinh^2 x = -4l_1e^{-2x}/(1 - e^{-2x})^2$, $x = l_1t + l_2 > 0$.

        The second form never overflows: $\sinh x$ does beyond $x \approx 710$, and the
        derivatives of $\sinh^2 x$ were then $0 \cdot \infty$, NaN (in $t$, $l_1$, $l_2$), where
        the true ones underflow to 0.
        """
        at_infinity, t = _split_infinity(t)
        minus_2x = -2 * (self.l1 * t + self.l2)
        return jnp.where(
            at_infinity, 0.0, -4 * self.l1 * jnp.exp(minus_2x) / jnp.expm1(minus_2x) ** 2
        )


class FiniteTimePerformance(AbstractPerformance):
    r"""The finite-time performance function of Zhang et al. (2021) eq. (36), in closed form.

    (36) is $\dot\rho = -q_0(\rho - \rho_\infty)^\alpha$ for $t \le T$ and $\dot\rho = 0$ after,
    with $q_0 = (\rho_0 - \rho_\infty)^{1-\alpha}/((1-\alpha)T)$. Integrated (SPEC 003.4 [V]):

    $$\rho(t) = \rho_\infty + (\rho_0 - \rho_\infty)\,(1 - t/T)^{1/(1-\alpha)}, \qquad
    \dot\rho(t) = -\frac{\rho_0 - \rho_\infty}{(1-\alpha)T}(1 - t/T)^{\alpha/(1-\alpha)}$$

    for $0 \le t \le T$, and $\rho = \rho_\infty$, $\dot\rho = 0$ for $t \ge T$. So $\rho$ reaches
    $\rho_\infty$ **exactly** at $T$ (not merely by $T$), is $C^1$ there, and $C^2$ for
    $\alpha > 1/2$. Any $\alpha \in (0, 1)$ works (the paper's Lemma 2 states $(0.5, 1)$, and
    its own $\alpha_4 = 0.5$ lies outside that; SPEC 003.4).

    The printed Section 4.3 functions lack $t$ and $\rho_0$ (erratum); the printed $q_i$ are
    inconsistent with $T = 300$ s, so $q_0$ is always computed from $\rho_0$, $\rho_\infty$, $T$
    and $\alpha$ ([`gain`][]).

    **Gradients** in $T$, $\alpha$, $\rho_0$, $\rho_\infty$ are finite for all $t$ (the power of
    $1 - t/T$ is taken through a guarded base, so the derivative in the exponent is 0, not
    NaN, once $t \ge T$).

    **Arguments** (broadcast together):
    - `initial`: $\rho_0 > \rho_\infty$; `final`: $\rho_\infty > 0$;
    - `horizon`: $T > 0$ [s], the time at which $\rho = \rho_\infty$;
    - `exponent`: $\alpha \in (0, 1)$.
    """

    initial_value: Float[Array, "*k"]
    final_value: Float[Array, "*k"]
    horizon: Float[Array, "*k"]
    exponent: Float[Array, "*k"]

    def __init__(
        self, initial: ArrayLike, final: ArrayLike, horizon: ArrayLike, exponent: ArrayLike
    ):
        where = "FiniteTimePerformance"
        initial = check_positive(where, "initial", initial)
        final = check_positive(where, "final", final)
        horizon = check_positive(where, "horizon", horizon)
        exponent = check_in_open_interval(where, "exponent", exponent, 0.0, 1.0)
        _check_final_below_initial(where, initial, final)
        self.initial_value, self.final_value, self.horizon, self.exponent = _common_shape(
            where, initial=initial, final=final, horizon=horizon, exponent=exponent
        )

    @property
    def initial(self):
        return self.initial_value

    @property
    def final(self):
        return self.final_value

    @property
    def gain(self) -> Float[Array, "*k"]:
        r"""$q_0 = (\rho_0 - \rho_\infty)^{1-\alpha}/((1-\alpha)T)$ of eq. (36)."""
        a = self.exponent
        return (self.initial_value - self.final_value) ** (1 - a) / ((1 - a) * self.horizon)

    def _remaining(self, t) -> tuple[Array, Array]:
        r"""$1 - t/T$ clipped at 0, and a copy that is 1 where it is 0 (a safe power base); 0 at
        $t = \infty$ with no gradient in $T$ (see `_split_infinity`)."""
        at_infinity, t = _split_infinity(t)
        x = jnp.where(at_infinity, 0.0, maximum(1.0 - t / self.horizon, 0.0))
        return x, jnp.where(x > 0, x, 1.0)

    def value(self, t: RealScalarLike) -> Float[Array, "*k"]:
        x, safe = self._remaining(t)
        shape = jnp.where(x > 0, safe ** (1.0 / (1.0 - self.exponent)), 0.0)
        return self.final_value + (self.initial_value - self.final_value) * shape

    def derivative(self, t: RealScalarLike) -> Float[Array, "*k"]:
        x, safe = self._remaining(t)
        a = self.exponent
        shape = jnp.where(x > 0, safe ** (a / (1.0 - a)), 0.0)
        return -(self.initial_value - self.final_value) / ((1.0 - a) * self.horizon) * shape
