r"""Keep-out sphere, approach corridors, the C$^1$ cubic blend and the product-form $h(P)$.

**Reconstruction (SPEC 001(c), findings 3 and 8; Wu et al.'s eqs. (25)-(26) are lost).**
With $P = (x, y, z)$ in the target body frame and $r^2 = y^2 + z^2$, the forbidden body is
the sphere of radius $a_3$ with the approach corridor drilled along $+x$, its mouth joined to
the sphere by a cubic blend on $[a_1, a_2]$:

$$h(P) = O(x, r^2)\,C(x, r^2), \quad
O = \begin{cases} r^2 + x^2 - a_3^2 & x \le a_1 \\ r^2 + p(x) & a_1 \le x \le a_2\end{cases},
\quad C = r^2 - F(x) \qquad (x \le a_2),$$

$$h(P) = \bar C^2 + \beta\,(x - a_2)^2, \quad \bar C = r^2 - F(a_2) - F'(a_2)(x - a_2)
\qquad (x > a_2).$$

$O < 0$ inside the outer surface (sphere, then blend), $C < 0$ inside the corridor; the
forbidden set $\{h \le 0\}$ is "inside the outer surface and outside the corridor". The cubic
satisfies $p(a_1) = a_1^2 - a_3^2$, $p'(a_1) = 2a_1$ (the sphere) and $p(a_2) = -F(a_2)$,
$p'(a_2) = -F'(a_2)$ (the corridor), so $O$ is C$^1$ and $O = C$ at $x = a_2$. What happens
beyond $a_2$ is not recoverable from the paper; the branch above is our choice: it is C$^1$
at $x = a_2$ (value $C^2$, gradient $2C\nabla C$ on both sides, because $O = C$ and
$O' = C'$ there) and positive for $x > a_2$, so a chaser on the docking axis beyond the
mouth is safe. $\beta$ [m$^2$] defaults to $a_3^2$. The corridor profile is odd in $x$
($F < 0$ for $x < 0$), so the corridor exists only in front of the target. $h$ is in m$^4$.
"""

import math
from fractions import Fraction

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike, Vector3Like
from .._validation import check_instance, is_real_scalar
from ..numerics import clip, maximum, minimum


def _real(where: str, name: str, value) -> float:
    """A real number as a float: `True` read as 1 m and a (3,) array failed in `float()`."""
    if not is_real_scalar(value):
        raise ValueError(f"{where}: `{name}` must be a real number, got {value!r}.")
    return float(value)


