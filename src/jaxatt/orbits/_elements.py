r"""Classical orbital elements, conversions to and from inertial state, Kepler propagation."""

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from ..numerics import clip, vectorized_sin, vectorized_sincos
from ._checks import check_orbit_arguments, check_orbit_state
from ._constants import MU_EARTH


class OrbitalElements(NamedTuple):
    r"""Classical elements of an elliptic orbit (angles in radians).

    - `a`: semi-major axis [m], $a > 0$;
    - `e`: eccentricity, $0 \le e < 1$;
    - `i`: inclination [rad];
    - `raan`: right ascension of the ascending node $\Omega$ [rad];
    - `argp`: argument of periapsis $\omega$ [rad];
    - `nu`: true anomaly $\theta$ [rad].

    Build from degrees with [`OrbitalElements.from_degrees`][].
    """

    a: Float[ArrayLike, ""]
    e: Float[ArrayLike, ""]
    i: Float[ArrayLike, ""]
    raan: Float[ArrayLike, ""]
    argp: Float[ArrayLike, ""]
    nu: Float[ArrayLike, ""]

    @classmethod
    def from_degrees(cls, a, e, i, raan, argp, nu) -> "OrbitalElements":
        """Elements with the four angles given in degrees (`a` in m)."""
        rad = np.deg2rad
        return cls(a, e, rad(i), rad(raan), rad(argp), rad(nu))


def _check_elements(where: str, elements, mu, **more) -> None:
    """The elements of an ellipse (`a > 0`, `e` in [0, 1), finite angles), `mu > 0`, and any
    `more` values finite (concrete values only)."""
    a, e, i, raan, argp, nu = elements
    check_orbit_arguments(where, a=a, e=e, i=i, raan=raan, argp=argp, nu=nu, mu=mu, **more)


