r"""Chen et al. (2022) controller M1 in closed loop, written from the equations (not jaxatt code).

Independent reference implementations for `bench_montecarlo.py`: the closed-loop vector field
of SPEC.md seed 000 in scalar components, written **once** against a small array namespace
`xp` ([`Namespace`][]), so that the same lines run

- on NumPy arrays of shape `(batch,)`, one per state component (struct of arrays), in a
  batch-vectorised classic RK4 ([`numpy_rk4`][]);
- on `jax.numpy` arrays inside one jitted `jax.lax.scan` ([`make_hand_scan`][]): the floor
  of what XLA can do with this vector field (batch axis innermost, everything elementwise;
  DESIGN.md, performance notes);
- on Python floats, as the right-hand side of SciPy's `solve_ivp` for one trajectory
  ([`scipy_trajectory`][]).

Only the constants of the scenario are copied (`jaxatt.scenarios.chen2022_two_phase_power`
and `_xia2011`); `bench_montecarlo.py` checks them against the jaxatt closed loop.

**The closed loop** (SI units: rad, rad/s, N m, kg m^2, s). State
$y = (q, \omega, q_d)$: body attitude quaternion $q = [q_0, q_v]$ (Hamilton, scalar first,
body relative to inertial), body rate $\omega$ [rad/s], desired attitude $q_d$.

- Reference (erratum E11): $q_d(0) = [1, 0, 0, 0]$,
  $\dot q_d = \tfrac12 q_d \otimes [0, \omega_d]$,
  $\omega_{d,i}(t) = 0.05 \sin(f_i t)$ rad/s with $f = \pi [0.01, 0.02, 0.03]$ rad/s and
  $\dot\omega_{d,i} = 0.05 f_i \cos(f_i t)$ rad/s^2.
- Errors (eqs. 7-10): $e = q_d^* \otimes q$, i.e. $e_0 = q_{d0} q_0 + q_{dv}\cdot q_v$,
  $e_v = q_{d0} q_v - q_0 q_{dv} - q_{dv} \times q_v$;
  $C(e) = (e_0^2 - e_v\cdot e_v) I + 2 e_v e_v^T - 2 e_0 [e_v\times]$ (desired frame to body
  frame; equal to eq. (10) for a unit $e$); $\omega_r = C\omega_d$, $e_\omega = \omega - \omega_r$.
- Surface (14): $s = e_\omega + \lambda e_v$, with
  $\dot e_v = \tfrac12(e_0 e_\omega + e_v \times e_\omega)$ (eq. 12).
- Two-phase power law (15)-(16), per axis:
  $r_i = -\rho s_i - \eta |s_i|^{a_i}\operatorname{sgn}(s_i)$, $a_i = p_1/q_1$ if $|s_i| \ge 1$
  else $q_2/p_2$; $\operatorname{sgn}(0) = 0$.
- Norm robust term (41): $\nu = \sigma^2 s / (\sigma\|s\| + \epsilon)$.
- Equivalent control with the nominal inertia $J_0$ (41, E3):
  $u_{cmd} = J_0(r - F - \lambda\dot e_v - \nu)$ with
  $F = -J_0^{-1}\omega\times J_0\omega + e_\omega\times\omega_r - C\dot\omega_d$, computed here as
  $u_{cmd} = \omega \times J_0\omega + J_0(r - e_\omega\times\omega_r + C\dot\omega_d
  - \lambda\dot e_v - \nu)$ (the product $J_0 J_0^{-1}$ cancelled: equal up to rounding).
- Actuator: $u_i = \min(30, \max(-30, u_{cmd,i}))$ N m.
- Plant (1)-(3): $\dot q = \tfrac12 q \otimes [0, \omega]$,
  $J(t)\dot\omega = -\omega \times J(t)\omega + u + d(t)$ with
  $J(t) = J_0 + \mathrm{diag}(\sin 0.1t, 2\sin 0.2t, 3\sin 0.3t)$ kg m^2 (no $\dot J$ term) and
  $d(t) = [0.1\sin 0.1t, 0.2\sin 0.2t, 0.3\sin 0.3t]$ N m; $J(t)^{-1}$ by the adjugate.

Quantities that depend on time only ($J(t)^{-1}$, $d$, $\omega_d$, $\dot\omega_d$) and the
reference $q_d$ (the same for every sample) are scalars shared by the batch, as they are under
`jax.vmap` over initial states; everything else is elementwise on `(batch,)` arrays.
"""

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np


