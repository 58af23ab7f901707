r"""Relative orbital motion about a Keplerian target: nonlinear, Tschauner-Hempel and
Clohessy-Wiltshire models, their state transition matrices, and frame conversions.

**Frame** (stated once, used everywhere in jaxatt): the target's local orbital (Hill, LVLH)
frame with origin at the target's centre of mass,

- $\hat x = r_t/\|r_t\|$: radial, outward (away from the Earth);
- $\hat z = h/\|h\|$, $h = r_t\times v_t$: along the orbit normal;
- $\hat y = \hat z\times\hat x$: along-track (in the direction of motion for a circular orbit).

It rotates with the angular velocity $\omega = \dot\theta\,\hat z$ relative to inertial space,
where $\theta$ is the target's true anomaly. The relative state is $\rho = [x, y, z]$ [m] and
$\dot\rho$ [m/s], both in Hill components, $\dot\rho$ the derivative *seen in the rotating frame*.

**Nonlinear model** (Zhang et al. 2017 eqs. 1-2, exact for any target eccentricity):

$$\ddot\rho = A_1\rho + A_2\dot\rho + g(\theta, \rho) + u,\qquad
A_1 = \begin{bmatrix}\dot\theta^2 & \ddot\theta & 0\\ -\ddot\theta & \dot\theta^2 & 0\\
0&0&0\end{bmatrix},\ A_2 = \begin{bmatrix}0 & 2\dot\theta & 0\\ -2\dot\theta & 0 & 0\\
0&0&0\end{bmatrix},$$
$$g = \Big[\frac{\mu}{r_t^2} - \frac{\mu (r_t + x)}{r_c^3},\ -\frac{\mu y}{r_c^3},\
-\frac{\mu z}{r_c^3}\Big],\quad r_c = \sqrt{(r_t + x)^2 + y^2 + z^2},$$

with $r_t = p/(1 + e\cos\theta)$, $\dot\theta = \sqrt{\mu/p^3}(1 + e\cos\theta)^2$,
$\ddot\theta = -2\dot r_t\dot\theta/r_t = -2\sqrt{\mu/p^3}^{\,2}\,e\sin\theta\,(1+e\cos\theta)^3$,
$p = a(1-e^2)$; $u$ is the thrust (or any non-gravitational) acceleration [m/s^2].

**Tschauner-Hempel** (linear in $\rho$, any $e$): $g \approx \frac{\mu}{r_t^3}[2x, -y, -z]$.
**Clohessy-Wiltshire** (linear, circular target): the same with $e = 0$, $\dot\theta = n$.
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from ..numerics import vectorized_sincos
from ._checks import check_orbit_arguments, check_orbit_state
from ._constants import MU_EARTH
from ._gravity import point_mass_gravity


# --- The target's orbit ----------------------------------------------------------------------


def semi_latus_rectum(a: RealScalarLike, e: RealScalarLike) -> Float[Array, ""]:
    """$p = a(1 - e^2)$ [m] of an ellipse (`a > 0`, `e` in [0, 1))."""
    check_orbit_arguments("semi_latus_rectum", a=a, e=e)
    return jnp.asarray(a) * (1.0 - jnp.asarray(e) ** 2)


def anomaly_rates(
    theta: RealScalarLike, a: RealScalarLike, e: RealScalarLike, mu: RealScalarLike = MU_EARTH
) -> tuple[Float[Array, ""], Float[Array, ""], Float[Array, ""]]:
    r"""$(r_t, \dot\theta, \ddot\theta)$ of a Keplerian orbit at true anomaly $\theta$.

    $r_t = p/(1+e\cos\theta)$ [m], $\dot\theta = \sqrt{\mu/p^3}(1+e\cos\theta)^2$ [rad/s],
    $\ddot\theta = -2\frac{\mu}{p^3}e\sin\theta(1+e\cos\theta)^3$ [rad/s^2].

    **Raises:** `ValueError` (concrete values) unless `a > 0`, $0 \le e < 1$, `mu > 0` and
    `theta` is finite; the same holds for the functions below that take an orbit.
    """
    check_orbit_arguments("anomaly_rates", theta=theta, a=a, e=e, mu=mu)
    return _anomaly_rates(theta, a, e, mu)


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def _anomaly_rates(theta, a, e, mu):
    p = semi_latus_rectum(a, e)  # its checks skip the traced arguments
    k2 = jnp.sqrt(mu / p**3)
    sin_theta, cos_theta = vectorized_sincos(theta)
    rho = 1.0 + e * cos_theta
    return p / rho, k2 * rho**2, -2.0 * k2**2 * e * sin_theta * rho**3


# Traced once per argument shape however often a step calls it (docs/performance.md).
@jax.jit
def coriolis_matrices(
    theta_dot: RealScalarLike, theta_ddot: RealScalarLike
) -> tuple[Float[Array, "3 3"], Float[Array, "3 3"]]:
    r"""$(A_1, A_2)$ of Zhang 2017 eq. (2): the rotating-frame (Coriolis, Euler, centrifugal)
    terms, $A_1\rho + A_2\dot\rho = -2\omega\times\dot\rho - \dot\omega\times\rho -
    \omega\times(\omega\times\rho)$ exactly, with $\omega = \dot\theta\hat z$ [rad/s]."""
    td, tdd = jnp.asarray(theta_dot), jnp.asarray(theta_ddot)
    zero = jnp.zeros_like(td)
    a1 = jnp.array([[td**2, tdd, zero], [-tdd, td**2, zero], [zero, zero, zero]])
    a2 = jnp.array([[zero, 2 * td, zero], [-2 * td, zero, zero], [zero, zero, zero]])
    return a1, a2


def relative_gravity(
    theta: RealScalarLike,
    rho: Float[ArrayLike, "3"],
    a: RealScalarLike,
    e: RealScalarLike,
    mu: RealScalarLike = MU_EARTH,
) -> Float[Array, "3"]:
    r"""$g(\theta, \rho)$: the differential gravity of the nonlinear model [m/s^2]."""
    check_orbit_arguments("relative_gravity", theta=theta, a=a, e=e, mu=mu)
    rho = jnp.asarray(rho)
    r_t, _, _ = anomaly_rates(theta, a, e, mu)
    rel = rho + jnp.stack([r_t, jnp.zeros_like(r_t), jnp.zeros_like(r_t)])
    return point_mass_gravity(rel, mu) + jnp.stack(
        [mu / r_t**2, jnp.zeros_like(r_t), jnp.zeros_like(r_t)]
    )


def linear_relative_gravity(
    theta: RealScalarLike,
    rho: Float[ArrayLike, "3"],
    a: RealScalarLike,
    e: RealScalarLike,
    mu: RealScalarLike = MU_EARTH,
) -> Float[Array, "3"]:
    r"""First-order $g \approx \frac{\mu}{r_t^3}[2x, -y, -z]$ (Tschauner-Hempel; CW for $e=0$)."""
    check_orbit_arguments("linear_relative_gravity", theta=theta, a=a, e=e, mu=mu)
    rho = jnp.asarray(rho)
    r_t, _, _ = anomaly_rates(theta, a, e, mu)
    return mu / r_t**3 * jnp.array([2.0, -1.0, -1.0]) * rho


def relative_acceleration(
    theta: RealScalarLike,
    rho: Float[ArrayLike, "3"],
    rho_dot: Float[ArrayLike, "3"],
    a: RealScalarLike,
    e: RealScalarLike,
    mu: RealScalarLike = MU_EARTH,
    *,
    linear: bool = False,
) -> Float[Array, "3"]:
    r"""Natural (unforced) $\ddot\rho = A_1\rho + A_2\dot\rho + g$ in the Hill frame [m/s^2].

    `linear=True` gives the Tschauner-Hempel linearisation (Clohessy-Wiltshire when `e = 0`).
    """
    check_orbit_arguments("relative_acceleration", theta=theta, a=a, e=e, mu=mu)
    rho, rho_dot = jnp.asarray(rho), jnp.asarray(rho_dot)
    _, td, tdd = anomaly_rates(theta, a, e, mu)
    a1, a2 = coriolis_matrices(td, tdd)
    gravity = linear_relative_gravity if linear else relative_gravity
    return a1 @ rho + a2 @ rho_dot + gravity(theta, rho, a, e, mu)


# --- Frames ----------------------------------------------------------------------------------


def hill_frame(r_t: Float[ArrayLike, "3"], v_t: Float[ArrayLike, "3"]) -> Float[Array, "3 3"]:
    r"""Rotation $C$ from inertial to Hill components: rows $\hat x, \hat y, \hat z$ (above).

    $\rho_{Hill} = C\,\rho_{inertial}$; $C^T$ maps back. The target's state must be finite,
    with $r_t \ne 0$ and $r_t\times v_t \ne 0$ (`ValueError` for concrete values).
    """
    check_orbit_state("hill_frame", "r_t", r_t, "v_t", v_t)
    return _hill_frame(r_t, v_t)


def _hill_frame(r_t, v_t):
    r_t, v_t = jnp.asarray(r_t), jnp.asarray(v_t)
    x_hat = r_t / jnp.linalg.norm(r_t)
    h = jnp.cross(r_t, v_t)
    z_hat = h / jnp.linalg.norm(h)
    return jnp.stack([x_hat, jnp.cross(z_hat, x_hat), z_hat])


def inertial_to_hill(
    r_t: Float[ArrayLike, "3"],
    v_t: Float[ArrayLike, "3"],
    r_c: Float[ArrayLike, "3"],
    v_c: Float[ArrayLike, "3"],
) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
    r"""Chaser inertial state $(r_c, v_c)$ to the relative state $(\rho, \dot\rho)$ in the
    target's Hill frame: $\rho = C(r_c - r_t)$, $\dot\rho = C(v_c - v_t) - \omega\times\rho$,
    $\omega = [0, 0, \|r_t\times v_t\|/\|r_t\|^2]$."""
    check_orbit_state("inertial_to_hill", "r_t", r_t, "v_t", v_t)
    r_t, v_t = jnp.asarray(r_t), jnp.asarray(v_t)
    c = _hill_frame(r_t, v_t)
    omega = jnp.stack(
        [0.0 * r_t[0], 0.0 * r_t[0], jnp.linalg.norm(jnp.cross(r_t, v_t)) / jnp.sum(r_t**2)]
    )
    rho = c @ (jnp.asarray(r_c) - r_t)
    return rho, c @ (jnp.asarray(v_c) - v_t) - jnp.cross(omega, rho)


def hill_to_inertial(
    r_t: Float[ArrayLike, "3"],
    v_t: Float[ArrayLike, "3"],
    rho: Float[ArrayLike, "3"],
    rho_dot: Float[ArrayLike, "3"],
) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
    """The inverse of [`inertial_to_hill`][]: the chaser's inertial position and velocity."""
    check_orbit_state("hill_to_inertial", "r_t", r_t, "v_t", v_t)
    r_t, v_t, rho = jnp.asarray(r_t), jnp.asarray(v_t), jnp.asarray(rho)
    c = _hill_frame(r_t, v_t)
    omega = jnp.stack(
        [0.0 * r_t[0], 0.0 * r_t[0], jnp.linalg.norm(jnp.cross(r_t, v_t)) / jnp.sum(r_t**2)]
    )
    return r_t + c.T @ rho, v_t + c.T @ (jnp.asarray(rho_dot) + jnp.cross(omega, rho))


