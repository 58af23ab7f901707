r"""Global sliding surfaces: a decaying offset that puts the state on the surface at $t_0$.

For any vector surface $s = \dot e + h(e)$ ([`PDSurface`][], [`TerminalSurface`][]) the global
variant (SPEC 001(b) [R]) is

$$s_g(t) = \dot e + h(e) - s(t_0)\,f(t - t_0),\qquad f(0) = 1,\ f(\tau) \to 0,$$

so $s_g(t_0) = 0$ exactly: there is no reaching phase, and a reaching law that keeps $s = 0$
an invariant set holds $s_g \equiv 0$ from the start; the error then follows the surface's
dynamics driven by the vanishing input $s(t_0)f(t - t_0)$. The decay $f$ is an option object:
[`ExponentialDecay`][] (asymptotic) or [`PolynomialDecay`][] (reaches 0 at a finite time and
stays there, so the terminal surface's finite-time convergence is kept).
"""

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike, Scalar
from .._validation import check_positive_scalar
from ..numerics import clip
from ._vector import PDSurface, TerminalSurface


class AbstractDecay(eqx.Module):
    r"""A decay profile $f(\tau)$, $f(0) = 1$, $f \to 0$, with its derivative."""

    @abc.abstractmethod
    def __call__(self, tau: Float[ArrayLike, ""]) -> tuple[Scalar, Scalar]:
        r"""$(f(\tau), \dot f(\tau))$ for the elapsed time $\tau \ge 0$ [s]."""


class ExponentialDecay(AbstractDecay):
    r"""$f(\tau) = e^{-\tau/T}$, $\dot f = -f/T$. **Argument:** `time_constant` $T > 0$ [s]."""

    time_constant: Float[Array, ""]

    def __init__(self, time_constant: RealScalarLike):
        # One time constant (a scalar field): a (3, 1) one made the (3,) surface (3, 3).
        self.time_constant = check_positive_scalar(
            "ExponentialDecay", "time_constant", time_constant
        )

    def __call__(self, tau: Float[ArrayLike, ""]) -> tuple[Scalar, Scalar]:
        f = jnp.exp(-jnp.asarray(tau) / self.time_constant)
        return f, -f / self.time_constant


class PolynomialDecay(AbstractDecay):
    r"""$f(\tau) = (1 - \tau/T)^3$ for $\tau < T$ and 0 after: twice continuously
    differentiable, zero from $\tau = T$ on. $\dot f = -3(1 - \tau/T)^2/T$.

    **Argument:** `horizon` $T > 0$ [s].
    """

    horizon: Float[Array, ""]

    def __init__(self, horizon: RealScalarLike):
        self.horizon = check_positive_scalar("PolynomialDecay", "horizon", horizon)

    def __call__(self, tau: Float[ArrayLike, ""]) -> tuple[Scalar, Scalar]:
        remaining = clip(1 - jnp.asarray(tau) / self.horizon, 0.0, 1.0)
        return remaining**3, -3 * remaining**2 / self.horizon


class GlobalSurfaceState(eqx.Module):
    """The surface's value `s_initial` $= s(t_0)$ and the start time `t0` [s]."""

    s_initial: Float[Array, "3"]
    t0: Float[Array, ""]


class GlobalSurface(eqx.Module):
    r"""$s_g = s(e, \dot e) - s(t_0) f(t - t_0)$ for a vector surface $s$ (module docstring).

    **Arguments:**
    - `surface`: a [`PDSurface`][] or a [`TerminalSurface`][] (the global terminal surface of
      SPEC 001(b): $s = \dot e + a e + b\,\mathrm{sig}^{q/p}(e)$ is
      `TerminalSurface(a, b, q/p)`).
    - `decay`: an [`AbstractDecay`][], e.g. `ExponentialDecay(T)`.

    - `init(t0, e, e_dot)` stores $s(t_0)$, so $s_g(t_0) = 0$ exactly (the same floating-point
      value is subtracted from itself);
    - `__call__(state, t, e, e_dot)` is $s_g$;
    - `error_term_rate(state, t, e, e_dot)` is $\dot s_g - \ddot e
      = \dot h(e) - s(t_0)\dot f(t - t_0)$ (the surface's guarded $\dot h$, see
      [`TerminalSurface`][]).
    """

    surface: PDSurface | TerminalSurface
    decay: AbstractDecay

    def __init__(self, surface: PDSurface | TerminalSurface, decay: AbstractDecay):
        if not isinstance(surface, (PDSurface, TerminalSurface)):
            raise TypeError(
                "GlobalSurface: `surface` must be a PDSurface or a TerminalSurface, got "
                f"{type(surface).__name__}."
            )
        if not isinstance(decay, AbstractDecay):
            raise TypeError(
                "GlobalSurface: `decay` must be an AbstractDecay (ExponentialDecay, "
                f"PolynomialDecay), got {type(decay).__name__}."
            )
        self.surface = surface
        self.decay = decay

    def init(
        self, t0: RealScalarLike, e: Float[Array, "3"], e_dot: Float[Array, "3"]
    ) -> GlobalSurfaceState:
        s_initial = self.surface(e, e_dot)
        return GlobalSurfaceState(s_initial, jnp.asarray(t0, dtype=s_initial.dtype))

    def __call__(
        self,
        state: GlobalSurfaceState,
        t: RealScalarLike,
        e: Float[Array, "3"],
        e_dot: Float[Array, "3"],
    ) -> Float[Array, "3"]:
        f, _ = self.decay(t - state.t0)
        return self.surface(e, e_dot) - state.s_initial * f

    def error_term_rate(
        self,
        state: GlobalSurfaceState,
        t: RealScalarLike,
        e: Float[Array, "3"],
        e_dot: Float[Array, "3"],
    ) -> Float[Array, "3"]:
        _, f_dot = self.decay(t - state.t0)
        return self.surface.error_term_rate(e, e_dot) - state.s_initial * f_dot
