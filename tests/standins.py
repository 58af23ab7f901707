"""Stand-in plant families and controllers written against jaxatt's public contracts only.

They exist to prove that the core is general: none of them is in `src/`, and `simulate`,
`monte_carlo` and `tune` run them unchanged.

- [`PointMass`][] + [`TranslationPD`][]: a 3-D double integrator under PD (translation only).
- [`Agents`][] + [`ConsensusPD`][]: three double integrators coupled through a graph
  Laplacian, $u = -k_p (L \\otimes I_3) r - k_d v$ (state arrays with a leading agent axis).
- [`FlexibleBody`][]: a rigid body carrying two modal coordinates (hybrid-coordinate model),
  flown by the existing quaternion sliding-mode controller through its attitude measurement.
- [`FractionalPD`][]: a PD law whose derivative term is a truncated Grunwald-Letnikov
  fractional derivative, with its sample memory in the controller state, advanced by the
  discrete `update` after every completed step.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from jaxatt._validation import check_batched_shape, check_positive, check_tree_finite
from jaxatt.controllers import AbstractController
from jaxatt.metrics import Effort, Peak, SettlingTime
from jaxatt.plants import AbstractPlant, QuaternionState
from jaxatt.references import ConstantAttitude
from jaxatt.rotations import attitude_error_quat, quat_kinematics, rate_error


class TranslationState(eqx.Module):
    """Position `r` [m] and velocity `v` [m/s] (a leading agent axis for networks)."""

    r: Float[Array, "*agents 3"]
    v: Float[Array, "*agents 3"]


def _check_translation(where, state, name, batch_shape, agents=()):
    if not isinstance(state, TranslationState):
        raise ValueError(f"{where}: `{name}` must be a TranslationState(r, v).")
    check_tree_finite(where, name, state)
    shape = (*agents, 3)
    return TranslationState(
        check_batched_shape(where, f"{name}.r", state.r, shape, batch_shape),
        check_batched_shape(where, f"{name}.v", state.v, shape, batch_shape),
    )


class PointMass(AbstractPlant):
    """$\\ddot r = u / m$ (regulation to the origin; `position_error` = r)."""

    mass: Float[Array, ""]
    measurement_type: ClassVar[type] = TranslationState

    def __init__(self, mass):
        self.mass = check_positive("PointMass", "mass", mass)

    def vector_field(self, t, state, control):
        return TranslationState(state.v, control / self.mass)

    def measure(self, t, state):
        return state

    def signals(self, t, state, reference):
        return {"position_error": state.r, "velocity": state.v}

    def check_state(self, state, name="x0", batch_shape=()):
        return _check_translation("PointMass", state, name, batch_shape)

    def default_metrics(self, tolerance):
        return {
            "settling_time": SettlingTime("position_error", tolerance),
            "peak_force": Peak("u"),
            "effort": Effort("u"),
        }


class TranslationPD(AbstractController):
    """$u = -k_p r - k_d v$ (per axis)."""

    kp: Float[Array, ""]
    kd: Float[Array, ""]
    measurement_type: ClassVar[type] = TranslationState

    def __init__(self, kp, kd):
        self.kp = check_positive("TranslationPD", "kp", kp)
        self.kd = check_positive("TranslationPD", "kd", kd)

    def init(self, t0, measurement, reference):
        return None

    def __call__(self, t, measurement, reference, state):
        return -self.kp * measurement.r - self.kd * measurement.v, None


class Agents(AbstractPlant):
    """`n` double integrators $\\ddot r_i = u_i$, state arrays `(n, 3)`.

    `disagreement` = $r_i - \\bar r$ per agent, the signal a consensus protocol drives to 0.
    """

    n: int = eqx.field(static=True)
    measurement_type: ClassVar[type] = TranslationState

    def vector_field(self, t, state, control):
        return TranslationState(state.v, control)

    def measure(self, t, state):
        return state

    def signals(self, t, state, reference):
        mean = jnp.mean(state.r, axis=0, keepdims=True)
        return {"disagreement": state.r - mean, "velocity": state.v}

    def check_state(self, state, name="x0", batch_shape=()):
        return _check_translation("Agents", state, name, batch_shape, (self.n,))


class ConsensusPD(AbstractController):
    """$u = -k_p (L \\otimes I_3) r - k_d v$ with a graph Laplacian $L$ (rows sum to 0)."""

    laplacian: Float[Array, "n n"]
    kp: Float[Array, ""]
    kd: Float[Array, ""]
    measurement_type: ClassVar[type] = TranslationState

    def __init__(self, laplacian, kp, kd):
        laplacian = jnp.asarray(laplacian, dtype=jnp.result_type(float))
        if not np.allclose(np.asarray(laplacian).sum(axis=1), 0):
            raise ValueError("ConsensusPD: `laplacian` rows must sum to 0.")
        self.laplacian = laplacian
        self.kp = check_positive("ConsensusPD", "kp", kp)
        self.kd = check_positive("ConsensusPD", "kd", kd)

    def init(self, t0, measurement, reference):
        return None

    def __call__(self, t, measurement, reference, state):
        return -self.kp * (self.laplacian @ measurement.r) - self.kd * measurement.v, None


class FlexibleState(eqx.Module):
    """Attitude `q`, body rate `omega` and two modal coordinates `eta` with rates `eta_dot`."""

    q: Float[Array, "4"]
    omega: Float[Array, "3"]
    eta: Float[Array, "2"]
    eta_dot: Float[Array, "2"]


class FlexibleBody(AbstractPlant):
    r"""A rigid hub with two flexible modes (hybrid coordinates):

    $$J\dot\omega + \delta^T\ddot\eta = -\omega\times(J\omega + \delta^T\dot\eta) + u,\qquad
    \ddot\eta + 2\zeta\Omega\dot\eta + \Omega^2\eta + \delta\dot\omega = 0,$$

    solved for $(\dot\omega, \ddot\eta)$ with the coupled mass matrix
    $\begin{bmatrix} J & \delta^T\\ \delta & I\end{bmatrix}$. It measures only its attitude
    and rate (`QuaternionState`), so quaternion attitude controllers fly it unchanged.
    """

    inertia: Float[Array, "3 3"]
    coupling: Float[Array, "2 3"]
    frequencies: Float[Array, "2"]
    damping: Float[Array, "2"]
    measurement_type: ClassVar[type] = QuaternionState

    def vector_field(self, t, state, control):
        mass = jnp.block([[self.inertia, self.coupling.T], [self.coupling, jnp.eye(2)]])
        momentum = self.inertia @ state.omega + self.coupling.T @ state.eta_dot
        rhs = jnp.concatenate(
            [
                -jnp.cross(state.omega, momentum) + control,
                -2 * self.damping * self.frequencies * state.eta_dot
                - self.frequencies**2 * state.eta,
            ]
        )
        accel = jnp.linalg.solve(mass, rhs)
        return FlexibleState(
            quat_kinematics(state.q, state.omega), accel[:3], state.eta_dot, accel[3:]
        )

    def measure(self, t, state):
        return QuaternionState(state.q, state.omega)

    def signals(self, t, state, reference):
        e = attitude_error_quat(state.q, reference.q_d)
        return {
            "attitude_error": e,
            "attitude_error_vector": e[1:],
            "rate_error": rate_error(e, state.omega, reference.omega_d),
            "modal_displacement": state.eta,
        }

    def check_state(self, state, name="x0", batch_shape=()):
        if not isinstance(state, FlexibleState):
            raise ValueError(f"FlexibleBody: `{name}` must be a FlexibleState.")
        check_tree_finite("FlexibleBody", name, state)
        return state

    def default_reference(self):
        return ConstantAttitude()


def grunwald_letnikov_weights(alpha: Array, n: int) -> Array:
    """$w_0 = 1$, $w_j = w_{j-1}(1 - (\\alpha + 1)/j)$ (differentiable in alpha)."""
    j = jnp.arange(1, n, dtype=jnp.result_type(alpha))
    return jnp.concatenate([jnp.ones(1, j.dtype), jnp.cumprod(1 - (alpha + 1) / j)])


class FractionalPD(AbstractController):
    r"""$u = -k_p r - k_d D^\alpha r$, $D^\alpha r(t) \approx h^{-\alpha}\sum_{j<N} w_j\,
    r(t - jh)$ (truncated Grunwald-Letnikov, memory $N$ samples at the step $h$).

    The state holds the positions of the last $N$ completed steps, newest first (entry 0 is
    the start of the current step, $t_k$). The sum takes the current position for $j = 0$ (so
    RK4's stages see it) and the stored $r(t_k - jh)$ for $j \ge 1$.
    """

    kp: Float[Array, ""]
    kd: Float[Array, ""]
    alpha: Float[Array, ""]
    step: float = eqx.field(static=True)
    memory: int = eqx.field(static=True)
    measurement_type: ClassVar[type] = TranslationState

    def __init__(self, kp, kd, alpha, step: float, memory: int):
        self.kp = check_positive("FractionalPD", "kp", kp)
        self.kd = check_positive("FractionalPD", "kd", kd)
        self.alpha = check_positive("FractionalPD", "alpha", alpha)
        self.step = float(step)
        self.memory = int(memory)

    def init(self, t0, measurement, reference):
        # Before t0 the position is taken as constant (a Caputo-like start).
        return jnp.broadcast_to(measurement.r, (self.memory, 3))

    def derivative(self, measurement, history):
        samples = jnp.concatenate([measurement.r[None], history[1:]], axis=0)
        weights = grunwald_letnikov_weights(self.alpha, self.memory)
        return self.step ** (-self.alpha) * weights @ samples

    def __call__(self, t, measurement, reference, state):
        u = -self.kp * measurement.r - self.kd * self.derivative(measurement, state)
        return u, jnp.zeros_like(state)  # the memory changes only in `update`

    def update(self, t, measurement, reference, state):
        return jnp.concatenate([measurement.r[None], state[:-1]], axis=0)

    def signals(self, t, measurement, reference, state):
        return {"fractional_derivative": self.derivative(measurement, state)}
