r"""Random draws for Monte Carlo studies: attitudes, rates, inertias, disturbance signals.

Every sampler takes an explicit key and a Python integer `n` (a static shape) and returns a
batch with a leading axis of length `n`, ready for [`monte_carlo`][] or `jax.vmap`. They are
pure JAX functions (jit-able with `n` static), draw in JAX's default float dtype (float64 when
x64 is enabled) unless an array argument fixes another, and never touch global random state.
The same key always gives the same batch; different keys give independent batches.
"""

import functools as ft
import numbers

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, ArrayLike, Float, PRNGKeyArray

from .._custom_types import RealScalarLike
from .._validation import (
    check,
    check_nonnegative,
    check_positive,
    check_spd,
    check_unit_quaternion,
)
from ..plants import MRPState, QuaternionState
from ..rotations import mrp_from_quat, quat_multiply, quat_to_dcm
from ..signals import Sinusoid


NEWTON_STEPS = 5
"""Newton iterations inverting the restricted Haar angle CDF (converged to ~1e-15 in float64
after 4 for every angle limit in (0, pi]; one more for margin)."""


def _check_count(where: str, n) -> int:
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
        raise ValueError(
            f"{where}: `n` must be a positive Python integer (it is a static shape), got n={n!r}."
        )
    return int(n)


def _float_dtype(*values) -> jnp.dtype:
    dtypes = [jnp.asarray(v).dtype for v in values if v is not None]
    floating = [d for d in dtypes if jnp.issubdtype(d, jnp.floating)]
    return jnp.result_type(*floating) if floating else jnp.result_type(float)


def uniform_attitudes(key: PRNGKeyArray, n: int) -> Float[Array, "n 4"]:
    r"""`n` attitudes drawn from the uniform (Haar) distribution on SO(3).

    Shoemake's subgroup algorithm: with $u_1, u_2, u_3 \sim U[0, 1)$ independent,

    $$q = \big[\sqrt{u_1}\cos 2\pi u_3,\ \sqrt{1-u_1}\sin 2\pi u_2,\
    \sqrt{1-u_1}\cos 2\pi u_2,\ \sqrt{u_1}\sin 2\pi u_3\big]$$

    is uniform on the unit sphere $S^3$, hence Haar-uniform on SO(3). Returned canonical
    ($q_0 \ge 0$, the short rotation). The rotation angle $\phi = 2\arccos q_0$ then has density
    $(1 - \cos\phi)/\pi$ on $[0, \pi]$, and the mean of every component $q_1, q_2, q_3$ is 0.

    **Arguments:**
    - `key`: a JAX PRNG key.
    - `n`: number of draws (a Python int, static).

    **Returns:** unit quaternions, shape `(n, 4)`, scalar first.
    """
    return _uniform_attitudes(key, _check_count("uniform_attitudes", n))


@ft.partial(jax.jit, static_argnums=1)
def _uniform_attitudes(key: PRNGKeyArray, n: int) -> Array:
    u1, u2, u3 = jr.uniform(key, (3, n))
    q = jnp.stack(
        [
            jnp.sqrt(u1) * jnp.cos(2 * jnp.pi * u3),
            jnp.sqrt(1 - u1) * jnp.sin(2 * jnp.pi * u2),
            jnp.sqrt(1 - u1) * jnp.cos(2 * jnp.pi * u2),
            jnp.sqrt(u1) * jnp.sin(2 * jnp.pi * u3),
        ],
        axis=-1,
    )
    return jnp.where(q[:, :1] < 0, -q, q)


def _versine_integral(theta: Array) -> Array:
    r"""$h(\theta) = \theta - \sin\theta$, by its Taylor series below 0.5 (no cancellation)."""
    t2 = theta * theta
    series = (
        theta
        * t2
        / 6
        * (1 - t2 / 20 * (1 - t2 / 42 * (1 - t2 / 72 * (1 - t2 / 110 * (1 - t2 / 156)))))
    )
    return jnp.where(theta < 0.5, series, theta - jnp.sin(theta))


