r"""Continuous robust terms added to a sliding-mode law to dominate bounded disturbances."""

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import Vec3
from .._validation import check_gain_shape, check_positive
from ..numerics import safe_norm


class AbstractRobustTerm(eqx.Module):
    """A term $\\nu(s)$ subtracted from the reaching dynamics, $\\dot s = r(s) - \\nu(s) + D$."""

    @abc.abstractmethod
    def __call__(self, s: Vec3) -> Vec3:
        """$\\nu(s)$."""


class NormRobustTerm(AbstractRobustTerm):
    r"""$\nu(s) = \dfrac{\sigma^2 s}{\sigma\|s\| + \epsilon}$ (vector norm), Chen 2022 eq. (41).

    For $\|D\| \le \mu \le \sigma$ it gives $s^T(D - \nu) \le \epsilon$ with $V = s^T s$, so
    $s$ reaches a neighbourhood of 0 whose size scales with $\epsilon$ (SPEC 000.3, E10: the
    paper's per-axis proof needs the per-axis form, [`AxisRobustTerm`][]).

    **Arguments:**
    - `sigma`: $\sigma > 0$, an upper bound of the lumped disturbance norm [rad/s^2].
    - `eps`: $\epsilon > 0$, the boundary that keeps the term continuous [rad/s^2 * rad/s].
    """

    sigma: Float[Array, ""]
    eps: Float[Array, ""]

    def __init__(self, sigma: ArrayLike, eps: ArrayLike):
        where = "NormRobustTerm"
        self.sigma = check_gain_shape(where, "sigma", check_positive(where, "sigma", sigma), ((),))
        self.eps = check_gain_shape(where, "eps", check_positive(where, "eps", eps), ((),))

    def __call__(self, s: Vec3) -> Vec3:
        return self.sigma**2 * s / (self.sigma * safe_norm(s) + self.eps)


class AxisRobustTerm(AbstractRobustTerm):
    r"""$\nu_i(s) = \dfrac{\sigma^2 s_i}{\sigma|s_i| + \epsilon}$ per axis, the form Chen 2022's
    proof (eq. 44) uses with $V = s_i^2$.

    **Arguments:** as [`NormRobustTerm`][].
    """

    sigma: Float[Array, "*k"]
    eps: Float[Array, "*k"]

    def __init__(self, sigma: ArrayLike, eps: ArrayLike):
        where = "AxisRobustTerm"
        self.sigma = check_gain_shape(where, "sigma", check_positive(where, "sigma", sigma))
        self.eps = check_gain_shape(where, "eps", check_positive(where, "eps", eps))

    def __call__(self, s: Vec3) -> Vec3:
        return self.sigma**2 * s / (self.sigma * jnp.abs(s) + self.eps)
