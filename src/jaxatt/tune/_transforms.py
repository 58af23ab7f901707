r"""Maps between unconstrained optimization variables and valid gains.

Gradient-based tuning works on unconstrained reals $u$; each tuned gain is $g = f(u)$ with a
transform $f$ whose image is the gain's valid range (positive, greater than 1, inside an
interval), so every optimizer step gives a valid controller. `inverse` maps the template's
initial value to its $u$ and fails (before any compilation) if the value is outside the range.
"""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validation import check_positive_int, is_real_scalar


def _check_bound(where: str, name: str, value) -> float:
    """A bound as a finite Python float; an infinite bound would make the starting gain NaN
    (`inverse` takes the log of an infinite distance) and the range is open on that side
    anyway with `GreaterThan` or an unconstrained `Identity`."""
    if not is_real_scalar(value):
        raise ValueError(f"{where}: `{name}` must be a real number, got {value!r}.")
    bound = float(value)
    if not np.isfinite(bound):
        raise ValueError(
            f"{where}: `{name}` must be finite, got {name}={bound!r} (for a range open on that "
            "side use GreaterThan(low), or Identity() for no constraint)."
        )
    return bound


def _strictly_inside(value: Array, low: float, high: float) -> Array:
    """`value` clipped to the open range `(low, high)`: a saturated exponential or sigmoid
    rounds to the bound itself (`1 + exp(-40)` is 1.0 in float64, `sigmoid(40)` is 1.0), a
    gain its law may refuse or read as another law; the nearest representable value inside is
    kept instead (in `value`'s dtype; gradient 0 there, as the saturated map's nearly is)."""
    value = jnp.maximum(jnp.asarray(value), _inward(low, high, jnp.asarray(value).dtype))
    if np.isinf(high):  # an overflowed exponential stays inf: no gain, a failure to see
        return value
    return jnp.minimum(value, _inward(high, low, value.dtype))


def _inward(bound: float, toward: float, dtype) -> Array:
    """The representable number next to `bound` in the direction of `toward`; next to 0, the
    smallest normal number (XLA:CPU flushes subnormals to zero)."""
    if bound == 0:
        return jnp.asarray(np.copysign(np.finfo(dtype).tiny, toward), dtype)
    return jnp.nextafter(jnp.asarray(bound, dtype), jnp.asarray(toward, dtype))


class AbstractTransform(eqx.Module):
    """A bijection from the reals onto a gain's valid range."""

    @abc.abstractmethod
    def forward(self, u: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        """Unconstrained variable -> gain."""

    @abc.abstractmethod
    def inverse(self, value: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
        """Gain -> unconstrained variable (only for values inside the range)."""

    @abc.abstractmethod
    def contains(self, value: Float[ArrayLike, "*shape"]) -> bool:
        """Whether every element of a concrete `value` lies strictly inside the range."""

    @abc.abstractmethod
    def describe(self) -> str:
        """The range in words, for error messages."""


class Identity(AbstractTransform):
    """No constraint: $g = u$."""

    def forward(self, u):
        return u

    def inverse(self, value):
        return value

    def contains(self, value) -> bool:
        return bool(np.all(np.isfinite(value)))

    def describe(self) -> str:
        return "any finite value"


class GreaterThan(AbstractTransform):
    r"""$g = \ell + e^u$, the range $(\ell, \infty)$. `GreaterThan(0.0)` is the positive gains;
    `GreaterThan(1.0)` an exponent above 1 (e.g. $p_1/q_1$).

    The exponential makes optimizer steps relative: a step of 0.1 in $u$ changes $g - \ell$ by
    about 10 %, whatever the gain's scale."""

    low: float = eqx.field(static=True)

    def __init__(self, low: float | int = 0.0):
        self.low = _check_bound("GreaterThan", "low", low)

    def forward(self, u):
        return _strictly_inside(self.low + jnp.exp(u), self.low, np.inf)

    def inverse(self, value):
        return jnp.log(value - self.low)

    def contains(self, value) -> bool:
        value = np.asarray(value)
        return bool(np.all(np.isfinite(value) & (value > self.low)))

    def describe(self) -> str:
        return f"greater than {self.low}"


def Positive() -> GreaterThan:
    """Positive gains: `GreaterThan(0.0)`."""
    return GreaterThan(0.0)


class Interval(AbstractTransform):
    r"""$g = \ell + (h - \ell)\,\mathrm{sigmoid}(u)$, the open interval $(\ell, h)$, e.g. an
    exponent in (0, 1) such as $q_2/p_2$."""

    low: float = eqx.field(static=True)
    high: float = eqx.field(static=True)

    def __init__(self, low: float | int, high: float | int):
        low = _check_bound("Interval", "low", low)
        high = _check_bound("Interval", "high", high)
        if not high > low:
            raise ValueError(f"Interval: `high` must exceed `low`, got low={low}, high={high}.")
        self.low, self.high = low, high

    def forward(self, u):
        value = self.low + (self.high - self.low) * jax.nn.sigmoid(u)
        return _strictly_inside(value, self.low, self.high)

    def inverse(self, value):
        p = (value - self.low) / (self.high - self.low)
        return jnp.log(p) - jnp.log1p(-p)

    def contains(self, value) -> bool:
        value = np.asarray(value)
        return bool(np.all(np.isfinite(value) & (value > self.low) & (value < self.high)))

    def describe(self) -> str:
        return f"inside ({self.low}, {self.high})"


def nearest_odd_ratio(value: float | int, max_denominator: int = 99) -> tuple[int, int]:
    """The ratio p/q of positive odd integers (q <= `max_denominator`) closest to `value`.

    Papers state power-law exponents as ratios of odd integers (so that $x^{p/q}$ is real
    and odd for negative $x$). jaxatt evaluates $|x|^a \\mathrm{sign}(x)$, which needs no such
    restriction, so tuning relaxes the exponents to real values; this rounds a tuned exponent
    back to the paper's form for reporting or for hardware that needs it.
    """
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"nearest_odd_ratio: `value` must be positive, got value={value}.")
    # Below 1 no denominator was tried, and (1, 1) came back as if it were the nearest.
    max_denominator = check_positive_int("nearest_odd_ratio", "max_denominator", max_denominator)
    best = (1, 1)
    best_error = abs(value - 1.0)
    for q in range(1, max_denominator + 1, 2):
        p = max(1, int(round(value * q)))
        for candidate in (p - 1, p, p + 1):
            if candidate > 0 and candidate % 2 == 1:
                error = abs(value - candidate / q)
                if error < best_error - 1e-15:
                    best, best_error = (candidate, q), error
    return best