def _restricted_haar_angles(key: PRNGKeyArray, n: int, max_angle: Array) -> Array:
    """Angles in [0, max_angle] (<= pi) with density proportional to 1 - cos(theta)."""
    u = jr.uniform(key, (n,), dtype=max_angle.dtype)
    target = u * _versine_integral(max_angle)
    # h(theta) <= theta^3 / 6, so the cube root starts at or left of the root; h is convex on
    # [0, pi], so after the first Newton step the iterates approach the root from the right.
    theta = jnp.clip(jnp.cbrt(6 * target), 0, max_angle)
    for _ in range(NEWTON_STEPS):
        slope = 2 * jnp.sin(theta / 2) ** 2  # 1 - cos(theta) without cancellation
        ok = slope > 0
        step = jnp.where(ok, (_versine_integral(theta) - target) / jnp.where(ok, slope, 1), 0)
        theta = jnp.clip(theta - step, 0, max_angle)
    return theta


def _unit_vectors(key: PRNGKeyArray, n: int, dtype) -> Array:
    """Uniform directions on the unit sphere (Archimedes: z uniform in [-1, 1])."""
    k_z, k_phi = jr.split(key)
    z = jr.uniform(k_z, (n,), dtype=dtype, minval=-1.0, maxval=1.0)
    phi = jr.uniform(k_phi, (n,), dtype=dtype, minval=0.0, maxval=2 * jnp.pi)
    rho = jnp.sqrt(jnp.maximum(1 - z * z, 0))
    return jnp.stack([rho * jnp.cos(phi), rho * jnp.sin(phi), z], axis=-1)


@ft.partial(jax.jit, static_argnums=1)
def _rotations_within(key: PRNGKeyArray, n: int, max_angle: Array) -> Array:
    k_angle, k_axis = jr.split(key)
    theta = _restricted_haar_angles(k_angle, n, max_angle)
    axis = _unit_vectors(k_axis, n, max_angle.dtype)
    return jnp.concatenate(
        [jnp.cos(theta / 2)[:, None], jnp.sin(theta / 2)[:, None] * axis], axis=-1
    )


def attitudes_within(
    key: PRNGKeyArray,
    n: int,
    max_angle: RealScalarLike,
    nominal: Float[ArrayLike, "4"] | None = None,
) -> Float[Array, "n 4"]:
    r"""`n` attitudes within `max_angle` of `nominal`: the Haar measure restricted to a cone.

    Each draw is $q = q_{nom} \otimes e$, $e = [\cos(\theta/2), \sin(\theta/2)\,\hat n]$, with
    the axis $\hat n$ uniform on the unit sphere and the angle $\theta \in [0, \Theta]$
    ($\Theta$ = `max_angle`) distributed as the uniform distribution on SO(3) conditioned on
    $\theta \le \Theta$:

    $$p(\theta) = \frac{1 - \cos\theta}{\Theta - \sin\Theta}, \qquad
    F(\theta) = \frac{\theta - \sin\theta}{\Theta - \sin\Theta}.$$

    $F^{-1}(u)$ is computed by `NEWTON_STEPS` Newton steps from $\sqrt[3]{6u(\Theta -
    \sin\Theta)}$ ($\theta - \sin\theta$ by its Taylor series below 0.5 rad, so small angles
    keep full relative precision). With $\Theta = \pi$ this is [`uniform_attitudes`][] again
    (rotated by `nominal`). The draws do not concentrate at the nominal: the density grows like
    $\theta^2$, so most lie near the cone's edge (median $\approx 0.79\,\Theta$ for small
    $\Theta$).

    **Arguments:**
    - `key`: a JAX PRNG key.
    - `n`: number of draws (a Python int, static).
    - `max_angle`: $\Theta$ [rad], $0 < \Theta \le \pi$.
    - `nominal`: the unit quaternion at the cone's center; default the identity.

    **Returns:** unit quaternions, shape `(n, 4)`; the rotation angle from `nominal`,
    `quat_angle(quat_multiply(quat_conjugate(nominal), q))`, never exceeds `max_angle`.

    **Gradients:** with respect to `max_angle` through the unrolled Newton steps (finite).
    """
    where = "attitudes_within"
    n = _check_count(where, n)
    max_angle = check(
        where,
        "max_angle",
        max_angle,
        lambda xp, x: xp.isfinite(x) & (x > 0) & (x <= np.pi),
        "must lie in (0, pi] [rad]",
    )
    if max_angle.ndim != 0:
        raise ValueError(f"{where}: `max_angle` must be a scalar, got shape {max_angle.shape}.")
    if nominal is None:
        return _rotations_within(key, n, max_angle)
    nominal = check_unit_quaternion(where, "nominal", nominal).astype(max_angle.dtype)
    return _attitudes_around(key, n, max_angle, nominal)


