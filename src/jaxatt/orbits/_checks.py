"""Host-side argument checks of the orbit functions.

The functions of [`jaxatt.orbits`][] act on one sample and run inside compiled dynamics (a
plant's vector field, a reference), so a check here is made only for **concrete** values, on
the host, with NumPy: a traced argument passes unchecked and adds nothing to the program (as
`elements_to_state` always did). A violated rule raises a `ValueError` naming the function,
the argument and the rule, instead of a NaN or a plausible wrong number.
"""

from collections.abc import Callable

import numpy as np

from .._validation import describe, is_traced


_RULES: dict[str, tuple[Callable[[np.ndarray], np.ndarray], str]] = {
    "a": (
        lambda x: np.isfinite(x) & (x > 0),
        "the semi-major axis `a` must be positive and finite",
    ),
    "e": (lambda x: (x >= 0) & (x < 1), "the eccentricity `e` must lie in [0, 1)"),
    "mu": (lambda x: np.isfinite(x) & (x > 0), "`mu` must be positive and finite"),
    "n": (lambda x: np.isfinite(x) & (x > 0), "the mean motion `n` must be positive and finite"),
}


def check_orbit_arguments(where: str, **values) -> None:
    """Check each concrete keyword argument: `a`, `e`, `mu`, `n` by their rules above, any other
    name (an angle, a time) for finiteness. `None` and traced values are skipped."""
    for name, value in values.items():
        if value is None or is_traced(value):
            continue
        predicate, rule = _RULES.get(name, (np.isfinite, f"`{name}` must be finite"))
        host = np.asarray(value, dtype=float)
        with np.errstate(invalid="ignore", over="ignore"):
            ok = bool(np.all(predicate(host)))
        if not ok:
            raise ValueError(f"{where}: {rule}, got {name}={describe(host)}.")


def check_orbit_state(where: str, r_name: str, r, v_name: str, v, *, bound_mu=None) -> None:
    """A concrete position and velocity (last axis 3): finite, a non-zero position and a
    non-zero angular momentum $r\\times v$ (a rectilinear state has no orbit plane); with
    `bound_mu`, also a negative energy (an ellipse). Traced values are skipped."""
    if is_traced(r) or is_traced(v) or is_traced(bound_mu):
        return
    r_host, v_host = np.asarray(r, dtype=float), np.asarray(v, dtype=float)
    for name, host in ((r_name, r_host), (v_name, v_host)):
        if host.shape[-1:] != (3,):
            raise ValueError(f"{where}: `{name}` must have shape (3,), got shape {host.shape}.")
        if not np.all(np.isfinite(host)):
            raise ValueError(f"{where}: `{name}` must be finite, got {name}={describe(host)}.")
    r_norm = np.linalg.norm(r_host, axis=-1)
    v_norm = np.linalg.norm(v_host, axis=-1)
    h_norm = np.linalg.norm(np.cross(r_host, v_host), axis=-1)
    if not np.all(r_norm > 0):
        raise ValueError(f"{where}: `{r_name}` must be non-zero, got {r_name}={describe(r_host)}.")
    if not np.all(h_norm > 1e-11 * r_norm * v_norm):
        raise ValueError(
            f"{where}: `{r_name}` x `{v_name}` must be non-zero (a rectilinear state has no orbit "
            f"plane), got {r_name}={describe(r_host)} and {v_name}={describe(v_host)}."
        )
    if bound_mu is not None:
        energy = 0.5 * v_norm**2 - np.asarray(bound_mu, dtype=float) / r_norm
        if not np.all(energy < 0):
            raise ValueError(
                f"{where}: the state must be bound (negative energy |{v_name}|^2/2 - mu/|{r_name}|"
                f"), got energy={describe(energy)} m^2/s^2 (a parabolic or hyperbolic orbit)."
            )