# ---------------------------------------------------------------------------------------------
# Constants of the scenario (SPEC.md 000.4; checked against jaxatt by bench_montecarlo.py).

J0 = ((20.0, 1.2, 0.9), (1.2, 17.0, 1.4), (0.9, 1.4, 15.0))  # nominal inertia [kg m^2]
DJ_AMPLITUDE = (1.0, 2.0, 3.0)  # Delta J(t) = diag(a_i sin(f_i t)) [kg m^2]
DJ_FREQUENCY = (0.1, 0.2, 0.3)  # [rad/s]
D_AMPLITUDE = (0.1, 0.2, 0.3)  # d_i(t) = a_i sin(f_i t) [N m]
D_FREQUENCY = (0.1, 0.2, 0.3)  # [rad/s]
WD_AMPLITUDE = 0.05  # omega_d,i(t) = 0.05 sin(f_i t) [rad/s]
WD_FREQUENCY = (0.01 * math.pi, 0.02 * math.pi, 0.03 * math.pi)  # [rad/s]
QD0 = (1.0, 0.0, 0.0, 0.0)  # q_d(0)
SLOPE = 5.0  # lambda [1/s]
RHO = 1.2  # [1/s]
ETA = 1.2
BETA = 31 / 11  # p1/q1, exponent for |s_i| >= 1
ALPHA = 5 / 9  # q2/p2, exponent for |s_i| < 1
SIGMA = 0.35  # robust term gain [rad/s^2]
EPS = 0.01  # robust term boundary
LIMIT = 30.0  # per-axis torque limit [N m]

STATE_NAMES = ("q0", "q1", "q2", "q3", "w1", "w2", "w3", "qd0", "qd1", "qd2", "qd3")
"""Order of the state components in the tuples used below."""


# ---------------------------------------------------------------------------------------------
# The array namespace.


@dataclasses.dataclass(frozen=True)
class Namespace:
    """The elementwise functions the vector field uses, for one array library and dtype.

    `sin`, `cos` act on the time (a scalar); `sqrt`, `abs`, `sign`, `where`, `clip` on the
    batch components; `const` turns a Python float into a scalar of the working dtype where a
    weakly typed Python float would not keep it (the exponent selected by `where`).
    """

    sin: Callable
    cos: Callable
    sqrt: Callable
    abs: Callable
    sign: Callable
    where: Callable
    clip: Callable
    const: Callable


def array_namespace(xp: Any, dtype: Any) -> Namespace:
    """The namespace of `numpy` or `jax.numpy` (`xp`) in `dtype` (float64 or float32)."""
    dtype = np.dtype(dtype)

    def clip(x, limit):
        return xp.clip(x, -limit, limit)

    def const(x):
        return xp.asarray(x, dtype=dtype)

    return Namespace(xp.sin, xp.cos, xp.sqrt, xp.abs, xp.sign, xp.where, clip, const)


def _scalar_sign(x: float) -> float:
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


SCALAR = Namespace(
    sin=math.sin,
    cos=math.cos,
    sqrt=math.sqrt,
    abs=abs,
    sign=_scalar_sign,
    where=lambda condition, a, b: a if condition else b,
    clip=lambda x, limit: min(limit, max(-limit, x)),
    const=float,
)
"""Python floats and `math`: the fastest right-hand side CPython offers SciPy."""


# ---------------------------------------------------------------------------------------------
# The closed-loop vector field.


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _matvec(m, v):
    return tuple(row[0] * v[0] + row[1] * v[1] + row[2] * v[2] for row in m)