@ft.partial(jax.jit, static_argnums=1)
def _attitudes_around(key: PRNGKeyArray, n: int, max_angle: Array, nominal: Array) -> Array:
    e = _rotations_within(key, n, max_angle)
    return jax.vmap(quat_multiply, in_axes=(None, 0))(nominal, e)


def _check_bound(where: str, name: str, value: ArrayLike, shapes, *, positive=False) -> Array:
    rule = check_positive if positive else check_nonnegative
    value = rule(where, name, value)
    if value.shape not in shapes:
        raise ValueError(
            f"{where}: `{name}` must have one of the shapes {list(shapes)}, got shape "
            f"{value.shape}."
        )
    return value


def rates_in_box(
    key: PRNGKeyArray, n: int, max_rate: RealScalarLike | Float[ArrayLike, "3"]
) -> Float[Array, "n 3"]:
    r"""`n` angular rates uniform in the box $[-\bar\omega_i, \bar\omega_i]$ per axis.

    **Arguments:**
    - `key`: a JAX PRNG key.
    - `n`: number of draws (a Python int, static).
    - `max_rate`: $\bar\omega \ge 0$ [rad/s], a scalar or one bound per axis, shape `(3,)`.

    **Returns:** rates [rad/s], shape `(n, 3)`, each component independent and uniform.
    """
    where = "rates_in_box"
    n = _check_count(where, n)
    max_rate = _check_bound(where, "max_rate", max_rate, ((), (3,)))
    return _uniform_box(key, (n, 3), max_rate)


@ft.partial(jax.jit, static_argnums=1)
def _uniform_box(key: PRNGKeyArray, shape: tuple[int, ...], bound: Array) -> Array:
    return jr.uniform(key, shape, dtype=bound.dtype, minval=-bound, maxval=bound)


def rates_in_ball(key: PRNGKeyArray, n: int, max_norm: RealScalarLike) -> Float[Array, "n 3"]:
    r"""`n` angular rates uniform in the ball $\|\omega\| \le \bar\omega$.

    $\omega = \bar\omega\, u^{1/3}\, \hat n$ with $u \sim U[0, 1)$ and $\hat n$ uniform on the
    sphere, so $P(\|\omega\| \le r) = (r/\bar\omega)^3$.

    **Arguments:**
    - `key`: a JAX PRNG key.
    - `n`: number of draws (a Python int, static).
    - `max_norm`: $\bar\omega \ge 0$ [rad/s], a scalar.

    **Returns:** rates [rad/s], shape `(n, 3)`.
    """
    where = "rates_in_ball"
    n = _check_count(where, n)
    max_norm = _check_bound(where, "max_norm", max_norm, ((),))
    return _rates_in_ball(key, n, max_norm)


