r"""Exact sampled-data analysis of $\dot g = A\,g(t) + B\,g(t_i)$ (zero-order-held $B$ term).

Over one interval $[t_i, t_i + h]$ the held sample is a constant input, so
$$\exp\!\Big(h\begin{bmatrix}A & B\\ 0 & 0\end{bmatrix}\Big)
= \begin{bmatrix}e^{Ah} & \Gamma(h)\\ 0 & I\end{bmatrix},\quad
\Gamma(h) = \int_0^h e^{As}\,ds\;B,\qquad g(t_{i+1}) = F(h)\,g(t_i),\quad F(h) = e^{Ah} +
\Gamma(h).$$
Under periodic sampling the loop is exponentially stable iff the spectral radius
$\rho(F(h)) < 1$. For the two-layer consensus loop, mode $k$ of
[`TwoLayerNetwork`][jaxatt.networks.TwoLayerNetwork] has $A = -L_1$, $B = -\lambda_k\Delta$;
mode 1 ($\lambda_1 = 0$) is $e^{-L_1h}$, whose disagreement part (orthogonal to $\mathbf 1$)
has the radius $e^{-\lambda_2(L_1)h} < 1$ for every $h$.

Everything here is JAX ([`expm`][jaxatt.networks.expm], a Padé-13 scaling and squaring, and
`jnp.linalg.eigvals`), hence
differentiable in the graph weights and in $h$. [`largest_stable_interval`][] brackets the
first $h$ where the largest modal radius reaches 1 and bisects to machine precision; its
derivative comes from the implicit function theorem,
$\mathrm d h^* = -\,\partial_\theta\rho \,\mathrm d\theta / \partial_h\rho$ at $\rho(h^*) = 1$.
"""

import functools
from collections.abc import Callable

import equinox as eqx
import jax
import jax.lax as lax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._custom_types import RealScalarLike
from .._validation import (
    as_float_array,
    check_positive,
    check_positive_int,
    check_positive_scalar,
    is_traced,
)
from ._coupling import TwoLayerNetwork
from ._expm import expm


def _jit_in_h(fn):
    """Compile `fn(network, h)` once per network structure: `h` becomes an array (a Python
    float would be a static argument of `eqx.filter_jit` and recompile for every value).

    A concrete `h` must be a positive finite scalar (a sampling period): `h = 0` gave a NaN
    decay rate, a negative `h` a plausible radius of the loop run backwards in time, and a
    (q,) `h` broadcast into one period per mode. A traced `h` is checked for shape only (the
    functions call each other inside their compiled programs)."""
    compiled = eqx.filter_jit(fn)

    @functools.wraps(fn)
    def wrapper(network, h):
        if is_traced(h):
            h = as_float_array(h, "h", fn.__name__)
            if h.shape != ():
                raise ValueError(f"{fn.__name__}: `h` must be a scalar, got shape {h.shape}.")
        else:
            h = check_positive_scalar(fn.__name__, "h", h)
        return compiled(network, jnp.asarray(h, dtype=network.intra_laplacian.dtype))

    return wrapper


def sampled_transition(
    a: Float[Array, "n n"], b: Float[Array, "n n"], h: RealScalarLike
) -> Float[Array, "n n"]:
    r"""$F(h) = e^{Ah} + \int_0^h e^{As}ds\,B$: one period of $\dot g = Ag + Bg(t_i)$."""
    n = a.shape[0]
    top = jnp.concatenate([a, b], axis=1)
    augmented = jnp.concatenate([top, jnp.zeros_like(top)], axis=0) * h
    e = expm(augmented)
    return e[:n, :n] + e[:n, n:]


def spectral_radius(m: Float[Array, "n n"]) -> Float[Array, ""]:
    r"""$\max_i |\mu_i(M)|$ (differentiable where the largest eigenvalue is simple)."""
    return jnp.max(jnp.abs(jnp.linalg.eigvals(m)))


@_jit_in_h
def mode_transitions(network: TwoLayerNetwork, h: RealScalarLike) -> Float[Array, "q p p"]:
    r"""$F_k(h)$ for every mode $k = 1..q$ ($A = -L_1$, $B = -\lambda_k\Delta$)."""
    lam, _ = network.modes()
    a = -network.intra_laplacian
    delta = network.delta
    return jax.vmap(lambda lk: sampled_transition(a, -lk * delta, h))(lam)


