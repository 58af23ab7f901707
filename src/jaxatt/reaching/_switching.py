r"""Switching functions: where a reaching law writes $\operatorname{sgn}(s)$.

A reaching law takes its switching function as an option object (STYLE rule 3):
`Sign()` is the discontinuous law of the papers; `Saturation(width)` and `Tanh(width)` give
its boundary-layer (smooth) variant. Which class is used is structure; `width` is a traced
array, so it can be tuned or vmapped.
"""

import abc

import equinox as eqx
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check_positive
from ..numerics import abs_pow, sat, sig_pow, sign, smooth_sign
from ._arrays import as_param


class AbstractSwitching(eqx.Module):
    r"""A switching function $\varphi(s) \approx \operatorname{sgn}(s)$, elementwise.

    Concrete switchings provide the function itself and the signed power
    $|s|^a \varphi(s)$ that replaces $\mathrm{sig}^a(s) = |s|^a \operatorname{sgn}(s)$ in a
    power reaching law.
    """

    @abc.abstractmethod
    def __call__(self, s: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        r"""$\varphi(s)$, elementwise; same shape and dtype as `s`."""

    @abc.abstractmethod
    def signed_power(
        self, s: Float[Array, "*shape"], a: Float[Array, "*shape"]
    ) -> Float[Array, "*shape"]:
        r"""$|s|^a \varphi(s)$, elementwise; `a` has the shape of `s`, `a >= 0`."""


class Sign(AbstractSwitching):
    r"""The discontinuous sign, $\operatorname{sgn}(0) = 0$ (SPEC's convention).

    `signed_power(s, a)` is [`jaxatt.numerics.sig_pow`][]: **gradient** in `s` is
    $a|s|^{a-1}$, capped at $a\sqrt{\varepsilon}^{\,a-1}$ near `s = 0` when `a < 1` (large but
    finite; the true slope is infinite); in `a` it is $\mathrm{sig}^a(s)\ln|s|$, 0 at `s = 0`.
    `__call__` has derivative 0 everywhere, so a gain that only multiplies `sgn(s)` gets no
    gradient signal through this switching; tune such gains with [`Saturation`][] or
    [`Tanh`][].

    This is the only switching for which the laws reach `s = 0` in finite time, hence the only
    one accepted by `convergence_time`.
    """

    def __call__(self, s: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        return sign(s)

    def signed_power(
        self, s: Float[Array, "*shape"], a: Float[Array, "*shape"]
    ) -> Float[Array, "*shape"]:
        return sig_pow(s, a)


class Saturation(AbstractSwitching):
    r"""Boundary-layer saturation $\mathrm{sat}(s/\phi) = \min(1, \max(-1, s/\phi))$.

    Equal to $\operatorname{sgn}(s)$ for $|s| \ge \phi$ and linear inside the layer, so the
    closed loop does not chatter; inside the layer a law no longer reaches `s = 0` in finite
    time (it converges asymptotically). `signed_power(s, a)` is $|s|^a\,\mathrm{sat}(s/\phi)$.

    **Gradient:** $1/\phi$ inside the layer and 0 outside; the signed power has slope 0 at
    `s = 0` (its true value: $|s|^{a+1}/\phi$ is flat there).
    """

    width: Float[Array, "..."]

    def __init__(self, width: RealScalarLike | Float[ArrayLike, "..."]):
        r"""**Arguments:**
        - `width`: boundary-layer half-width $\phi > 0$, in the units of `s`; a scalar or an
          array broadcasting against `s` (per axis).
        """
        self.width = check_positive("Saturation", "width", width)

    def __call__(self, s: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        return sat(s, as_param("Saturation", "width", self.width, s))

    def signed_power(
        self, s: Float[Array, "*shape"], a: Float[Array, "*shape"]
    ) -> Float[Array, "*shape"]:
        return abs_pow(s, a) * self(s)


class Tanh(AbstractSwitching):
    r"""Smooth sign $\tanh(s/\phi)$: infinitely differentiable, slope $1/\phi$ at 0.

    Tends to $\operatorname{sgn}(s)$ as $\phi \to 0$, with
    $|\tanh(s/\phi) - \operatorname{sgn}(s)| < 2e^{-2|s|/\phi}$. `signed_power(s, a)` is
    $|s|^a \tanh(s/\phi)$; it has slope 0 at `s = 0`. As for [`Saturation`][], a law with this
    switching converges to `s = 0` only asymptotically.
    """

    width: Float[Array, "..."]

    def __init__(self, width: RealScalarLike | Float[ArrayLike, "..."]):
        r"""**Arguments:**
        - `width`: $\phi > 0$, in the units of `s`; a scalar or an array broadcasting against
          `s` (per axis).
        """
        self.width = check_positive("Tanh", "width", width)

    def __call__(self, s: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        return smooth_sign(s, as_param("Tanh", "width", self.width, s))

    def signed_power(
        self, s: Float[Array, "*shape"], a: Float[Array, "*shape"]
    ) -> Float[Array, "*shape"]:
        return abs_pow(s, a) * self(s)