@ft.partial(jax.jit, static_argnums=1)
def _rates_in_ball(key: PRNGKeyArray, n: int, max_norm: Array) -> Array:
    k_r, k_dir = jr.split(key)
    radius = max_norm * jnp.cbrt(jr.uniform(k_r, (n,), dtype=max_norm.dtype))
    return radius[:, None] * _unit_vectors(k_dir, n, max_norm.dtype)


def inertia_dispersion(
    key: PRNGKeyArray,
    n: int,
    inertia: Float[ArrayLike, "3 3"],
    *,
    principal_scale: RealScalarLike,
    max_misalignment: RealScalarLike,
) -> Float[Array, "n 3 3"]:
    r"""`n` inertia matrices dispersed around `inertia`; each is symmetric positive definite.

    With the nominal eigendecomposition $J_0 = V\,\mathrm{diag}(\lambda_1, \lambda_2,
    \lambda_3)\,V^\top$, draw $k$ is

    $$J_k = R_k V\,\mathrm{diag}\big(\lambda_i (1 + \delta_{ik})\big)\,V^\top R_k^\top,$$

    - $\delta_{ik} \sim U[-s, s]$ independent per principal moment ($s$ = `principal_scale`),
    - $R_k$ a rotation drawn as in [`attitudes_within`][] with $\Theta$ = `max_misalignment`:
      axis uniform on the sphere, angle with density $\propto 1 - \cos\theta$ on $[0, \Theta]$
      (the uniform distribution on SO(3) restricted to the cone), independent of the
      $\delta$'s. Every principal axis of $J_k$ is within $\Theta$ of the nominal one.

    Since $s < 1$ the moments stay positive, so every draw is symmetric positive definite by
    construction; its eigenvalues are $\lambda_i(1 + \delta_{ik})$, within
    $[(1 - s)\lambda_i, (1 + s)\lambda_i]$. The output is symmetrized
    ($\tfrac12(J + J^\top)$) so that symmetry is exact in floating point. Triangle inequalities
    of a physical body ($\lambda_i \le \lambda_j + \lambda_k$) are not enforced.

    **Arguments:**
    - `key`: a JAX PRNG key.
    - `n`: number of draws (a Python int, static).
    - `inertia`: the nominal inertia $J_0$ [kg m^2], symmetric positive definite, `(3, 3)`.
    - `principal_scale`: $s \in [0, 1)$, relative half-range of each principal moment.
    - `max_misalignment`: $\Theta \in [0, \pi]$ [rad], largest rotation of the principal
      axes (0 keeps the nominal axes).

    **Returns:** inertias [kg m^2], shape `(n, 3, 3)`.

    **Gradients:** through `jnp.linalg.eigh`, undefined (NaN) with respect to `inertia` when
    two nominal moments are equal; the draws themselves are always valid.
    """
    where = "inertia_dispersion"
    n = _check_count(where, n)
    inertia = check_spd(where, "inertia", inertia)
    scale = check(
        where,
        "principal_scale",
        principal_scale,
        lambda xp, x: xp.isfinite(x) & (x >= 0) & (x < 1),
        "must lie in [0, 1)",
    )
    misalignment = check(
        where,
        "max_misalignment",
        max_misalignment,
        lambda xp, x: xp.isfinite(x) & (x >= 0) & (x <= np.pi),
        "must lie in [0, pi] [rad]",
    )
    for name, value in (("principal_scale", scale), ("max_misalignment", misalignment)):
        if value.ndim != 0:
            raise ValueError(f"{where}: `{name}` must be a scalar, got shape {value.shape}.")
    dtype = _float_dtype(inertia, scale, misalignment)
    return _inertia_dispersion(
        key, n, inertia.astype(dtype), scale.astype(dtype), misalignment.astype(dtype)
    )


