r"""Modal analysis of a cantilever Euler-Bernoulli appendage attached to a rigid hub.

A uniform beam of bending stiffness $EI$ [N m^2], mass per length $\rho A$ [kg/m] and length
$l_1$ [m], clamped to the hub at distance $r_0$ [m] from the hub's rotation axis, bending in
the plane normal to that axis. Its free vibration $\rho A\,\ddot u + EI\,u'''' = 0$ with
$u(0) = u'(0) = 0$, $u''(l_1) = u'''(l_1) = 0$ has the mode shapes ($x = \beta_i y$)

$$\varphi_i(y) = \cosh x - \cos x - \sigma_i(\sinh x - \sin x),\qquad
\sigma_i = \frac{\cosh\beta_i l_1 + \cos\beta_i l_1}{\sinh\beta_i l_1 + \sin\beta_i l_1},$$

where $\beta_i l_1$ are the roots of $\cos(\beta l)\cosh(\beta l) = -1$ (1.8751, 4.6941,
7.8548, ...), and the natural frequencies $\omega_i = \beta_i^2\sqrt{EI/\rho A}$ [rad/s].

Shi & Song (2024) eq. (5) with the corrections of SPEC seed 002(b):

- mass normalisation $u_i = 1/\sqrt{\rho A\int_0^{l_1}\varphi_i^2\,dy}$ (so $\varepsilon = U n$
  with mass-normalised modal coordinates $n$);
- coupling $b_i = -u_i\,\rho A\int_0^{l_1}\varphi_i(y)\,(r_0 + y)\,dy$ [kg^(1/2) m];
- stiffness $K_s = \mathrm{diag}(u_i^2 EI\int\varphi_i''^2) = \mathrm{diag}(\omega_i^2)$ (the
  paper prints $u_i$, not $u_i^2$: [`BeamModes.literal_stiffness`][] keeps that reading);
- damping $C_s = \mathrm{diag}(2\xi_i\omega_i)$ (the printed form contains the state
  $\varepsilon_i(t)$ and a spurious 2 under the root).

The integrals use Gauss-Legendre quadrature (exact to rounding for these smooth shapes), so
everything is differentiable in the beam's parameters; the roots $\beta_i l_1$ are pure numbers,
found once on the host by Newton's method in float64.
"""

import functools

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._validation import (
    check_nonnegative,
    check_positive_int,
    check_positive_scalar,
    check_scalar,
)


CANTILEVER_ROOTS_REFERENCE = (1.875104068711961, 4.694091132974175, 7.854757438237613)
"""$\\beta_i l$ of the first three cantilever modes, to 16 digits (Blevins, Table 8-1)."""


@functools.cache
def cantilever_roots(n_modes: int) -> tuple[float, ...]:
    r"""The first `n_modes` roots $\beta_i l$ of $\cos x\cosh x + 1 = 0$ (host floats).

    Newton's method on $f(x) = \cos x + 1/\cosh x$ (the same roots, better scaled) from
    $x_0 = (2i - 1)\pi/2$, iterated to a relative step below 1e-16.
    """
    n_modes = check_positive_int("cantilever_roots", "n_modes", n_modes)
    roots = []
    for i in range(1, n_modes + 1):
        x = (2 * i - 1) * np.pi / 2
        for _ in range(100):
            f = np.cos(x) + 1 / np.cosh(x)
            df = -np.sin(x) - np.tanh(x) / np.cosh(x)
            step = f / df
            x -= step
            if abs(step) <= 1e-16 * x:
                break
        roots.append(float(x))
    return tuple(roots)


def _gauss_legendre(order: int, length: Array) -> tuple[Array, Array]:
    nodes, weights = np.polynomial.legendre.leggauss(order)
    y = 0.5 * length * (jnp.asarray(nodes, length.dtype) + 1)
    w = 0.5 * length * jnp.asarray(weights, length.dtype)
    return y, w


class CantileverBeam(eqx.Module):
    r"""A uniform cantilever Euler-Bernoulli beam on a rigid hub (see the module docstring).

    **Arguments** (all positive except `root_offset`, which may be 0):
    - `youngs_modulus`: $E$ [N/m^2].
    - `area_moment`: second moment of area $I$ [m^4].
    - `mass_per_length`: $\rho A$ [kg/m].
    - `length`: $l_1$ [m].
    - `root_offset`: $r_0 \ge 0$, distance of the clamped root from the hub axis [m].

    !!! example
        Shi & Song (2024): `CantileverBeam(7e10, 3e-9, 2.8e3 * 1.125e-2, 3.0, 0.65)`
        ($EI = 210$ N m^2, $\rho A = 31.5$ kg/m, beam mass 94.5 kg).
    """

    youngs_modulus: Float[Array, ""]
    area_moment: Float[Array, ""]
    mass_per_length: Float[Array, ""]
    length: Float[Array, ""]
    root_offset: Float[Array, ""]

    def __init__(
        self,
        youngs_modulus: float | Float[ArrayLike, ""],
        area_moment: float | Float[ArrayLike, ""],
        mass_per_length: float | Float[ArrayLike, ""],
        length: float | Float[ArrayLike, ""],
        root_offset: float | Float[ArrayLike, ""] = 0.0,
    ):
        where = "CantileverBeam"
        self.youngs_modulus = check_positive_scalar(where, "youngs_modulus", youngs_modulus)
        self.area_moment = check_positive_scalar(where, "area_moment", area_moment)
        self.mass_per_length = check_positive_scalar(where, "mass_per_length", mass_per_length)
        self.length = check_positive_scalar(where, "length", length)
        self.root_offset = check_nonnegative(
            where, "root_offset", check_scalar(where, "root_offset", root_offset)
        )

    @property
    def bending_stiffness(self) -> Float[Array, ""]:
        """$EI$ [N m^2]."""
        return self.youngs_modulus * self.area_moment

    @property
    def mass(self) -> Float[Array, ""]:
        """$\\rho A\\,l_1$ [kg]."""
        return self.mass_per_length * self.length

    def hub_axis_inertia(self) -> Float[Array, ""]:
        """Rigid beam's moment of inertia about the hub axis, $\\rho A\\int_0^{l_1}(r_0 + y)^2dy$
        [kg m^2] (the upper bound of $\\sum_i b_i^2$ over all modes)."""
        r0, l1 = self.root_offset, self.length
        return self.mass_per_length * ((r0 + l1) ** 3 - r0**3) / 3


