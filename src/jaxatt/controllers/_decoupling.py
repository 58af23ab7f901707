r"""Input-output decoupling of the Euler-angle rigid body by feedback linearisation (SPEC 001(b)).

With the outputs $y = h(x) = (\phi, \theta, \psi)$ of [`jaxatt.plants.RigidBodyEuler`][],
$\dot y = R(\phi, \theta)\,\omega$ and $J\dot\omega = -\omega\times J\omega + M$, each output
has relative degree 2 and

$$\ddot y = b(x) + A(x)\,M,\qquad A(x) = [L_{g_j}L_f h_i] = R(\phi, \theta)\,J^{-1},$$
$$b(x) = [L_f^2 h_i] = \frac{\partial (R\omega)}{\partial y}R\omega
- R J^{-1}(\omega\times J\omega).$$

The control $M = A(x)^{-1}(v - b(x)) = J R^{-1}(v - b(x))$ makes $\ddot y = v$ exactly: three
decoupled double integrators. $b(x)$ is computed by forward-mode autodiff (`jax.jvp`) of
$R(y)\omega$ along the drift, never by a hand-expanded formula, and $R^{-1}$ in closed form
([`jaxatt.rotations.euler321_body_rates`][]). $A(x)$ is invertible wherever
$\cos\theta \ne 0$ ($\det R = 1/\cos\theta$).

The outer law is pluggable: any [`AbstractDecoupledLaw`][] giving the error acceleration
$a = \ddot e$ of the three double integrators from $e = y - y_d$, $\dot e = \dot y - \dot y_d$;
then $v = \ddot y_d + a$. Provided: [`DecoupledPD`][] and [`DecoupledSlidingMode`][] (with a
[`jaxatt.sliding.GlobalSurface`][], the global terminal sliding mode of SPEC 001(b)).
"""

import abc
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float, PyTree

from .._custom_types import Mat33, RealScalarLike, Vec3
from .._validation import (
    check_gain_shape,
    check_in_open_interval,
    check_positive,
    check_scalar,
    check_spd,
)
from ..numerics import inv3, solve3
from ..plants import EulerAngleState
from ..reaching import AbstractReachingLaw
from ..references import EulerAngleCommand
from ..rotations import euler321_body_rates, euler321_kinematics, euler321_kinematics_matrix
from ..sliding import GlobalSurface, PDSurface, TerminalSurface
from ._base import AbstractController


def decoupling_matrix(
    inertia: Float[ArrayLike, "3 3"],
    angles: Float[ArrayLike, "3"],
    cos_floor: RealScalarLike | None = None,
) -> Mat33:
    r"""$A(x) = R(\phi, \theta)J^{-1}$ [1/(kg m^2)] (`cos_floor` as in
    [`jaxatt.rotations.euler321_kinematics_matrix`][]). $J^{-1}$ by the adjugate
    ([`jaxatt.numerics.inv3`][]): no LAPACK call when used in a batched step."""
    rotation = euler321_kinematics_matrix(angles, cos_floor)
    return rotation @ inv3(inertia)


def decoupling_drift(
    inertia: Float[ArrayLike, "3 3"],
    angles: Float[ArrayLike, "3"],
    omega: Float[ArrayLike, "3"],
    cos_floor: RealScalarLike | None = None,
) -> Vec3:
    r"""$b(x) = L_f^2 h$ [rad/s^2]: the time derivative of $R(y)\omega$ along the torque-free
    motion $\dot y = R\omega$, $\dot\omega = -J^{-1}(\omega\times J\omega)$, by `jax.jvp`."""
    inertia, angles, omega = jnp.asarray(inertia), jnp.asarray(angles), jnp.asarray(omega)
    angle_rates = euler321_kinematics(angles, omega, cos_floor)
    omega_dot = solve3(inertia, -jnp.cross(omega, inertia @ omega))

    def output_rate(angles, omega):
        return euler321_kinematics(angles, omega, cos_floor)

    _, drift = jax.jvp(output_rate, (angles, omega), (angle_rates, omega_dot))
    return drift


class AbstractDecoupledLaw(eqx.Module):
    r"""An outer law for three decoupled double integrators $\ddot e = a$.

    **Required:**
    - `init(t0, e, e_dot) -> state`: internal state at $t_0$ (`None` if none);
    - `__call__(t, e, e_dot, state) -> (a, state_dot)`: the commanded error acceleration
      $a$ (3,) and the derivative of the continuous state (`None` if none).

    **Optional:** `signals(t, e, e_dot, state) -> dict` (default: none).
    """

    @abc.abstractmethod
    def init(self, t0: RealScalarLike, e: Vec3, e_dot: Vec3) -> PyTree[Array]:
        """Internal state at `t0`."""

    @abc.abstractmethod
    def __call__(
        self, t: RealScalarLike, e: Vec3, e_dot: Vec3, state: PyTree[Array]
    ) -> tuple[Vec3, PyTree[Array]]:
        """Commanded $\\ddot e$ and the state derivative."""

    def signals(
        self, t: RealScalarLike, e: Vec3, e_dot: Vec3, state: PyTree[Array]
    ) -> dict[str, Array]:
        """Named signals to record (default: none)."""
        del t, e, e_dot, state
        return {}