@_jit_in_h
def mode_spectral_radii(network: TwoLayerNetwork, h: RealScalarLike) -> Float[Array, " modes"]:
    r"""$\rho(F_k(h))$ for the inter-group modes $k = 2..q$ (eigenvalues of $L_2$ ascending)."""
    return jax.vmap(spectral_radius)(mode_transitions(network, h)[1:])


@_jit_in_h
def disagreement_spectral_radius(network: TwoLayerNetwork, h: RealScalarLike) -> Float[Array, ""]:
    r"""The spectral radius of one period on the disagreement subspace: the largest of
    $\rho(F_k(h))$, $k \ge 2$, and $e^{-\lambda_2(L_1)h}$ (mode 1 without its average)."""
    intra = jnp.exp(-jnp.linalg.eigvalsh(network.intra_laplacian)[1] * h)
    return jnp.maximum(jnp.max(mode_spectral_radii(network, h)), intra)


@_jit_in_h
def network_transition(network: TwoLayerNetwork, h: RealScalarLike) -> Float[Array, "N N"]:
    r"""$F(h)$ of the whole network, $A = -I_q\otimes L_1$, $B = -L_2\otimes\Delta$, as a
    dense $N\times N$ matrix (small networks; a check of the modal decomposition)."""
    return sampled_transition(-network.kron_intra(), -network.kron_inter(), h)


@_jit_in_h
def decay_rate(network: TwoLayerNetwork, h: RealScalarLike) -> Float[Array, ""]:
    r"""The disagreement's exponential decay rate under periodic sampling,
    $-\ln\rho/h$ [1/s] with $\rho$ = [`disagreement_spectral_radius`][] (negative: growth)."""
    return -jnp.log(disagreement_spectral_radius(network, h)) / h


def _worst_mode_radius(network: TwoLayerNetwork, h) -> Array:
    return jnp.max(mode_spectral_radii(network, h))


def _first_unstable_interval(
    radius: Callable[[Array], Array], *, h_max: float, grid: int, iterations: int, dtype
) -> Array:
    r"""The first $h \in (0, h_{max}]$ at which `radius(h)` (a spectral radius) reaches 1:
    `inf` if it stays below 1 on the grid, NaN when a radius on the way is NaN (a NaN radius
    is never taken for a stable one). The radii on `grid` equally spaced points locate the
    first crossing, then `iterations` bisection steps shrink its bracket. Traceable; its
    derivative is not the root's (`_h_star` supplies that by the implicit function theorem)."""
    hs = jnp.linspace(h_max / grid, h_max, grid, dtype=dtype)
    radii = jax.vmap(radius)(hs)
    unstable = ~(radii < 1)  # a NaN radius is not a stable one
    first = jnp.argmax(unstable)
    hi = jnp.where(jnp.any(unstable), hs[first], jnp.inf)
    lo = jnp.where(first > 0, hs[jnp.maximum(first - 1, 0)], 0.0)

    def bisect(_, bracket):
        lo, hi = bracket
        mid = 0.5 * (lo + hi)
        stable = radius(mid) < 1
        return jnp.where(stable, mid, lo), jnp.where(stable, hi, mid)

    lo, hi = lax.fori_loop(0, iterations, bisect, (lo, jnp.where(jnp.isfinite(hi), hi, h_max)))
    # The bracket ends on a radius >= 1 (a crossing) or on a NaN radius (no answer).
    crossing = jnp.isfinite(radius(hi))
    return jnp.where(jnp.any(unstable), jnp.where(crossing, 0.5 * (lo + hi), jnp.nan), jnp.inf)


@eqx.filter_custom_jvp
def _h_star(network: TwoLayerNetwork, *, h_max: float, grid: int, iterations: int) -> Array:
    return _first_unstable_interval(
        lambda h: _worst_mode_radius(network, h),
        h_max=h_max,
        grid=grid,
        iterations=iterations,
        dtype=network.intra_laplacian.dtype,
    )