@ft.partial(jax.jit, static_argnums=1)
def _inertia_dispersion(
    key: PRNGKeyArray, n: int, inertia: Array, scale: Array, misalignment: Array
) -> Array:
    dtype = inertia.dtype
    moments, axes = jnp.linalg.eigh(0.5 * (inertia + inertia.T))
    k_scale, k_rot = jr.split(key)
    delta = jr.uniform(k_scale, (n, 3), dtype=dtype, minval=-scale, maxval=scale)
    rotations = jax.vmap(quat_to_dcm)(_rotations_within(k_rot, n, misalignment))
    # quat_to_dcm gives C = R^T; the transpose has the same (inversion-symmetric) distribution,
    # so R_k = C_k^T is used as drawn.
    principal_axes = jnp.einsum("nji,jk->nik", rotations, axes)
    j = jnp.einsum(
        "nik,nk,njk->nij", principal_axes, moments[None, :] * (1 + delta), principal_axes
    )
    return 0.5 * (j + jnp.swapaxes(j, -1, -2))


def sinusoid_dispersion(
    key: PRNGKeyArray,
    n: int,
    signal: Sinusoid,
    *,
    amplitude_scale: RealScalarLike,
    phase_spread: RealScalarLike,
) -> Sinusoid:
    r"""`n` copies of a [`jaxatt.plants.Sinusoid`][] with dispersed amplitudes and phases.

    For every element of the signal's (broadcast) shape independently,
    $a_k = a\,(1 + \epsilon_k)$ with $\epsilon_k \sim U[-s_a, s_a]$ and
    $\varphi_k = \varphi + \psi_k$ with $\psi_k \sim U[-s_\varphi, s_\varphi]$; frequency and
    offset are kept. Zero amplitudes stay zero (a diagonal inertia perturbation stays
    diagonal).

    **Arguments:**
    - `key`: a JAX PRNG key.
    - `n`: number of draws (a Python int, static).
    - `signal`: the nominal `Sinusoid` (e.g. Chen 2022's disturbance $d(t)$).
    - `amplitude_scale`: $s_a \ge 0$, relative half-range of each amplitude.
    - `phase_spread`: $s_\varphi \ge 0$ [rad], half-range of each phase shift ($\pi$ draws
      uniform phases).

    **Returns:** a `Sinusoid` whose four fields are stacked, each of shape `(n, *shape)` with
    `shape` the signal's broadcast shape; put it into a closed loop with [`batch_field`][].
    """
    where = "sinusoid_dispersion"
    n = _check_count(where, n)
    if not isinstance(signal, Sinusoid):
        raise ValueError(
            f"{where}: `signal` must be a jaxatt.plants.Sinusoid, got {type(signal).__name__}."
        )
    amplitude_scale = _check_bound(where, "amplitude_scale", amplitude_scale, ((),))
    phase_spread = _check_bound(where, "phase_spread", phase_spread, ((),))
    fields = (signal.amplitude, signal.frequency, signal.phase, signal.offset)
    shape = jnp.broadcast_shapes(*(f.shape for f in fields))
    dtype = _float_dtype(*fields, amplitude_scale, phase_spread)
    fields = tuple(f.astype(dtype) for f in fields)
    return Sinusoid(
        *_sinusoid_dispersion(
            key, (n, *shape), fields, amplitude_scale.astype(dtype), phase_spread.astype(dtype)
        )
    )


@ft.partial(jax.jit, static_argnums=1)
def _sinusoid_dispersion(
    key: PRNGKeyArray,
    shape: tuple[int, ...],
    fields: tuple[Array, Array, Array, Array],
    amplitude_scale: Array,
    phase_spread: Array,
) -> tuple[Array, Array, Array, Array]:
    amplitude, frequency, phase, offset = (jnp.broadcast_to(f, shape) for f in fields)
    k_a, k_p = jr.split(key)
    eps = jr.uniform(
        k_a, shape, dtype=amplitude.dtype, minval=-amplitude_scale, maxval=amplitude_scale
    )
    psi = jr.uniform(k_p, shape, dtype=amplitude.dtype, minval=-phase_spread, maxval=phase_spread)
    return amplitude * (1 + eps), frequency, phase + psi, offset