def time_terms(xp: Namespace, t):
    r"""The quantities that depend on $t$ [s] only, shared by the batch.

    **Returns:** `(inertia, jinv, d, wd, wd_dot)`: the entries of $J(t)$ [kg m^2] and of
    $J(t)^{-1}$ (adjugate over determinant) [1/(kg m^2)], $d(t)$ [N m], $\omega_d(t)$ [rad/s],
    $\dot\omega_d(t)$ [rad/s^2].
    """
    (a, b, c), (d_, e, f), (g, h, i) = J0
    a = a + DJ_AMPLITUDE[0] * xp.sin(DJ_FREQUENCY[0] * t)
    e = e + DJ_AMPLITUDE[1] * xp.sin(DJ_FREQUENCY[1] * t)
    i = i + DJ_AMPLITUDE[2] * xp.sin(DJ_FREQUENCY[2] * t)
    adj = (
        (e * i - f * h, c * h - b * i, b * f - c * e),
        (f * g - d_ * i, a * i - c * g, c * d_ - a * f),
        (d_ * h - e * g, b * g - a * h, a * e - b * d_),
    )
    det = a * adj[0][0] + b * adj[1][0] + c * adj[2][0]
    jinv = tuple(tuple(x / det for x in row) for row in adj)
    inertia = ((a, b, c), (d_, e, f), (g, h, i))
    d = tuple(amp * xp.sin(freq * t) for amp, freq in zip(D_AMPLITUDE, D_FREQUENCY))
    wd = tuple(WD_AMPLITUDE * xp.sin(freq * t) for freq in WD_FREQUENCY)
    wd_dot = tuple(WD_AMPLITUDE * freq * xp.cos(freq * t) for freq in WD_FREQUENCY)
    return inertia, jinv, d, wd, wd_dot


def tracking_control(xp: Namespace, t, y: tuple, wd, wd_dot) -> tuple:
    r"""M1's commanded torque $u_{cmd}$ [N m] (before saturation) and the sliding variable $s$.

    **Arguments:** `xp`, `t`, `y` as in [`vector_field`][]; `wd`, `wd_dot`: $\omega_d(t)$
    [rad/s] and $\dot\omega_d(t)$ [rad/s^2] from [`time_terms`][].

    **Returns:** `(u_cmd, s)`, two 3-tuples of components.
    """
    q0, q1, q2, q3, w1, w2, w3, qd0, qd1, qd2, qd3 = y
    qv, w, qdv = (q1, q2, q3), (w1, w2, w3), (qd1, qd2, qd3)

    # Error quaternion e = qd* (x) q and C(e) applied to wd and wd_dot.
    e0 = qd0 * q0 + _dot(qdv, qv)
    qd_x_q = _cross(qdv, qv)
    ev = tuple(qd0 * qv[k] - q0 * qdv[k] - qd_x_q[k] for k in range(3))
    c_diag = e0 * e0 - _dot(ev, ev)

    def dcm(v):  # C(e) v = (e0^2 - ev.ev) v + 2 (ev.v) ev - 2 e0 ev x v
        ev_v = 2 * _dot(ev, v)
        ev_x_v = _cross(ev, v)
        return tuple(c_diag * v[k] + ev_v * ev[k] - 2 * e0 * ev_x_v[k] for k in range(3))

    wr = dcm(wd)  # desired rate in body components
    wr_dot = dcm(wd_dot)  # C(e) wd_dot
    ew = tuple(w[k] - wr[k] for k in range(3))
    ev_x_ew = _cross(ev, ew)
    ev_dot = tuple(0.5 * (e0 * ew[k] + ev_x_ew[k]) for k in range(3))
    s = tuple(ew[k] + SLOPE * ev[k] for k in range(3))

    # Two-phase power reaching law (one pow per axis), norm robust term.
    alpha, beta = xp.const(ALPHA), xp.const(BETA)
    reach = []
    for sk in s:
        abs_s = xp.abs(sk)
        power = abs_s ** xp.where(abs_s >= 1, beta, alpha)
        reach.append(-RHO * sk - ETA * xp.sign(sk) * power)
    robust_scale = SIGMA * SIGMA / (SIGMA * xp.sqrt(_dot(s, s)) + EPS)

    # u_cmd = w x J0 w + J0 (r - ew x wr + C wd_dot - lambda ev_dot - nu).
    ew_x_wr = _cross(ew, wr)
    bracket = tuple(
        reach[k] - ew_x_wr[k] + wr_dot[k] - SLOPE * ev_dot[k] - robust_scale * s[k]
        for k in range(3)
    )
    gyro_nominal = _cross(w, _matvec(J0, w))
    j0_bracket = _matvec(J0, bracket)
    return tuple(gyro_nominal[k] + j0_bracket[k] for k in range(3)), s


