r"""Relative orbital motion of a chaser about a Keplerian target, as plants.

The state is [`RelativeOrbitState`][]: the target's true anomaly $\theta$ [rad] (integrated
with $\dot\theta = \sqrt{\mu/p^3}(1 + e\cos\theta)^2$, so the models hold for any target
eccentricity), and the relative position $\rho$ [m] and velocity $\dot\rho$ [m/s] in the
target's Hill frame (x radial out, y along-track, z orbit normal; see
[`jaxatt.orbits`][]). The control is a thrust acceleration $u$ [m/s^2] in the same frame:

$$\ddot\rho = A_1(\theta)\rho + A_2(\theta)\dot\rho + g(\theta, \rho) + u + d(t).$$

- [`RelativeOrbit`][]: the exact nonlinear model (Zhang et al. 2017 eqs. 1-2);
- [`TschaunerHempel`][]: its linearisation in $\rho$ (closed-form transition
  [`jaxatt.orbits.tschauner_hempel_stm`][]);
- [`ClohessyWiltshire`][]: the linearisation about a circular orbit
  ([`jaxatt.orbits.clohessy_wiltshire_stm`][]).

Each plant also serves as a controller's *model* of the drift: `natural_acceleration(t, x)`
is $A_1\rho + A_2\dot\rho + g$ without control or disturbance.

**Signals:** `position_error` $\rho - \rho_d$ [m], `velocity_error` $\dot\rho - \dot\rho_d$
[m/s], `position_norm` $\|\rho - \rho_d\|$ [m], `disturbance` $d(t)$ [m/s^2], `true_anomaly`
$\theta$ [rad].
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import (
    check,
    check_batched_shape,
    check_finite,
    check_positive,
    check_scalar,
    check_tree_finite,
)
from ..metrics import AbstractMetric, Effort, Peak, SettlingTime
from ..orbits import MU_EARTH, j2_gravity
from ..orbits._relative_motion import (
    anomaly_rates,
    coriolis_matrices,
    hill_rotation,
    linear_relative_gravity,
    relative_gravity,
)
from ..references import AbstractReference, ConstantPosition, TranslationReference
from ..signals import AbstractSignal, Constant, check_signal_shape
from ._base import AbstractPlant


class RelativeOrbitState(eqx.Module):
    """Target true anomaly `theta` [rad]; relative position `rho` [m] and velocity `rho_dot`
    [m/s] in the target's Hill frame (x radial out, y along-track, z orbit normal)."""

    theta: Float[Array, "*batch"]
    rho: Float[Array, "*batch 3"]
    rho_dot: Float[Array, "*batch 3"]


def check_target_orbit(where: str, a, e, mu) -> tuple[Array, Array, Array]:
    """Semi-major axis `a` > 0 [m], eccentricity `e` in [0, 1), `mu` > 0 [m^3/s^2]."""
    a = check_positive(where, "a", a)
    e = check(where, "e", e, lambda xp, x: (x >= 0) & (x < 1), "must lie in [0, 1)")
    mu = check_positive(where, "mu", mu)
    for name, value in (("a", a), ("e", e), ("mu", mu)):
        if value.shape != ():
            raise ValueError(f"{where}: `{name}` must be a scalar, got shape {value.shape}.")
    return a, e, mu


def translation_reference(where: str, reference) -> TranslationReference:
    if not isinstance(reference, TranslationReference):
        raise ValueError(
            f"{where}: the reference must produce a TranslationReference (e.g. "
            f"jaxatt.references.ConstantPosition), got {type(reference).__name__}."
        )
    return reference