# --- Closed-form state transition matrices ------------------------------------------------------


def clohessy_wiltshire_stm(n: RealScalarLike, t: RealScalarLike) -> Float[Array, "6 6"]:
    r"""State transition matrix of the Clohessy-Wiltshire equations over a time `t` [s].

    $\ddot x = 3n^2x + 2n\dot y$, $\ddot y = -2n\dot x$, $\ddot z = -n^2 z$ (Hill frame above,
    mean motion $n$ [rad/s]); $[\rho(t), \dot\rho(t)] = \Phi(t)[\rho(0), \dot\rho(0)]$
    (Vallado, *Fundamentals of Astrodynamics*, eq. 6-66 in this axis order).

    **Raises:** `ValueError` (concrete values) unless `n > 0` and `t` is finite.
    """
    check_orbit_arguments("clohessy_wiltshire_stm", n=n, t=t)
    n, t = jnp.asarray(n), jnp.asarray(t)
    s, c = vectorized_sincos(n * t)
    zero, one = jnp.zeros_like(s), jnp.ones_like(s)
    return jnp.array(
        [
            [4 - 3 * c, zero, zero, s / n, 2 * (1 - c) / n, zero],
            [6 * (s - n * t), one, zero, -2 * (1 - c) / n, (4 * s - 3 * n * t) / n, zero],
            [zero, zero, c, zero, zero, s / n],
            [3 * n * s, zero, zero, c, 2 * s, zero],
            [-6 * n * (1 - c), zero, zero, -2 * s, 4 * c - 3, zero],
            [zero, zero, -n * s, zero, zero, c],
        ]
    )