def _positive(where: str, name: str, value) -> float:
    value = _real(where, name, value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{where}: `{name}` must be positive and finite, got {name}={value}.")
    return value


def _half_angle(where: str, value) -> float:
    value = _real(where, "half_angle", value)
    if not (math.isfinite(value) and 0.0 < value < math.pi / 2):
        raise ValueError(
            f"{where}: `half_angle` must lie in (0, pi/2) rad, got half_angle={value}."
        )
    return value


class KeepOutSphere(eqx.Module):
    r"""The sphere $|P| = a_3$ about the target: factor $r^2 + x^2 - a_3^2$ (< 0 inside).

    **Arguments:** `radius` $a_3 > 0$ [m].
    """

    radius: float = eqx.field(static=True)

    def __init__(self, radius: RealScalarLike):
        self.radius = _positive("KeepOutSphere", "radius", radius)

    def factor(
        self, x: Float[ArrayLike, "..."], r2: Float[ArrayLike, "..."]
    ) -> Float[ArrayLike, "..."]:
        """$r^2 + x^2 - a_3^2$ [m$^2$]."""
        return r2 + x * x - self.radius**2


class ConeCorridor(eqx.Module):
    r"""A cone of half angle $\theta$ about $+x$, apex at the target:
    $F(x) = \tan^2\theta\,x|x|$ [m$^2$] (odd, so $F < 0$ behind the target), $F'(x) =
    2\tan^2\theta|x|$. Works on NumPy and JAX values alike.

    **Arguments:** `half_angle` $\theta \in (0, \pi/2)$ [rad].
    """

    half_angle: float = eqx.field(static=True)

    def __init__(self, half_angle: RealScalarLike):
        self.half_angle = _half_angle("ConeCorridor", half_angle)

    def profile(self, x: Float[ArrayLike, "..."]) -> Float[ArrayLike, "..."]:
        return math.tan(self.half_angle) ** 2 * x * abs(x)

    def slope(self, x: Float[ArrayLike, "..."]) -> Float[ArrayLike, "..."]:
        return 2.0 * math.tan(self.half_angle) ** 2 * abs(x)


class CissoidCorridor(eqx.Module):
    r"""The "ellipse cissoid" corridor $F(x) = \tan^2\theta\,x^3/(2a - x)$ for $x < 2a$ (its
    asymptote), $F'(x) = \tan^2\theta\,x^2(6a - 2x)/(2a - x)^2$. At small $x$ it is the cone
    scaled by $x/(2a)$; at $x = a$ it matches the cone exactly.

    **Arguments:** `half_angle` $\theta \in (0, \pi/2)$ [rad], `a` $> 0$ [m].
    """

    half_angle: float = eqx.field(static=True)
    a: float = eqx.field(static=True)

    def __init__(self, half_angle: RealScalarLike, a: RealScalarLike):
        self.half_angle = _half_angle("CissoidCorridor", half_angle)
        self.a = _positive("CissoidCorridor", "a", a)

    def profile(self, x: Float[ArrayLike, "..."]) -> Float[ArrayLike, "..."]:
        return math.tan(self.half_angle) ** 2 * x**3 / (2.0 * self.a - x)

    def slope(self, x: Float[ArrayLike, "..."]) -> Float[ArrayLike, "..."]:
        return (
            math.tan(self.half_angle) ** 2
            * x**2
            * (6.0 * self.a - 2.0 * x)
            / (2.0 * self.a - x) ** 2
        )


Corridor = ConeCorridor | CissoidCorridor


def _check_below_asymptote(where: str, corridor: Corridor, a2: float) -> None:
    """The blend ends at $a_2$, where a cissoid corridor must still be defined ($a_2 < 2a$):
    beyond its asymptote $F$ changes sign and the blend joined a corridor that is not there."""
    if isinstance(corridor, CissoidCorridor) and not a2 < 2 * corridor.a:
        raise ValueError(f"{where}: the cissoid's asymptote 2a={2 * corridor.a} <= a2={a2}.")


class CubicBlend(eqx.Module):
    r"""The C$^1$ cubic $p$ on $[a_1, a_2]$ joining the sphere to the corridor.

    End conditions: $p(a_1) = a_1^2 - a_3^2$, $p'(a_1) = 2a_1$, $p(a_2) = -F(a_2)$,
    $p'(a_2) = -F'(a_2)$. Solved in float64 in the local variable $t = (x - a_1)/(a_2 - a_1)$
    (cubic Hermite, $p = \sum_k d_k t^k$) and evaluated there by Horner's rule: the monomial
    form $c_4 + c_1x + c_2x^2 + c_3x^3$ cancels catastrophically near $x \approx 49$ (terms of
    $10^{10}$ summing to $10^2$). `coefficients` gives $[c_1, c_2, c_3, c_4]$, expanded
    exactly (rational arithmetic) from the float64 local coefficients. For Wu 2018's cone
    ($\theta = 2°$, $a_1 = 48.9$, $a_2 = 49$, $a_3 = 50$ m) they are $[-1.451673 \cdot 10^9,
    2.965676 \cdot 10^7, -2.019561 \cdot 10^5, 2.368602 \cdot 10^{10}]$ to 7 digits, equal to
    the exact rational solution of the end conditions to 4.4e-14 (SPEC's 7-digit $c_2$ and
    $c_4$, ...677e7 and ...603e10, are one unit off in the last digit).

    **Arguments:** `sphere`, `corridor`, `a1`, `a2` [m] with $0 < a_1 < a_2$ (and
    $a_2 < 2a$ for a cissoid corridor).
    """

    a1: float = eqx.field(static=True)
    a2: float = eqx.field(static=True)
    local: tuple[float, float, float, float] = eqx.field(static=True)

    def __init__(
        self, sphere: KeepOutSphere, corridor: Corridor, a1: RealScalarLike, a2: RealScalarLike
    ):
        where = "CubicBlend"
        check_instance(where, "sphere", sphere, KeepOutSphere, "a KeepOutSphere")
        check_instance(
            where, "corridor", corridor, (ConeCorridor, CissoidCorridor), "a cone or cissoid"
        )
        a1 = _positive(where, "a1", a1)
        a2 = _positive(where, "a2", a2)
        if not a2 > a1:
            raise ValueError(f"CubicBlend: need a2 > a1 > 0, got a1={a1}, a2={a2}.")
        _check_below_asymptote(where, corridor, a2)
        length = a2 - a1
        y0, m0 = a1 * a1 - sphere.radius**2, 2.0 * a1 * length
        y1, m1 = -float(corridor.profile(a2)), -float(corridor.slope(a2)) * length
        self.a1, self.a2 = a1, a2
        self.local = (y0, m0, -3 * y0 - 2 * m0 + 3 * y1 - m1, 2 * y0 + m0 - 2 * y1 + m1)

    def __call__(self, x: Float[ArrayLike, "..."]) -> Float[ArrayLike, "..."]:
        """$p(x)$ [m$^2$] (NumPy or JAX)."""
        t = (x - self.a1) / (self.a2 - self.a1)
        d0, d1, d2, d3 = self.local
        return d0 + t * (d1 + t * (d2 + t * d3))

    @property
    def coefficients(self) -> tuple[float, float, float, float]:
        """$[c_1, c_2, c_3, c_4]$ of $p(x) = c_4 + c_1x + c_2x^2 + c_3x^3$ (the paper's order)."""
        a1, length = Fraction(self.a1), Fraction(self.a2) - Fraction(self.a1)
        mono = [Fraction(0)] * 4
        for k, d in enumerate(self.local):
            scale = Fraction(d) / length**k
            for j in range(k + 1):
                mono[j] += scale * math.comb(k, j) * (-a1) ** (k - j)
        return float(mono[1]), float(mono[2]), float(mono[3]), float(mono[0])


class CollisionAvoidance(eqx.Module):
    r"""The product-form collision-avoidance function $h(P)$ of the module docstring.

    **Arguments:** `sphere` ([`KeepOutSphere`][], radius $a_3$), `corridor`
    ([`ConeCorridor`][] or [`CissoidCorridor`][]), `a1`, `a2` [m] with $a_3 > a_2 > a_1 > 0$,
    `beta` [m$^2$] (beyond-the-mouth weight, default $a_3^2$).
    Raises `ValueError` for broken geometry (ordering, angle, a cissoid asymptote inside the
    blend).
    """

    sphere: KeepOutSphere
    corridor: Corridor
    blend: CubicBlend
    beta: float = eqx.field(static=True)

    def __init__(
        self,
        sphere: KeepOutSphere,
        corridor: Corridor,
        a1: RealScalarLike,
        a2: RealScalarLike,
        beta: RealScalarLike | None = None,
    ):
        where = "CollisionAvoidance"
        if not isinstance(sphere, KeepOutSphere):
            raise ValueError(f"{where}: `sphere` must be a KeepOutSphere, got {sphere!r}.")
        if not isinstance(corridor, (ConeCorridor, CissoidCorridor)):
            raise ValueError(f"{where}: `corridor` must be a cone or cissoid, got {corridor!r}.")
        a1, a2 = _real(where, "a1", a1), _real(where, "a2", a2)
        if not (sphere.radius > a2 > a1 > 0):
            raise ValueError(
                f"{where}: the geometry needs a3 > a2 > a1 > 0, got a1={a1}, a2={a2}, "
                f"a3={sphere.radius}."
            )
        _check_below_asymptote(where, corridor, a2)
        self.sphere, self.corridor = sphere, corridor
        self.blend = CubicBlend(sphere, corridor, a1, a2)
        self.beta = sphere.radius**2 if beta is None else _positive(where, "beta", beta)

    @property
    def a1(self) -> float:
        return self.blend.a1

    @property
    def a2(self) -> float:
        return self.blend.a2

    def factors(self, position: Float[ArrayLike, "3"]) -> tuple[Float[Array, ""], Float[Array, ""]]:
        r"""The outer and corridor factors $(O, C)$ [m$^2$] at one position; beyond $x = a_2$
        both are continued by $\bar C$, so $h = O\,C + \beta\max(0, x - a_2)^2$ everywhere."""
        p = jnp.asarray(position)
        if p.shape != (3,):
            # Indexing clamps in JAX: a (2,) position read its y as z, a (4,) one dropped an
            # entry and a (3, 3) batch gave three rows of plausible values.
            raise ValueError(
                "CollisionAvoidance: `position` must have shape (3,) (one position; vmap for "
                f"batches), got shape {p.shape}."
            )
        x, r2 = p[0], p[1] ** 2 + p[2] ** 2
        a1, a2 = self.a1, self.a2
        outer = jnp.where(x <= a1, self.sphere.factor(x, r2), r2 + self.blend(clip(x, a1, a2)))
        inner = r2 - self.corridor.profile(minimum(x, a2))
        beyond = r2 - float(self.corridor.profile(a2)) - float(self.corridor.slope(a2)) * (x - a2)
        return jnp.where(x <= a2, outer, beyond), jnp.where(x <= a2, inner, beyond)

    def __call__(self, position: Float[ArrayLike, "3"]) -> Float[Array, ""]:
        """$h(P)$ [m$^4$] at one position (vmap for batches); $h > 0$ is safe."""
        return self.value_and_factors(position)[0]

    def value_and_factors(
        self, position: Float[ArrayLike, "3"]
    ) -> tuple[Float[Array, ""], Float[Array, ""], Float[Array, ""]]:
        r"""$(h, O, C)$ at one position, the factors evaluated once (for callers that need
        both, such as a normaliser of $h$)."""
        outer, inner = self.factors(position)
        past = maximum(jnp.asarray(position)[0] - self.a2, 0.0)
        return outer * inner + self.beta * past**2, outer, inner

    def gradient(self, position: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
        r"""$\nabla h$ [m$^3$] by autodiff."""
        return jax.grad(self.__call__)(jnp.asarray(position, dtype=float))

    def inverse_gradient(self, position: Float[ArrayLike, "3"]) -> Float[Array, "3"]:
        r"""$\nabla(1/h) = -\nabla h/h^2$ [m$^{-5}$] (the avoidance term's direction)."""
        h = self(position)
        return -self.gradient(position) / h**2

    def check_safe(self, where: str, name: str, position: Vector3Like) -> None:
        """Raise `ValueError` naming `name` when $h(P) \\le 0$ (concrete positions)."""
        import numpy as np

        value = float(self(np.asarray(position, dtype=float)))
        if not value > 0:
            raise ValueError(
                f"{where}: `{name}` = {np.asarray(position).tolist()} is outside the safe set "
                f"(h = {value:.6g} <= 0)."
            )