class DecoupledPD(AbstractDecoupledLaw):
    r"""$a = -k_p e - k_d\dot e$: each axis $\ddot e + k_d\dot e + k_p e = 0$.

    **Arguments:** `kp` [1/s^2], `kd` [1/s], positive scalars or per-axis (3,) arrays.
    """

    kp: Float[Array, "*k"]
    kd: Float[Array, "*k"]

    def __init__(self, kp: Float[ArrayLike, "*k"], kd: Float[ArrayLike, "*k"]):
        self.kp = check_gain_shape("DecoupledPD", "kp", check_positive("DecoupledPD", "kp", kp))
        self.kd = check_gain_shape("DecoupledPD", "kd", check_positive("DecoupledPD", "kd", kd))

    def init(self, t0: RealScalarLike, e: Vec3, e_dot: Vec3) -> None:
        del t0, e, e_dot
        return None

    def __call__(self, t: RealScalarLike, e: Vec3, e_dot: Vec3, state: None) -> tuple[Vec3, None]:
        del t, state
        return -self.kp * e - self.kd * e_dot, None


class DecoupledSlidingMode(AbstractDecoupledLaw):
    r"""Sliding mode for $\ddot e = a$: $a = r(s) - \dot h$, so that $\dot s = r(s)$ exactly.

    With a plain surface $s = \dot e + h(e)$ ([`jaxatt.sliding.PDSurface`][],
    [`jaxatt.sliding.TerminalSurface`][]) or a [`jaxatt.sliding.GlobalSurface`][]
    $s_g = \dot e + h(e) - s(t_0)f(t - t_0)$, whose $s_g(t_0) = 0$: then, for a reaching law
    with $r(0) = 0$ (every law of [`jaxatt.reaching`][]), $s_g \equiv 0$ and the reaching phase
    is gone. That is the **global terminal sliding mode** of SPEC 001(b) [R]:
    `DecoupledSlidingMode(GlobalSurface(TerminalSurface(a, b, q/p), ExponentialDecay(T)), law)`.

    **Terminal singularity.** $\dot h = (a + b\,\tfrac qp|e|^{q/p - 1})\dot e$ is unbounded as
    $e_i \to 0$ with $\dot e_i \ne 0$ (the standard singularity of terminal sliding modes with
    $q/p < 1$). [`jaxatt.sliding.TerminalSurface`][] guards it by evaluating $|e_i|^{q/p-1}$ at
    $\max(|e_i|, \epsilon_e)$ (its `floor`), so the law is finite everywhere; inside the floor
    $\dot s = r(s)$ holds only approximately. On the surface $\dot e \approx -b\,
    \mathrm{sig}^{q/p}(e)$ near 0, so the exact term $|e|^{q/p-1}\dot e \sim |e|^{2q/p - 1}$
    stays bounded iff $q/p \ge 1/2$: choose $q/p \in [1/2, 1)$. (The nonsingular form
    $s = e + \beta\,\mathrm{sig}^{p/q}(\dot e)$ is not implemented.)

    **Arguments:** `surface` (above), `reaching_law` (an
    [`jaxatt.reaching.AbstractReachingLaw`][]). **Signals:** `s` (3,).
    """

    surface: GlobalSurface | PDSurface | TerminalSurface
    reaching_law: AbstractReachingLaw

    def __init__(
        self,
        surface: GlobalSurface | PDSurface | TerminalSurface,
        reaching_law: AbstractReachingLaw,
    ):
        if not isinstance(surface, (GlobalSurface, PDSurface, TerminalSurface)):
            raise TypeError(
                "DecoupledSlidingMode: `surface` must be a GlobalSurface, PDSurface or "
                f"TerminalSurface, got {type(surface).__name__}."
            )
        if not isinstance(reaching_law, AbstractReachingLaw):
            raise TypeError(
                "DecoupledSlidingMode: `reaching_law` must be a jaxatt.reaching law, got "
                f"{type(reaching_law).__name__}."
            )
        self.surface = surface
        self.reaching_law = reaching_law

    def init(self, t0: RealScalarLike, e: Vec3, e_dot: Vec3):
        if isinstance(self.surface, GlobalSurface):
            return self.surface.init(t0, e, e_dot)
        return None

    def sliding_variable(self, t: RealScalarLike, e: Vec3, e_dot: Vec3, state: PyTree) -> Vec3:
        """$s$ (or $s_g$) at `t`."""
        if isinstance(self.surface, GlobalSurface):
            return self.surface(state, t, e, e_dot)
        return self.surface(e, e_dot)

    def __call__(self, t: RealScalarLike, e: Vec3, e_dot: Vec3, state):
        s = self.sliding_variable(t, e, e_dot, state)
        if isinstance(self.surface, GlobalSurface):
            h_dot = self.surface.error_term_rate(state, t, e, e_dot)
            state_dot = jax.tree_util.tree_map(jnp.zeros_like, state)
        else:
            h_dot = self.surface.error_term_rate(e, e_dot)
            state_dot = None
        return self.reaching_law.rate(s) - h_dot, state_dot

    def signals(self, t: RealScalarLike, e: Vec3, e_dot: Vec3, state) -> dict[str, Array]:
        return {"s": self.sliding_variable(t, e, e_dot, state)}