def _ya_fundamental(theta, e, j):
    """Yamanaka-Ankersen fundamental matrix (x along-track, z radial inward; transformed
    variables, rows x~, z~, x~', z~')."""
    sin_theta, cos_theta = vectorized_sincos(theta)
    sin_2theta, cos_2theta = vectorized_sincos(2 * theta)
    rho = 1 + e * cos_theta
    s, c = rho * sin_theta, rho * cos_theta
    sp = cos_theta + e * cos_2theta
    cp = -(sin_theta + e * sin_2theta)
    zero, one = jnp.zeros_like(s), jnp.ones_like(s)
    return jnp.array(
        [
            [one, -c * (1 + 1 / rho), s * (1 + 1 / rho), 3 * rho**2 * j],
            [zero, s, c, 2 - 3 * e * s * j],
            [zero, 2 * s, 2 * c - e, 3 * (1 - 2 * e * s * j)],
            [zero, sp, cp, -3 * e * (sp * j + s / rho**2)],
        ]
    )


def _ya_inverse(theta, e):
    """Inverse of the fundamental matrix at J = 0 (Yamanaka & Ankersen 2002, eq. 82)."""
    sin_theta, cos_theta = vectorized_sincos(theta)
    rho = 1 + e * cos_theta
    s, c = rho * sin_theta, rho * cos_theta
    zero = jnp.zeros_like(s)
    m = jnp.array(
        [
            [1 - e**2, 3 * e * s * (1 / rho + 1 / rho**2), -e * s * (1 + 1 / rho), 2 - e * c],
            [zero, -3 * s * (1 / rho + e**2 / rho**2), s * (1 + 1 / rho), c - 2 * e],
            [zero, -3 * (c / rho + e), c * (1 + 1 / rho) + e, -s],
            [zero, 3 * rho + e**2 - 1, -(rho**2), e * s],
        ]
    )
    return m / (1 - e**2)