def vector_field(xp: Namespace, t, y: tuple) -> tuple:
    r"""$\dot y$ of the M1 closed loop (module docstring) for the components `y`.

    **Arguments:**
    - `xp`: a [`Namespace`][] (NumPy, `jax.numpy` or [`SCALAR`][]).
    - `t`: time [s], a scalar.
    - `y`: the 11 components in the order of [`STATE_NAMES`][]; arrays of one shape (the
      batch) or scalars; $q_d$ may be scalars shared by a batch.

    **Returns:** the 11 derivatives, in the same order.
    """
    q0, q1, q2, q3, w1, w2, w3, qd0, qd1, qd2, qd3 = y
    qv, w, qdv = (q1, q2, q3), (w1, w2, w3), (qd1, qd2, qd3)
    inertia, jinv, dist, wd, wd_dot = time_terms(xp, t)

    # Reference kinematics: qd_dot = 1/2 qd (x) [0, wd].
    qd_x_wd = _cross(qdv, wd)
    dqd0 = -0.5 * _dot(qdv, wd)
    dqdv = tuple(0.5 * (qd0 * wd[k] + qd_x_wd[k]) for k in range(3))

    # Control, saturated per axis.
    u_cmd, _ = tracking_control(xp, t, y, wd, wd_dot)
    u = tuple(xp.clip(uk, LIMIT) for uk in u_cmd)

    # Plant: q_dot = 1/2 q (x) [0, w]; J(t) w_dot = -w x J(t) w + u + d(t).
    qv_x_w = _cross(qv, w)
    dq0 = -0.5 * _dot(qv, w)
    dqv = tuple(0.5 * (q0 * w[k] + qv_x_w[k]) for k in range(3))
    w_x_h = _cross(w, _matvec(inertia, w))
    rhs = tuple(-w_x_h[k] + u[k] + dist[k] for k in range(3))
    dw = _matvec(jinv, rhs)
    return (dq0, *dqv, *dw, dqd0, *dqdv)


def rk4_step(xp: Namespace, t, dt, y: tuple) -> tuple:
    """One classic RK4 step of [`vector_field`][] from `t` [s] with step `dt` [s].

    Stages at t, t + dt/2, t + dt/2, t + dt; the update is y + dt (k1 + 2 k2 + 2 k3 + k4) / 6.
    """
    half = 0.5 * dt

    def axpy(h, k):
        return tuple(yi + h * ki for yi, ki in zip(y, k))

    k1 = vector_field(xp, t, y)
    k2 = vector_field(xp, t + half, axpy(half, k1))
    k3 = vector_field(xp, t + half, axpy(half, k2))
    k4 = vector_field(xp, t + dt, axpy(dt, k3))
    return tuple(
        yi + dt * ((a + 2 * b + 2 * c + d) / 6) for yi, a, b, c, d in zip(y, k1, k2, k3, k4)
    )


def initial_components(q, omega, asarray, dtype) -> tuple:
    """The 11 components from a batch `q` (n, 4), `omega` (n, 3) [rad/s] and $q_d(0)$.

    `asarray` is `numpy.asarray` or `jax.numpy.asarray`. $q_d$ is the same for every sample,
    so its components are 0-d scalars shared by the batch (as under `jax.vmap`, where the
    reference state stays unbatched).
    """
    plant = tuple(asarray(q[:, k], dtype=dtype) for k in range(4)) + tuple(
        asarray(omega[:, k], dtype=dtype) for k in range(3)
    )
    return plant + tuple(asarray(x, dtype=dtype) for x in QD0)