@_h_star.def_jvp
def _h_star_jvp(primals, tangents, *, h_max, grid, iterations):
    (network,) = primals
    (t_network,) = tangents
    h = _h_star(network, h_max=h_max, grid=grid, iterations=iterations)
    h_safe = jnp.where(jnp.isfinite(h), h, h_max)
    t_network = jax.tree_util.tree_map(
        lambda p, t: jnp.zeros_like(p) if t is None else t,
        network,
        t_network,
        is_leaf=lambda x: x is None,
    )
    _, d_theta = jax.jvp(lambda net: _worst_mode_radius(net, h_safe), (network,), (t_network,))
    d_h = jax.grad(lambda hh: _worst_mode_radius(network, hh))(h_safe)
    tangent = jnp.where(jnp.isfinite(h), -d_theta / d_h, 0.0)
    return h, tangent


_h_star_jit = eqx.filter_jit(_h_star)


def largest_stable_interval(
    network: TwoLayerNetwork, *, h_max: float = 5.0, grid: int = 200, iterations: int = 60
) -> Float[Array, ""]:
    r"""$h^*$ [s]: the first periodic sampling interval at which an inter-group mode stops
    being stable, $\max_{k\ge2}\rho(F_k(h^*)) = 1$ (`inf` if none below `h_max`; NaN when a
    radius on the way is NaN, e.g. a network with a NaN weight inside `jit` or `grad`: a NaN
    radius is never taken for a stable one).

    Bracketing: the radii on `grid` equally spaced $h \in (0, h_{max}]$ locate the first
    sign change of $\rho - 1$, then `iterations` bisection steps shrink the bracket (60 steps
    reach machine precision from a bracket of `h_max/grid`). The radius may cross 1 and come
    back inside one grid cell only if the grid is too coarse: refine `grid` if in doubt.
    Differentiable in every array of `network` (implicit function theorem); jit-compatible.
    The $\lambda_1 = 0$ mode is excluded: its disagreement part is stable for every $h$.
    """
    where = "largest_stable_interval"
    if not (np.isfinite(h_max) and h_max > 0):
        raise ValueError(f"{where}: `h_max` must be positive, got {h_max!r}.")
    # A float grid or iteration count was truncated silently, a grid of 0 divided by zero and
    # a negative count of iterations returned the coarse bracket's midpoint as the answer.
    grid = check_positive_int(where, "grid", grid)
    iterations = check_positive_int(where, "iterations", iterations, minimum=0)
    return _h_star_jit(network, h_max=float(h_max), grid=grid, iterations=iterations)


def sampled_response(
    network: TwoLayerNetwork, x0: Float[Array, "q p"], intervals: Float[Array, " intervals"]
) -> Float[Array, "samples q p"]:
    r"""The exact discretisation: $x(t_0), x(t_1), \dots$ with $t_{i+1} = t_i + h_i$, computed
    mode by mode, $g_k(t_{i+1}) = F_k(h_i)\,g_k(t_i)$ (no integration error; any real
    $h_i > 0$, periodic or not).

    **Arguments:** `network`; `x0`, the state at $t_0$, shape `(q, p)`; `intervals`, the
    $h_i > 0$ [s], a vector (concrete ones are checked: a negative or NaN interval ran the
    loop backwards or returned NaN states).
    """
    where = "sampled_response"
    shape = (network.groups, network.agents_per_group)
    x0 = as_float_array(x0, "x0", where)
    if x0.shape != shape:
        raise ValueError(f"{where}: `x0` must have shape {shape} (q, p), got shape {x0.shape}.")
    intervals = as_float_array(intervals, "intervals", where)
    if intervals.ndim != 1:
        raise ValueError(f"{where}: `intervals` must be a vector, got shape {intervals.shape}.")
    if not is_traced(intervals):
        intervals = check_positive(where, "intervals", intervals)
    return _sampled_response(network, x0, intervals)


@eqx.filter_jit
def _sampled_response(
    network: TwoLayerNetwork, x0: Float[Array, "q p"], intervals: Float[Array, " intervals"]
) -> Float[Array, "samples q p"]:
    lam, _ = network.modes()
    a = -network.intra_laplacian
    delta = network.delta

    def one(g, h):
        f = jax.vmap(lambda lk: sampled_transition(a, -lk * delta, h))(lam)
        g = jnp.einsum("kij,kj->ki", f, g)
        return g, g

    g0 = network.modal(x0)
    _, gs = lax.scan(one, g0, jnp.asarray(intervals, g0.dtype))
    gs = jnp.concatenate([g0[None], gs], axis=0)
    return jax.vmap(network.from_modal)(gs)