def tschauner_hempel_stm(
    theta0: RealScalarLike,
    t: RealScalarLike,
    a: RealScalarLike,
    e: RealScalarLike,
    mu: RealScalarLike = MU_EARTH,
) -> Float[Array, "6 6"]:
    r"""State transition matrix of the Tschauner-Hempel equations (Yamanaka-Ankersen form).

    From true anomaly `theta0` at time 0 over a time `t` [s], in the Hill frame above:
    $[\rho(t), \dot\rho(t)] = \Phi[\rho(0), \dot\rho(0)]$ for an elliptic target orbit
    ($0 \le e < 1$). The in-plane solution uses the transformed variables
    $\tilde\rho = (1 + e\cos\theta)\rho$ with $\theta$ as the independent variable and
    $J = \sqrt{\mu/p^3}\,t$; the out-of-plane one is $\tilde z'' + \tilde z = 0$.

    !!! cite
        K. Yamanaka, F. Ankersen, "New state transition matrix for relative motion on an
        arbitrary elliptical orbit", J. Guidance, Control, and Dynamics 25(1):60-66, 2002.

    **Raises:** `ValueError` (concrete values) unless `a > 0`, $0 \le e < 1$, `mu > 0` and
    `theta0`, `t` are finite.
    """
    check_orbit_arguments("tschauner_hempel_stm", theta0=theta0, t=t, a=a, e=e, mu=mu)
    from ._elements import mean_motion, mean_to_true_anomaly, true_to_mean_anomaly

    theta0, t = jnp.asarray(theta0, dtype=float), jnp.asarray(t, dtype=float)
    p = semi_latus_rectum(a, e)
    k2 = jnp.sqrt(mu / p**3)
    m0 = true_to_mean_anomaly(theta0, e)
    dtheta = mean_to_true_anomaly(m0 + mean_motion(a, mu) * t, e) - theta0
    dtheta = jnp.mod(dtheta - mean_motion(a, mu) * t + jnp.pi, 2 * jnp.pi) - jnp.pi
    theta = theta0 + dtheta + mean_motion(a, mu) * t  # continuous in t (whole revolutions)

    def to_transformed(th):
        # [x_ya, z_ya, x_ya_dot, z_ya_dot] -> [x~, z~, x~', z~'] (Yamanaka-Ankersen eq. 73)
        sin_th, cos_th = vectorized_sincos(th)
        rho = 1 + e * cos_th
        d = -e * sin_th
        g = 1 / (k2 * rho)
        zero = jnp.zeros_like(rho)
        return jnp.array(
            [
                [rho, zero, zero, zero],
                [zero, rho, zero, zero],
                [d, zero, g, zero],
                [zero, d, zero, g],
            ]
        )

    phi_t = jnp.linalg.solve(to_transformed(theta), jnp.eye(4))
    in_plane = phi_t @ _ya_fundamental(theta, e, k2 * t) @ _ya_inverse(theta0, e)
    in_plane = in_plane @ to_transformed(theta0)
    # Hill (x radial out, y along) from YA (x_ya along, z_ya radial in): x = -z_ya, y = x_ya;
    # p_map maps [x_ya, z_ya, xd_ya, zd_ya] -> [x, y, xd, yd].
    p_map = jnp.array(
        [
            [0.0, -1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, -1.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    )
    planar = p_map @ in_plane @ p_map.T
    # Out of plane: z~ = rho z, z~'' + z~ = 0 in theta.
    (sin0, cos0), (sin1, cos1) = vectorized_sincos(theta0), vectorized_sincos(theta)
    sin_d, cos_d = vectorized_sincos(theta - theta0)
    rho0, rho1 = 1 + e * cos0, 1 + e * cos1
    to0 = jnp.array([[rho0, 0.0 * rho0], [-e * sin0, 1 / (k2 * rho0)]])
    to1 = jnp.array([[rho1, 0.0 * rho1], [-e * sin1, 1 / (k2 * rho1)]])
    rot = jnp.array([[cos_d, sin_d], [-sin_d, cos_d]])
    normal = jnp.linalg.solve(to1, rot @ to0)
    out = jnp.zeros((6, 6), planar.dtype)
    idx_planar = jnp.array([0, 1, 3, 4])
    idx_normal = jnp.array([2, 5])
    out = out.at[jnp.ix_(idx_planar, idx_planar)].set(planar)
    out = out.at[jnp.ix_(idx_normal, idx_normal)].set(normal)
    return out


@jax.jit
def hill_rotation(
    theta: RealScalarLike, i: RealScalarLike, raan: RealScalarLike, argp: RealScalarLike
) -> Float[Array, "3 3"]:
    r"""$C_{HN} = R_3(\omega + \theta)R_1(i)R_3(\Omega)$: inertial to Hill components for a target
    at true anomaly $\theta$ on an orbit of inclination $i$, node $\Omega$, periapsis $\omega$
    (the same matrix as [`hill_frame`][] of the target's state, without needing the state).

    A `jax.jit` function: traced once per argument shape however many times a closed loop's
    step evaluates it (XLA inlines the call, so the compiled step is the same)."""
    u = jnp.asarray(argp) + jnp.asarray(theta)

    def r1(a):
        s, c = vectorized_sincos(a)
        return jnp.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])

    def r3(a):
        s, c = vectorized_sincos(a)
        return jnp.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])

    return r3(u) @ r1(jnp.asarray(i)) @ r3(jnp.asarray(raan))