class BeamModes(eqx.Module):
    r"""Modal data of a [`CantileverBeam`][] (see the module docstring for the formulas).

    - `beta`: $\beta_i$ [1/m], shape (N,).
    - `frequencies`: $\omega_i = \beta_i^2\sqrt{EI/\rho A}$ [rad/s].
    - `normalization`: $u_i = 1/\sqrt{\rho A\int\varphi_i^2}$ [kg^(-1/2)].
    - `coupling`: $b_i = -u_i\rho A\int\varphi_i(r_0 + y)dy$ [kg^(1/2) m].
    - `literal_stiffness`: the paper's printed $u_i EI\int\varphi_i''^2$ (not $\omega_i^2$; its
      square root, 3.145 rad/s for the first mode of the paper's beam, is not a frequency of
      the beam).
    """

    beta: Float[Array, " N"]
    frequencies: Float[Array, " N"]
    normalization: Float[Array, " N"]
    coupling: Float[Array, " N"]
    literal_stiffness: Float[Array, " N"]


def mode_shape(
    beam: CantileverBeam, beta: Float[ArrayLike, "..."], y: Float[ArrayLike, "..."]
) -> Float[Array, "..."]:
    r"""$\varphi(y)$ for the root $\beta$, evaluated stably.

    $\cosh x - \sigma\sinh x = \tfrac{1 - \sigma}{2}e^x + \tfrac{1 + \sigma}{2}e^{-x}$, with
    $1 - \sigma = (\sin L - \cos L - e^{-L})/(\sinh L + \sin L)$, $L = \beta l_1$, so the
    exponentially large terms never cancel.
    """
    beta = jnp.asarray(beta)
    x = beta * jnp.asarray(y)
    big = beta * beam.length
    denominator = jnp.sinh(big) + jnp.sin(big)
    sigma = (jnp.cosh(big) + jnp.cos(big)) / denominator
    one_minus_sigma = (jnp.sin(big) - jnp.cos(big) - jnp.exp(-big)) / denominator
    return (
        0.5 * one_minus_sigma * jnp.exp(x)
        + 0.5 * (1 + sigma) * jnp.exp(-x)
        - jnp.cos(x)
        + sigma * jnp.sin(x)
    )


def mode_curvature(
    beam: CantileverBeam, beta: Float[ArrayLike, "..."], y: Float[ArrayLike, "..."]
) -> Float[Array, "..."]:
    r"""$\varphi''(y) = \beta^2(\cosh x + \cos x - \sigma(\sinh x + \sin x))$, evaluated stably."""
    beta = jnp.asarray(beta)
    x = beta * jnp.asarray(y)
    big = beta * beam.length
    denominator = jnp.sinh(big) + jnp.sin(big)
    sigma = (jnp.cosh(big) + jnp.cos(big)) / denominator
    one_minus_sigma = (jnp.sin(big) - jnp.cos(big) - jnp.exp(-big)) / denominator
    return beta**2 * (
        0.5 * one_minus_sigma * jnp.exp(x)
        + 0.5 * (1 + sigma) * jnp.exp(-x)
        + jnp.cos(x)
        - sigma * jnp.sin(x)
    )


def cantilever_modes(
    beam: CantileverBeam, n_modes: int = 3, *, quadrature_order: int = 64
) -> BeamModes:
    """Frequencies, mass normalisation and hub coupling of the first `n_modes` modes.

    Integrals by `quadrature_order`-point Gauss-Legendre quadrature over $[0, l_1]$;
    differentiable in every field of `beam`.
    """
    if not isinstance(beam, CantileverBeam):
        raise ValueError(f"cantilever_modes: `beam` must be a CantileverBeam, got {beam!r}.")
    n_modes = check_positive_int("cantilever_modes", "n_modes", n_modes)
    quadrature_order = check_positive_int("cantilever_modes", "quadrature_order", quadrature_order)
    roots = jnp.asarray(cantilever_roots(n_modes), beam.length.dtype)
    beta = roots / beam.length
    y, w = _gauss_legendre(quadrature_order, beam.length)
    shapes = mode_shape(beam, beta[:, None], y[None, :])
    curvatures = mode_curvature(beam, beta[:, None], y[None, :])
    rho_a = beam.mass_per_length
    w, y = w[None, :], y[None, :]
    normalization = 1 / jnp.sqrt(rho_a * jnp.sum(w * shapes**2, axis=1))
    coupling = -normalization * rho_a * jnp.sum(w * shapes * (beam.root_offset + y), axis=1)
    curvature_integral = jnp.sum(w * curvatures**2, axis=1)
    frequencies = beta**2 * jnp.sqrt(beam.bending_stiffness / rho_a)
    literal = normalization * beam.bending_stiffness * curvature_integral
    return BeamModes(beta, frequencies, normalization, coupling, literal)