class AbstractRelativeOrbit(AbstractPlant):
    r"""Shared machinery of the relative-orbit plants; subclasses give the gravity term $g$.

    **Fields:** `a` [m], `e`, `mu` [m^3/s^2] of the target's orbit; `disturbance`: an
    acceleration signal $d(t)$ of shape (3,) [m/s^2] (default zero).
    """

    a: eqx.AbstractVar[Float[Array, ""]]
    e: eqx.AbstractVar[Float[Array, ""]]
    mu: eqx.AbstractVar[Float[Array, ""]]
    disturbance: eqx.AbstractVar[AbstractSignal]
    measurement_type: ClassVar[type] = RelativeOrbitState

    @abc.abstractmethod
    def gravity(self, theta: RealScalarLike, rho: Float[Array, "3"]) -> Float[Array, "3"]:
        """The (differential) gravity term $g(\\theta, \\rho)$ of the model [m/s^2]."""

    def anomaly_rates(
        self, theta: RealScalarLike
    ) -> tuple[Float[Array, ""], Float[Array, ""], Float[Array, ""]]:
        """$(r_t, \\dot\\theta, \\ddot\\theta)$ of the target at true anomaly `theta`."""
        return anomaly_rates(theta, self.a, self.e, self.mu)

    def natural_acceleration(
        self, t: RealScalarLike, state: RelativeOrbitState
    ) -> Float[Array, "3"]:
        r"""$A_1\rho + A_2\dot\rho + g(\theta, \rho)$ [m/s^2] (no control, no disturbance)."""
        del t
        _, td, tdd = self.anomaly_rates(state.theta)
        a1, a2 = coriolis_matrices(td, tdd)
        return a1 @ state.rho + a2 @ state.rho_dot + self.gravity(state.theta, state.rho)

    def vector_field(self, t, state: RelativeOrbitState, control) -> RelativeOrbitState:
        _, td, _ = self.anomaly_rates(state.theta)
        accel = self.natural_acceleration(t, state) + control + self.disturbance(t)
        return RelativeOrbitState(td, state.rho_dot, accel)

    def measure(self, t, state: RelativeOrbitState) -> RelativeOrbitState:
        return state

    def signals(self, t, state: RelativeOrbitState, reference) -> dict[str, Array]:
        reference = translation_reference(type(self).__name__, reference)
        error = state.rho - reference.position
        return {
            "position_error": error,
            "velocity_error": state.rho_dot - reference.velocity,
            "position_norm": jnp.sqrt(jnp.sum(error**2)),
            "disturbance": self.disturbance(t),
            "true_anomaly": state.theta,
        }

    def check_state(self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()):
        where = type(self).__name__
        if not isinstance(state, RelativeOrbitState):
            raise ValueError(
                f"{where}: `{name}` must be a RelativeOrbitState(theta, rho, rho_dot), got "
                f"{type(state).__name__}."
            )
        check_tree_finite(where, name, state)
        return RelativeOrbitState(
            check_batched_shape(where, f"{name}.theta", state.theta, (), batch_shape),
            check_batched_shape(where, f"{name}.rho", state.rho, (3,), batch_shape),
            check_batched_shape(where, f"{name}.rho_dot", state.rho_dot, (3,), batch_shape),
        )

    def default_reference(self) -> AbstractReference:
        return ConstantPosition()

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """`settling_time` of $\\|\\rho - \\rho_d\\|$ to `tolerance` [m], `peak_control`
        $\\max|u_i|$ [m/s^2], `effort` $\\int\\|u\\|^2dt$ [m^2/s^3]."""
        return {
            "settling_time": SettlingTime("position_error", tolerance),
            "peak_control": Peak("u"),
            "effort": Effort("u"),
        }


def _disturbance(where: str, disturbance) -> AbstractSignal:
    disturbance = Constant(jnp.zeros(3)) if disturbance is None else disturbance
    check_signal_shape(where, "disturbance", disturbance, (3,))
    return disturbance


class RelativeOrbit(AbstractRelativeOrbit):
    r"""Exact nonlinear relative motion about a Keplerian target of any eccentricity.

    $g = [\mu/r_t^2 - \mu(r_t + x)/r_c^3,\ -\mu y/r_c^3,\ -\mu z/r_c^3]$,
    $r_c = \|[r_t + x, y, z]\|$ (Zhang et al. 2017 eqs. 1-2; SPEC 001(e)).

    **Arguments:** `a` [m] > 0, `e` in [0, 1), `mu` [m^3/s^2] (default Earth),
    `disturbance`: a (3,) acceleration signal [m/s^2] (default none).

    !!! cite
        Zhang Y, Du L, Yue X, Xu Y. Sliding-mode control of close-range relative orbits.
        Journal of Dynamics and Control 15(1):87-92, 2017, eqs. (1)-(2).
    """

    a: Float[Array, ""]
    e: Float[Array, ""]
    mu: Float[Array, ""]
    disturbance: AbstractSignal

    def __init__(
        self,
        a: RealScalarLike,
        e: RealScalarLike = 0.0,
        mu: RealScalarLike = MU_EARTH,
        disturbance: AbstractSignal | None = None,
    ):
        self.a, self.e, self.mu = check_target_orbit("RelativeOrbit", a, e, mu)
        self.disturbance = _disturbance("RelativeOrbit", disturbance)

    def gravity(self, theta, rho):
        return relative_gravity(theta, rho, self.a, self.e, self.mu)


