r"""Gravity models: point mass and the $J_2$ zonal perturbation."""

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from ._constants import J2_EARTH, MU_EARTH, R_EARTH


def point_mass_gravity(
    r: Float[ArrayLike, "3"], mu: RealScalarLike = MU_EARTH
) -> Float[Array, "3"]:
    r"""Two-body acceleration $-\mu\,r/\|r\|^3$ [m/s^2] at the position `r` [m].

    Singular at $r = 0$ (inside the central body; not guarded). $\|r\|^3$ is computed as
    $\|r\|^2 \sqrt{\|r\|^2}$: a square root vectorizes, where a float64 `** 1.5` is a
    C-library `pow` call per element on XLA:CPU (docs/performance.md).
    """
    r = jnp.asarray(r)
    r2 = jnp.sum(r * r)
    return -mu * r / (r2 * jnp.sqrt(r2))


def j2_gravity(
    r: Float[ArrayLike, "3"],
    mu: RealScalarLike = MU_EARTH,
    j2: RealScalarLike = J2_EARTH,
    radius: RealScalarLike = R_EARTH,
) -> Float[Array, "3"]:
    r"""The $J_2$ perturbing acceleration [m/s^2] (the point-mass term excluded).

    With the planet's spin axis along the inertial $z$ axis and $\rho = \|r\|$:

    $$a_{J_2} = -\frac{3 \mu J_2 R^2}{2 \rho^5}
    \begin{bmatrix} x(1 - 5z^2/\rho^2) \\ y(1 - 5z^2/\rho^2) \\ z(3 - 5z^2/\rho^2)\end{bmatrix}.$$

    **Arguments:** `r` the position [m] in the planet-centred inertial frame, `mu` [m^3/s^2],
    `j2` (dimensionless), `radius` the equatorial radius $R$ [m].
    """
    r = jnp.asarray(r)
    rho2 = jnp.sum(r * r)
    z2 = 5.0 * r[2] ** 2 / rho2
    factor = -1.5 * mu * j2 * radius**2 / (rho2 * rho2 * jnp.sqrt(rho2))  # rho^5, no pow call
    return factor * r * jnp.stack([1.0 - z2, 1.0 - z2, 3.0 - z2])