def mrps_in_ball(key: PRNGKeyArray, n: int, max_norm: RealScalarLike) -> Float[Array, "n 3"]:
    r"""`n` MRPs uniform (in the Euclidean sense) in the ball $\|\sigma\| \le \bar\sigma$.

    $\sigma = \bar\sigma\, u^{1/3}\, \hat n$ with $\hat n$ a normalized Gaussian vector and
    $u \sim U[0, 1)$ (two halves of `jr.split(key)`). Uniform in the MRP coordinates, not in
    SO(3): use [`uniform_attitudes`][] for the Haar measure.

    **Arguments:** `key`, `n` (static), `max_norm` $\bar\sigma > 0$ (an MRP norm
    $\tan(\phi/4)$; 1 is a rotation by $\pi$).

    **Returns:** MRPs, shape `(n, 3)`.
    """
    where = "mrps_in_ball"
    n = _check_count(where, n)
    max_norm = _check_bound(where, "max_norm", max_norm, ((),), positive=True)
    return _mrps_in_ball(key, n, max_norm)


@ft.partial(jax.jit, static_argnums=1)
def _mrps_in_ball(key: PRNGKeyArray, n: int, max_norm: Array) -> Array:
    k_dir, k_radius = jr.split(key)
    return _ball(k_dir, k_radius, n, max_norm)


def _ball(k_dir, k_radius, n: int, max_norm: Array) -> Array:
    direction = jr.normal(k_dir, (n, 3), dtype=max_norm.dtype)
    direction = direction / jnp.linalg.norm(direction, axis=1, keepdims=True)
    return direction * max_norm * jr.uniform(k_radius, (n, 1), dtype=max_norm.dtype) ** (1 / 3)


def _check_ratio(where: str, max_ratio: RealScalarLike) -> Array:
    """`max_ratio`, a scalar in (0, 1] (an array of ratios broadcast against the draws' axes
    and scaled each axis by its own ratio: another law than the documented one)."""
    max_ratio = check(
        where, "max_ratio", max_ratio, lambda xp, x: (x > 0) & (x <= 1), "must lie in (0, 1]"
    )
    if max_ratio.ndim != 0:
        raise ValueError(f"{where}: `max_ratio` must be a scalar, got shape {max_ratio.shape}.")
    return max_ratio


def rates_with_barrier_ratio(
    key: PRNGKeyArray,
    n: int,
    *,
    rate_limit: RealScalarLike,
    exponent: RealScalarLike,
    max_ratio: RealScalarLike,
) -> Float[Array, "n 3"]:
    r"""`n` rates whose barrier ratio $\chi(\omega)/M^p$, $\chi(\omega) = \sum_i|\omega_i|^p$,
    is uniform in $[0, r_{\max})$, along Gaussian directions.

    $\omega = M\, r^{1/p}\, w$ with $w$ a Gaussian vector normalized to $\sum_i |w_i|^p = 1$
    and $r \sim U[0, r_{\max})$ (two halves of `jr.split(key)`), so
    $\chi(\omega) = r M^p$: every draw lies inside the barrier set $\chi < M^p$ of a
    rate-constrained law (e.g. [`jaxatt.controllers.RateConstrainedFiniteTimeMRP`][],
    with $p = 1 + \alpha_2$).

    **Arguments:** `key`, `n` (static); `rate_limit` $M > 0$ [rad/s]; `exponent` $p > 0$;
    `max_ratio` $r_{\max} \in (0, 1]$.

    **Returns:** rates [rad/s], shape `(n, 3)`.
    """
    where = "rates_with_barrier_ratio"
    n = _check_count(where, n)
    rate_limit = _check_bound(where, "rate_limit", rate_limit, ((),), positive=True)
    exponent = _check_bound(where, "exponent", exponent, ((),), positive=True)
    max_ratio = _check_ratio(where, max_ratio)
    k_w, k_r = jr.split(key)
    return _barrier_rates(k_w, k_r, n, rate_limit, exponent, max_ratio)


