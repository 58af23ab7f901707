r"""A circular fly-around of a target on an eccentric orbit, with a target-pointing attitude
(Zhu & Yang 2009, SPEC 001(a)).

Position (target's Hill frame, see [`jaxatt.orbits`][]): a circle of radius $R_f$ centred on
the target, in the plane with unit normal $n_f$ (any orientation, fixed in the Hill frame),
flown at the rate $w_f$:

$$\rho_d = R_f(\cos\varphi\,a + \sin\varphi\,b),\quad \varphi = \varphi_0 + w_f(t - t_0),\quad
\dot\rho_d = R_f w_f(-\sin\varphi\,a + \cos\varphi\,b),\quad \ddot\rho_d = -w_f^2\rho_d,$$

with $(a, b, n_f)$ right-handed. Attitude: the desired frame D has $x_D = -\rho_d/R_f$ (the
body x axis points at the target) and $z_D = n_f$; relative to inertial space it turns at
$\omega_D = w_f n_f + \dot\theta\hat z$ (Hill components), so in D components
$\omega_d = C_{DH}(w_f n_f + \dot\theta\hat z)$ and
$\dot\omega_d = C_{DH}(w_f\dot\theta\,\hat z\times n_f + \ddot\theta\hat z)$;
$q_d$ is the quaternion of $C_{DN} = C_{DH}C_{HN}(\theta)$. The target's true anomaly $\theta$
is the reference's own state, integrated with the plant (the same ODE as
[`jaxatt.plants.RelativeOrbit`][]'s). A DCM gives $q_d$ only up to sign; the state also keeps
the last $q_d$, and each new one takes the sign closest to it (updated after every completed
step), so that $q_d(t)$ is continuous and a tracking law never sees a sudden 360 deg error.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._custom_types import RealScalarLike, Vector3Like
from .._validation import check, check_finite, check_positive, check_scalar, check_shape
from ..numerics import vectorized_sincos
from ..orbits import MU_EARTH
from ..orbits._relative_motion import anomaly_rates, hill_rotation
from ..rotations import quat_from_dcm
from ._base import AbstractReference, AttitudeReference
from ._translation import PoseReference, TranslationReference


class FlyAroundState(eqx.Module):
    """The target's true anomaly `theta` [rad] and the last desired quaternion `q_last`."""

    theta: Float[Array, ""]
    q_last: Float[Array, "4"]