class RelativeOrbitJ2(AbstractRelativeOrbit):
    r"""[`RelativeOrbit`][] with the $J_2$ perturbation acting on the chaser only.

    $g = g_{\text{Kepler}}(\theta, \rho) + C_{HN}\,a_{J_2}(C_{HN}^T[r_t + x, y, z])$: the target
    stays Keplerian (its orbit defines the Hill frame and $\theta$), the chaser feels the
    Earth's oblateness ([`jaxatt.orbits.j2_gravity`][], spin axis along inertial $z$). This is
    Wu et al. 2018's disturbance force "J2 only" (SPEC 001(c)); a controller that models the
    plain [`RelativeOrbit`][] sees $a_{J_2}$ ($\approx 10^{-2}$ m/s$^2$ in LEO) as a disturbance.

    **Arguments:** `a` [m], `e`, `i`, `raan`, `argp` [rad] of the target's orbit, `mu`,
    `disturbance` as [`RelativeOrbit`][].
    """

    a: Float[Array, ""]
    e: Float[Array, ""]
    mu: Float[Array, ""]
    i: Float[Array, ""]
    raan: Float[Array, ""]
    argp: Float[Array, ""]
    disturbance: AbstractSignal

    def __init__(
        self,
        a: RealScalarLike,
        e: RealScalarLike = 0.0,
        i: RealScalarLike = 0.0,
        raan: RealScalarLike = 0.0,
        argp: RealScalarLike = 0.0,
        mu: RealScalarLike = MU_EARTH,
        disturbance: AbstractSignal | None = None,
    ):
        self.a, self.e, self.mu = check_target_orbit("RelativeOrbitJ2", a, e, mu)
        self.i, self.raan, self.argp = (
            check_finite("RelativeOrbitJ2", n, check_scalar("RelativeOrbitJ2", n, v))
            for n, v in (("i", i), ("raan", raan), ("argp", argp))
        )
        self.disturbance = _disturbance("RelativeOrbitJ2", disturbance)

    def j2_acceleration(
        self, theta: RealScalarLike, rho: Float[ArrayLike, "3"]
    ) -> Float[Array, "3"]:
        """The chaser's $J_2$ acceleration in Hill components [m/s^2]."""
        r_t, _, _ = anomaly_rates(theta, self.a, self.e, self.mu)
        c_hn = hill_rotation(theta, self.i, self.raan, self.argp)
        chaser = c_hn.T @ (jnp.asarray(rho) + jnp.stack([r_t, 0.0 * r_t, 0.0 * r_t]))
        return c_hn @ j2_gravity(chaser, self.mu)

    def gravity(self, theta, rho):
        return relative_gravity(theta, rho, self.a, self.e, self.mu) + self.j2_acceleration(
            theta, rho
        )


class TschaunerHempel(AbstractRelativeOrbit):
    r"""Relative motion linearised in $\rho$ about an elliptic target orbit:
    $g \approx \frac{\mu}{r_t^3}[2x, -y, -z]$ (Tschauner & Hempel 1965).

    Same arguments as [`RelativeOrbit`][]; its exact solution is
    [`jaxatt.orbits.tschauner_hempel_stm`][].
    """

    a: Float[Array, ""]
    e: Float[Array, ""]
    mu: Float[Array, ""]
    disturbance: AbstractSignal

    def __init__(
        self,
        a: RealScalarLike,
        e: RealScalarLike = 0.0,
        mu: RealScalarLike = MU_EARTH,
        disturbance: AbstractSignal | None = None,
    ):
        self.a, self.e, self.mu = check_target_orbit("TschaunerHempel", a, e, mu)
        self.disturbance = _disturbance("TschaunerHempel", disturbance)

    def gravity(self, theta, rho):
        return linear_relative_gravity(theta, rho, self.a, self.e, self.mu)


class ClohessyWiltshire(AbstractRelativeOrbit):
    r"""Clohessy-Wiltshire: linear relative motion about a circular orbit of radius `a`,
    $\ddot x = 3n^2x + 2n\dot y + u_x$, $\ddot y = -2n\dot x + u_y$, $\ddot z = -n^2z + u_z$,
    $n = \sqrt{\mu/a^3}$ ($\theta$ advances at the constant rate $n$).

    **Arguments:** `a` [m], `mu`, `disturbance` as [`RelativeOrbit`][]. Exact solution:
    [`jaxatt.orbits.clohessy_wiltshire_stm`][].
    """

    a: Float[Array, ""]
    e: Float[Array, ""]
    mu: Float[Array, ""]
    disturbance: AbstractSignal

    def __init__(
        self,
        a: RealScalarLike,
        mu: RealScalarLike = MU_EARTH,
        disturbance: AbstractSignal | None = None,
    ):
        self.a, self.e, self.mu = check_target_orbit("ClohessyWiltshire", a, 0.0, mu)
        self.disturbance = _disturbance("ClohessyWiltshire", disturbance)

    def gravity(self, theta, rho):
        return linear_relative_gravity(theta, rho, self.a, self.e, self.mu)


def relative_orbit_state(
    theta: RealScalarLike, rho: Float[ArrayLike, "3"], rho_dot: Float[ArrayLike, "3"]
) -> RelativeOrbitState:
    """A [`RelativeOrbitState`][] from plain numbers (floating arrays)."""
    return RelativeOrbitState(
        jnp.asarray(theta, dtype=float),
        jnp.asarray(rho, dtype=float),
        jnp.asarray(rho_dot, dtype=float),
    )
