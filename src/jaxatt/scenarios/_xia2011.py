"""The spacecraft of Xia et al. (2011), reused by Chen et al. (2022) and Yue & Li (2018).

SPEC 000.4: nominal inertia, inertia uncertainty, disturbance and the first initial attitude.
Functions (not module-level arrays) so that arrays are created after the caller has chosen
float64 (STYLE behaviour 5).
"""

import jax.numpy as jnp
from jaxtyping import Array, Float

from ..plants import Sinusoid


def nominal_inertia() -> Float[Array, "3 3"]:
    """$J_0$ [kg m^2]."""
    return jnp.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])


def inertia_perturbation() -> Sinusoid:
    r"""$\Delta J(t) = \mathrm{diag}(\sin 0.1t,\ 2\sin 0.2t,\ 3\sin 0.3t)$ [kg m^2]."""
    return Sinusoid(jnp.diag(jnp.array([1.0, 2.0, 3.0])), jnp.diag(jnp.array([0.1, 0.2, 0.3])))


def disturbance() -> Sinusoid:
    r"""$d(t) = [0.1\sin 0.1t,\ 0.2\sin 0.2t,\ 0.3\sin 0.3t]^T$ [N m]."""
    return Sinusoid(jnp.array([0.1, 0.2, 0.3]), jnp.array([0.1, 0.2, 0.3]))


def initial_attitude_d1() -> Float[Array, "4"]:
    """$q(0) = [0.8832, 0.3, -0.2, -0.3]$ as printed (norm 1.000021), normalized."""
    q = jnp.array([0.8832, 0.3, -0.2, -0.3])
    return q / jnp.linalg.norm(q)
