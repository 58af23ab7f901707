r"""The prescribed-performance error transformation (Zhang et al. 2021 eqs. 22-30, $\delta = 1$)."""

from typing import ClassVar, NamedTuple

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._validation import check, is_traced
from ..metrics import AbstractMetric
from ..numerics import amin, clip, vectorized_atanh


class TransformedError(NamedTuple):
    r"""The transformed error of [`transform_error`][].

    - `kappa`: $\kappa = \operatorname{atanh}(z)$, $z = e/\rho$;
    - `beta`: $\beta = \partial\kappa/\partial e = 1/(\rho(1 - z^2))$;
    - `kappa_dot`: $\dot\kappa = \beta(\dot e - e\,\dot\rho/\rho)$;
    - `z`: the normalised error $e/\rho$ (unclipped; $|z| \ge 1$ means a violation).
    """

    kappa: Float[Array, "*k"]
    beta: Float[Array, "*k"]
    kappa_dot: Float[Array, "*k"]
    z: Float[Array, "*k"]


Z_LIMIT = 1.0 - 1e-9
"""$|z|$ is clipped to this inside `atanh` and $\\beta$: $\\kappa$ stays below 10.7 and
$\\beta\\rho$ below $5\\times10^8$, finite in float32 and float64."""


def transform_error(
    error: Float[ArrayLike, "*k"],
    error_rate: Float[ArrayLike, "*k"],
    rho: Float[ArrayLike, "*k"],
    rho_dot: Float[ArrayLike, "*k"],
) -> TransformedError:
    r"""Transform an error constrained to $|e| < \rho$ into an unconstrained one.

    With $e = \rho\tanh\kappa$ (eqs. 22-27): $z = e/\rho$, $\kappa = \operatorname{atanh} z
    = \tfrac12\ln\frac{1+z}{1-z}$, $\beta = 1/(\rho(1 - z^2))$ (eq. 29) and
    $\dot\kappa = \beta(\dot e - e\dot\rho/\rho)$ (eq. 30). Elementwise.

    **Guard.** For $|z| \ge 1$ (the error left its envelope) the inverse does not exist;
    $z$ is clipped to $\pm$`Z_LIMIT` $= 1 - 10^{-9}$ inside `atanh` and $\beta$, so the
    values stay finite (never NaN) and the caller reports the violation (a controller's
    `admissible` hook, so the sample's status becomes `constraint_violated`). `z` is returned
    unclipped.

    **Envelope.** $\rho$ must be positive and finite: a concrete $\rho \le 0$ (an envelope that
    has closed, or a sign slip) raises a `ValueError` naming `rho`; it has no transformed
    error, and clipping would hide it as a plausible $\kappa$. A traced $\rho$ is not checked
    here (the performance functions' constructors guarantee $\rho > 0$ inside the closed loop).
    """
    e = jnp.asarray(error)
    if not is_traced(rho):
        check(
            "transform_error",
            "rho",
            rho,
            lambda xp, r: (r > 0) & xp.isfinite(r),
            "must be positive and finite (the envelope's half-width)",
        )
    rho = jnp.asarray(rho)
    z = e / rho
    zc = clip(z, -Z_LIMIT, Z_LIMIT)
    kappa = vectorized_atanh(zc)  # jnp.arctanh is a C-library log call per element on CPU
    beta = 1.0 / (rho * (1.0 - zc**2))
    kappa_dot = beta * (jnp.asarray(error_rate) - e * jnp.asarray(rho_dot) / rho)
    return TransformedError(kappa, beta, kappa_dot, z)


def envelope_margin(
    error: Float[ArrayLike, "*k"], rho: Float[ArrayLike, "*k"]
) -> Float[Array, "*k"]:
    r"""$\rho - |e|$: positive inside the envelope, $\le 0$ for a violation."""
    return jnp.asarray(rho) - jnp.abs(jnp.asarray(error))


class MinimumMargin(AbstractMetric):
    r"""$\min_{t,i}$ of a margin signal, e.g. `"envelope_margin"` $\rho_i - |e_i|$ (the
    controller's signal): how close a run came to its envelopes [units of the error].

    A violation makes the sample's status `constraint_violated` (its time is
    `failure_time`), so a failed sample reports NaN here, as every non-time metric does,
    never a margin that looks safe.
    """

    signal: str = eqx.field(default="envelope_margin", static=True)
    worst: ClassVar[str] = "smallest"  # the closest call, not the safest run

    def __call__(self, traj) -> Array:
        return amin(traj.signals[self.signal])