@ft.partial(jax.jit, static_argnums=2)
def _barrier_rates(k_w, k_r, n: int, rate_limit, exponent, max_ratio) -> Array:
    w = jr.normal(k_w, (n, 3), dtype=rate_limit.dtype)
    w = w / jnp.sum(jnp.abs(w) ** exponent, axis=1, keepdims=True) ** (1 / exponent)
    ratio = max_ratio * jr.uniform(k_r, (n, 1), dtype=rate_limit.dtype)
    return rate_limit * w * ratio ** (1 / exponent)


def barrier_states(
    key: PRNGKeyArray,
    n: int,
    *,
    max_sigma: RealScalarLike,
    rate_limit: RealScalarLike,
    exponent: RealScalarLike,
    max_ratio: RealScalarLike,
) -> MRPState:
    r"""`n` rigid-body states inside a rate barrier: MRPs uniform in the ball
    $\|\sigma\| <$ `max_sigma` ([`mrps_in_ball`][]'s law, `max_sigma` $> 0$) and rates with a
    barrier ratio uniform in $[0,$ `max_ratio`$)$ ([`rates_with_barrier_ratio`][]'s law).

    The four draws use the four keys of `jr.split(key, 4)` (direction, radius, rate
    direction, ratio). The batch of Yu et al. (2022)'s rate-bound Monte Carlo.

    **Returns:** an `MRPState` with leading axis `n`.
    """
    where = "barrier_states"
    n = _check_count(where, n)
    max_sigma = _check_bound(where, "max_sigma", max_sigma, ((),), positive=True)
    rate_limit = _check_bound(where, "rate_limit", rate_limit, ((),), positive=True)
    exponent = _check_bound(where, "exponent", exponent, ((),), positive=True)
    max_ratio = _check_ratio(where, max_ratio)
    k_dir, k_radius, k_w, k_r = jr.split(key, 4)
    sigma = _jit_ball(k_dir, k_radius, n, max_sigma)
    return MRPState(sigma, _barrier_rates(k_w, k_r, n, rate_limit, exponent, max_ratio))


_jit_ball = jax.jit(_ball, static_argnums=2)


def quaternion_states(
    key: PRNGKeyArray,
    n: int,
    *,
    max_rate: RealScalarLike | Float[ArrayLike, "3"],
    max_angle: RealScalarLike | None = None,
) -> QuaternionState:
    r"""`n` rigid-body states: attitudes Haar-uniform (`max_angle=None`, [`uniform_attitudes`][])
    or within `max_angle` of the identity ([`attitudes_within`][]), rates uniform in the box
    $[-\bar\omega, \bar\omega]^3$ ([`rates_in_box`][]); the two halves of `jr.split(key)`.

    **Returns:** a `QuaternionState` with leading axis `n`.
    """
    k_q, k_w = jr.split(key)
    q = uniform_attitudes(k_q, n) if max_angle is None else attitudes_within(k_q, n, max_angle)
    return QuaternionState(q, rates_in_box(k_w, n, max_rate))


def mrp_states(
    key: PRNGKeyArray,
    n: int,
    *,
    max_rate: RealScalarLike | Float[ArrayLike, "3"],
    max_angle: RealScalarLike | None = None,
) -> MRPState:
    r"""As [`quaternion_states`][], with the attitudes as MRPs (canonical draws, so
    $\|\sigma\| \le 1$).

    **Returns:** an `MRPState` with leading axis `n`.
    """
    states = quaternion_states(key, n, max_rate=max_rate, max_angle=max_angle)
    return MRPState(_mrps_from_quats(states.q), states.omega)


_mrps_from_quats = jax.jit(jax.vmap(mrp_from_quat))