def _perifocal_to_inertial(i, raan, argp) -> Float[Array, "3 3"]:
    """$R_3(-\\Omega) R_1(-i) R_3(-\\omega)$: perifocal (P, Q, W) to inertial components."""
    sO, cO = vectorized_sincos(raan)
    si, ci = vectorized_sincos(i)
    sw, cw = vectorized_sincos(argp)
    return jnp.array(
        [
            [cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
            [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
            [sw * si, cw * si, ci],
        ]
    )


def elements_to_state(
    elements: OrbitalElements, mu: RealScalarLike = MU_EARTH
) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
    r"""Inertial position [m] and velocity [m/s] of the elements.

    With $p = a(1 - e^2)$ and true anomaly $\theta$: in the perifocal frame
    $r = \frac{p}{1 + e\cos\theta}[\cos\theta, \sin\theta, 0]$,
    $v = \sqrt{\mu/p}\,[-\sin\theta, e + \cos\theta, 0]$, rotated by
    $R_3(-\Omega)R_1(-i)R_3(-\omega)$ (Vallado, *Fundamentals of Astrodynamics*, alg. 10).

    **Raises:** `ValueError` if `a <= 0`, `e` outside [0, 1), an angle not finite or
    `mu <= 0` (concrete values).
    """
    _check_elements("elements_to_state", elements, mu)
    a, e, i, raan, argp, nu = (jnp.asarray(x, dtype=float) for x in elements)
    p = a * (1.0 - e**2)
    sin_nu, cos_nu = vectorized_sincos(nu)
    radius = p / (1.0 + e * cos_nu)
    r_pf = radius * jnp.stack([cos_nu, sin_nu, jnp.zeros_like(nu)])
    v_pf = jnp.sqrt(mu / p) * jnp.stack([-sin_nu, e + cos_nu, jnp.zeros_like(nu)])
    rotation = _perifocal_to_inertial(i, raan, argp)
    return rotation @ r_pf, rotation @ v_pf


def state_to_elements(
    r: Float[ArrayLike, "3"], v: Float[ArrayLike, "3"], mu: RealScalarLike = MU_EARTH
) -> OrbitalElements:
    r"""Classical elements of an inertial state (the inverse of [`elements_to_state`][]).

    Standard vector formulas (Vallado alg. 9): $h = r\times v$, node vector
    $n = \hat z \times h$, eccentricity vector $e = v\times h/\mu - r/\|r\|$.
    Singular elements get conventional values: for a circular orbit ($e = 0$) $\omega = 0$ and
    $\theta$ is the argument of latitude; for an equatorial one ($i = 0$) $\Omega = 0$ and
    angles are measured from the $x$ axis. The state must be bound (negative energy).

    **Raises:** `ValueError` (concrete values) if `r` or `v` is not finite, `r` is zero, the
    state is rectilinear ($r\times v = 0$) or not bound, or `mu <= 0`.
    """
    check_orbit_arguments("state_to_elements", mu=mu)
    check_orbit_state("state_to_elements", "r", r, "v", v, bound_mu=mu)
    r, v = jnp.asarray(r, dtype=float), jnp.asarray(v, dtype=float)
    tiny = 1e-11
    h = jnp.cross(r, v)
    h_norm = jnp.linalg.norm(h)
    r_norm = jnp.linalg.norm(r)
    node = jnp.array([-h[1], h[0], 0.0])
    node_norm = jnp.linalg.norm(node)
    e_vec = jnp.cross(v, h) / mu - r / r_norm
    e = jnp.linalg.norm(e_vec)
    energy = 0.5 * jnp.dot(v, v) - mu / r_norm
    a = -mu / (2.0 * energy)
    i = jnp.arccos(clip(h[2] / h_norm, -1.0, 1.0))
    equatorial = node_norm < tiny * h_norm
    circular = e < tiny
    # Reference direction in the orbit plane: the node line, or x for an equatorial orbit.
    n_hat = jnp.where(
        equatorial, jnp.array([1.0, 0.0, 0.0]), node / jnp.where(equatorial, 1.0, node_norm)
    )
    raan = jnp.where(equatorial, 0.0, jnp.arctan2(n_hat[1], n_hat[0]))
    w_hat = h / h_norm
    m_hat = jnp.cross(w_hat, n_hat)  # completes (n_hat, m_hat) in the orbit plane

    def angle_from_node(vec):
        return jnp.arctan2(jnp.dot(vec, m_hat), jnp.dot(vec, n_hat))

    argp = jnp.where(circular, 0.0, angle_from_node(e_vec))
    nu = angle_from_node(r) - argp
    wrap = lambda x: jnp.mod(x, 2 * jnp.pi)
    return OrbitalElements(a, e, i, wrap(raan), wrap(argp), wrap(nu))


def mean_motion(a: RealScalarLike, mu: RealScalarLike = MU_EARTH) -> Float[Array, ""]:
    r"""Mean motion $n = \sqrt{\mu/a^3}$ [rad/s] (`a > 0`, `mu > 0`)."""
    check_orbit_arguments("mean_motion", a=a, mu=mu)
    return jnp.sqrt(mu / jnp.asarray(a, dtype=float) ** 3)


def true_to_mean_anomaly(nu: RealScalarLike, e: RealScalarLike) -> Float[Array, ""]:
    r"""Mean anomaly $M = E - e\sin E$, $\tan(E/2) = \sqrt{(1-e)/(1+e)}\tan(\theta/2)$
    (an ellipse: $0 \le e < 1$)."""
    check_orbit_arguments("true_to_mean_anomaly", nu=nu, e=e)
    nu, e = jnp.asarray(nu, dtype=float), jnp.asarray(e, dtype=float)
    sin_half, cos_half = vectorized_sincos(nu / 2)
    big_e = 2.0 * jnp.arctan2(jnp.sqrt(1.0 - e) * sin_half, jnp.sqrt(1.0 + e) * cos_half)
    return big_e - e * vectorized_sin(big_e)


def mean_to_true_anomaly(
    mean_anomaly: RealScalarLike, e: RealScalarLike, iterations: int = 30
) -> Float[Array, ""]:
    r"""True anomaly from the mean anomaly: Kepler's equation $M = E - e\sin E$ by Newton.

    Starts at $E_0 = M + e\sin M$ and takes a fixed number of Newton steps (so the function
    is traceable and differentiable); 30 steps reach rounding for $e \le 0.9$. The result is
    in $(-\pi, \pi]$ plus the whole revolutions of $M$. An ellipse: $0 \le e < 1$.
    """
    check_orbit_arguments("mean_to_true_anomaly", mean_anomaly=mean_anomaly, e=e)
    m, e = jnp.asarray(mean_anomaly, dtype=float), jnp.asarray(e, dtype=float)
    big_e = m + e * vectorized_sin(m)
    for _ in range(iterations):
        sin_e, cos_e = vectorized_sincos(big_e)
        big_e = big_e - (big_e - e * sin_e - m) / (1.0 - e * cos_e)
    sin_half, cos_half = vectorized_sincos(big_e / 2)
    half = 2.0 * jnp.arctan2(jnp.sqrt(1.0 + e) * sin_half, jnp.sqrt(1.0 - e) * cos_half)
    return half


def kepler_propagate(
    elements: OrbitalElements, dt: RealScalarLike, mu: RealScalarLike = MU_EARTH
) -> OrbitalElements:
    r"""The elements after `dt` seconds of unperturbed two-body motion (elliptic, closed form).

    Only the true anomaly changes: $M(t + \Delta t) = M(t) + n\,\Delta t$, then Kepler's
    equation ([`mean_to_true_anomaly`][]).
    """
    _check_elements("kepler_propagate", elements, mu, dt=dt)
    m0 = true_to_mean_anomaly(elements.nu, elements.e)
    nu = mean_to_true_anomaly(m0 + mean_motion(elements.a, mu) * dt, elements.e)
    return elements._replace(nu=nu)