class FlyAround(AbstractReference):
    r"""Circular fly-around with target pointing (see the module docstring).

    **Arguments:**
    - `a` [m], `e`, `i`, `raan`, `argp` [rad], `mu`: the target's orbit; `theta0`: its true
      anomaly at `t0` (the plant's initial $\theta$).
    - `radius`: $R_f > 0$ [m]; `rate`: $w_f$ [rad/s] (sign = direction);
      `normal`: $n_f$, any finite non-zero (3,) vector in Hill components (normalised here);
      `phase`: $\varphi_0$ [rad], measured from the in-plane axis $a$ of
      [`basis`][jaxatt.references.FlyAround.basis] (for $n_f = \hat z$: phase 0 on the
      negative along-track axis); `t0` [s].
    """

    a: Float[Array, ""]
    e: Float[Array, ""]
    i: Float[Array, ""]
    raan: Float[Array, ""]
    argp: Float[Array, ""]
    mu: Float[Array, ""]
    theta0: Float[Array, ""]
    radius: Float[Array, ""]
    rate: Float[Array, ""]
    normal: Float[Array, "3"]
    phase: Float[Array, ""]
    t0: Float[Array, ""]
    output_type: ClassVar[type] = PoseReference

    def __init__(
        self,
        a: RealScalarLike,
        e: RealScalarLike,
        i: RealScalarLike,
        raan: RealScalarLike,
        argp: RealScalarLike,
        *,
        radius: RealScalarLike,
        rate: RealScalarLike,
        normal: Vector3Like,
        theta0: RealScalarLike = 0.0,
        phase: RealScalarLike = 0.0,
        t0: RealScalarLike = 0.0,
        mu: RealScalarLike = MU_EARTH,
    ):
        where = "FlyAround"
        # Every orbit and circle parameter is one number: a (3,) `rate` or `t0` would broadcast
        # into the (3,) position and give a plausible but meaningless trajectory.
        a, e, i, raan, argp, radius, rate, theta0, phase, t0, mu = (
            check_scalar(where, n, v)
            for n, v in (
                ("a", a),
                ("e", e),
                ("i", i),
                ("raan", raan),
                ("argp", argp),
                ("radius", radius),
                ("rate", rate),
                ("theta0", theta0),
                ("phase", phase),
                ("t0", t0),
                ("mu", mu),
            )
        )
        self.a = check_positive(where, "a", a)
        self.e = check(where, "e", e, lambda xp, x: (x >= 0) & (x < 1), "must lie in [0, 1)")
        self.i, self.raan, self.argp = (
            check_finite(where, n, v) for n, v in (("i", i), ("raan", raan), ("argp", argp))
        )
        self.mu = check_positive(where, "mu", mu)
        self.theta0 = check_finite(where, "theta0", theta0)
        self.radius = check_positive(where, "radius", radius)
        self.rate = check_finite(where, "rate", rate)
        # Finite as well as non-zero: an infinite entry normalises to NaN. One predicate serves
        # a concrete normal (host check) and a traced one (run-time check).
        normal = check(
            where,
            "normal",
            check_shape(where, "normal", normal, (3,)),
            lambda xp, n: xp.all(xp.isfinite(n)) & (xp.sum(n * n) > 0),
            "must be a finite non-zero vector",
        )
        self.normal = normal / jnp.linalg.norm(normal)
        self.phase = check_finite(where, "phase", phase)
        self.t0 = check_finite(where, "t0", t0)

    def basis(self) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
        r"""$(a, b)$: orthonormal in the fly-around plane, $a \times b = n_f$; `phase` is
        measured from $a$.

        $a = h \times n_f / \|h \times n_f\|$ with the helper $h = \hat z$ where
        $|n_{f,z}| < 0.9$ and $h = \hat x$ otherwise, and $b = n_f \times a$. For example
        $n_f = \hat z$ gives $a = -\hat y$, $b = \hat x$ (phase 0 starts on the negative
        along-track axis, phase $\pi/2$ on the radial axis), $n_f = \hat x$ gives
        $a = \hat y$, $b = \hat z$. No choice is continuous over every normal: where
        $|n_{f,z}|$ crosses 0.9 the origin of `phase` jumps (and so do derivatives with
        respect to `normal`)."""
        n = self.normal
        helper = jnp.where(jnp.abs(n[2]) < 0.9, jnp.array([0.0, 0.0, 1.0]), jnp.array([1.0, 0, 0]))
        a = jnp.cross(helper, n)
        a = a / jnp.linalg.norm(a)
        return a, jnp.cross(n, a)

    def _frame(self, t, theta):
        a, b = self.basis()
        phi = self.phase + self.rate * (t - self.t0)
        s, c = vectorized_sincos(phi)
        x_d = -(c * a + s * b)
        c_dh = jnp.stack([x_d, jnp.cross(self.normal, x_d), self.normal])
        return phi, c_dh, c_dh @ hill_rotation(theta, self.i, self.raan, self.argp)

    def init(self, t0: RealScalarLike) -> FlyAroundState:
        _, _, c_dn = self._frame(t0, self.theta0)
        return FlyAroundState(self.theta0, quat_from_dcm(c_dn))

    def __call__(self, t: RealScalarLike, state: FlyAroundState):
        a, b = self.basis()
        phi, c_dh, c_dn = self._frame(t, state.theta)
        s, c = vectorized_sincos(phi)
        position = self.radius * (c * a + s * b)
        velocity = self.radius * self.rate * (-s * a + c * b)
        translation = TranslationReference(position, velocity, -(self.rate**2) * position)
        _, td, tdd = anomaly_rates(state.theta, self.a, self.e, self.mu)
        z = jnp.array([0.0, 0.0, 1.0])
        omega_d = c_dh @ (self.rate * self.normal + td * z)
        omega_d_dot = c_dh @ (self.rate * td * jnp.cross(z, self.normal) + tdd * z)
        q_d = quat_from_dcm(c_dn)
        q_d = jnp.where(jnp.dot(q_d, state.q_last) < 0, -q_d, q_d)
        attitude = AttitudeReference(q_d, omega_d, omega_d_dot)
        state_dot = FlyAroundState(td, jnp.zeros(4, q_d.dtype))
        return PoseReference(translation, attitude), state_dot

    def update(self, t: RealScalarLike, state: FlyAroundState) -> FlyAroundState:
        output, _ = self(t, state)
        return FlyAroundState(state.theta, output.attitude.q_d)

    def signals(self, t, state: FlyAroundState) -> dict[str, Array]:
        return {"reference_true_anomaly": state.theta}