class FeedbackLinearization(AbstractController):
    r"""$M = A(x)^{-1}(v - b(x))$, $v = \ddot y_d + a(e, \dot e)$ (module docstring).

    **Arguments:**
    - `inertia`: the inertia $J$ the law knows, symmetric positive definite (3, 3) [kg m^2].
    - `outer`: an [`AbstractDecoupledLaw`][] giving $a$.
    - `gimbal_margin`: $\cos\theta$ is floored in magnitude at this value inside $R$ so the
      law stays finite (exact for $|\cos\theta| \ge$ it); default 1e-6.

    Reads an `EulerAngleState` and an [`jaxatt.references.EulerAngleCommand`][] (from
    [`jaxatt.references.EulerAngleTrajectory`][]). With the plant's own inertia and no
    disturbance, $\ddot y = v$ exactly. **Signals:** `v` (3,) [rad/s^2] and the outer law's.
    """

    inertia: Mat33
    outer: AbstractDecoupledLaw
    gimbal_margin: Float[Array, ""]
    measurement_type: ClassVar[type] = EulerAngleState
    reference_type: ClassVar[type] = EulerAngleCommand

    def __init__(
        self,
        inertia: Float[ArrayLike, "3 3"],
        outer: AbstractDecoupledLaw,
        *,
        gimbal_margin: RealScalarLike = 1e-6,
    ):
        where = "FeedbackLinearization"
        self.inertia = check_spd(where, "inertia", inertia)
        if not isinstance(outer, AbstractDecoupledLaw):
            raise TypeError(
                f"{where}: `outer` must be an AbstractDecoupledLaw (DecoupledPD, "
                f"DecoupledSlidingMode, ...), got {type(outer).__name__}."
            )
        self.outer = outer
        self.gimbal_margin = check_in_open_interval(
            where, "gimbal_margin", check_scalar(where, "gimbal_margin", gimbal_margin), 0.0, 1.0
        )

    def output_errors(
        self, measurement: EulerAngleState, reference: EulerAngleCommand
    ) -> tuple[Vec3, Vec3]:
        r"""$e = y - y_d$ [rad], $\dot e = R\omega - \dot y_d$ [rad/s]."""
        rates = euler321_kinematics(measurement.angles, measurement.omega, self.gimbal_margin)
        return measurement.angles - reference.angles, rates - reference.rates

    def torque(self, measurement: EulerAngleState, v: Vec3) -> Vec3:
        r"""$M = J R^{-1}(v - b(x))$ [N m], the torque that makes $\ddot y = v$."""
        drift = decoupling_drift(
            self.inertia, measurement.angles, measurement.omega, self.gimbal_margin
        )
        return self.inertia @ euler321_body_rates(measurement.angles, v - drift)

    def init(self, t0: RealScalarLike, measurement: EulerAngleState, reference):
        e, e_dot = self.output_errors(measurement, reference)
        return self.outer.init(t0, e, e_dot)

    def _v(self, t, measurement, reference, state):
        e, e_dot = self.output_errors(measurement, reference)
        a, state_dot = self.outer(t, e, e_dot, state)
        return reference.accelerations + a, state_dot

    def __call__(
        self,
        t: RealScalarLike,
        measurement: EulerAngleState,
        reference: EulerAngleCommand,
        state: PyTree[Array],
    ) -> tuple[Vec3, PyTree[Array]]:
        v, state_dot = self._v(t, measurement, reference, state)
        return self.torque(measurement, v), state_dot

    def signals(
        self,
        t: RealScalarLike,
        measurement: EulerAngleState,
        reference: EulerAngleCommand,
        state: PyTree[Array],
    ) -> dict[str, Array]:
        e, e_dot = self.output_errors(measurement, reference)
        v, _ = self._v(t, measurement, reference, state)
        return {"v": v, **self.outer.signals(t, e, e_dot, state)}