def stack_components(y: tuple, n: int) -> np.ndarray:
    """The components as one NumPy array of shape (n, 11) (shared scalars broadcast)."""
    return np.stack([np.broadcast_to(np.asarray(c), (n,)) for c in y], axis=-1)


# ---------------------------------------------------------------------------------------------
# NumPy: batch-vectorised RK4.


def numpy_rk4(q, omega, n_steps: int, dt: float, *, dtype=np.float64, t0: float = 0.0):
    """Classic RK4 over a batch with NumPy, struct of arrays.

    **Arguments:** `q` (n, 4) and `omega` (n, 3) initial states [-, rad/s]; `n_steps` steps
    of `dt` [s] from `t0`; `dtype` of the computation (float64 or float32).

    **Returns:** the final state as an (n, 11) array (columns [`STATE_NAMES`][]).
    """
    dtype = np.dtype(dtype)
    xp = array_namespace(np, dtype)
    q, omega = np.asarray(q), np.asarray(omega)
    y = initial_components(q, omega, np.asarray, dtype)
    # q_d as NumPy scalars of the working dtype (cheaper in the interpreter than 0-d arrays).
    y = y[:7] + tuple(dtype.type(c) for c in y[7:])
    for i in range(n_steps):
        t = dtype.type(t0 + i * dt)
        y = rk4_step(xp, t, dt, y)
    return stack_components(y, q.shape[0])


# ---------------------------------------------------------------------------------------------
# JAX: the same code under jax.numpy in one lax.scan ("hand scan").


def make_hand_scan(n_steps: int, dt: float, dtype, *, t0: float = 0.0):
    """A jitted `run(q, omega) -> (n, 11)` final state: RK4 under `jax.numpy` in a `lax.scan`.

    The time of step `i` is `t0 + i * dt` rounded to `dtype`, as jaxatt's `simulate` does.
    """
    import jax
    import jax.numpy as jnp

    dtype = np.dtype(dtype)
    xp = array_namespace(jnp, dtype)

    @jax.jit
    def run(q, omega):
        y = initial_components(q, omega, jnp.asarray, dtype)

        def body(y, i):
            t = jnp.asarray(t0 + i * dt, dtype=dtype)
            return rk4_step(xp, t, dt, y), None

        y, _ = jax.lax.scan(body, y, jnp.arange(n_steps))
        return jnp.stack([jnp.broadcast_to(c, (q.shape[0],)) for c in y], axis=-1)

    return run


# ---------------------------------------------------------------------------------------------
# SciPy: one trajectory with solve_ivp.

SCIPY_OPTIONS = {"method": "RK45", "rtol": 1e-8, "atol": 1e-10}


def scipy_rhs(t: float, y: np.ndarray) -> list:
    """`solve_ivp` right-hand side: [`vector_field`][] on Python floats."""
    return list(vector_field(SCALAR, t, tuple(y.tolist())))


def scipy_trajectory(q0, omega0, t1: float, *, t0: float = 0.0, **options):
    """Integrate one trajectory from `q0` (4,), `omega0` (3,) [rad/s] over [t0, t1] [s].

    `solve_ivp` with [`SCIPY_OPTIONS`][] (RK45, rtol 1e-8, atol 1e-10) unless overridden, in
    float64. **Returns:** `(y1, stats)`: the final state (11,) (columns [`STATE_NAMES`][]) and
    `{"nfev", "steps"}` (evaluations, accepted steps).
    """
    from scipy.integrate import solve_ivp

    y0 = np.concatenate([np.asarray(q0, np.float64), np.asarray(omega0, np.float64), QD0])
    sol = solve_ivp(scipy_rhs, (t0, t1), y0, **{**SCIPY_OPTIONS, **options})
    if sol.status != 0:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return sol.y[:, -1].copy(), {"nfev": int(sol.nfev), "steps": len(sol.t) - 1}
