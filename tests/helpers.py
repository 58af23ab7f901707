"""Shared test models: small, fixed scenarios built once per module, a compile counter, and
the primitives of a jaxpr."""

import jax
import jax.extend.core as jex
import jax.numpy as jnp
import numpy as np

import jaxatt
from jaxatt.controllers import MRPPD, QuaternionPD
from jaxatt.plants import (
    MRPState,
    QuaternionState,
    RigidBodyMRP,
    RigidBodyQuaternion,
    Sinusoid,
)
from jaxatt.simulation import ClosedLoop


J0 = np.array([[20.0, 1.2, 0.9], [1.2, 17.0, 1.4], [0.9, 1.4, 15.0]])
"""Chen 2022 / Xia 2011 nominal inertia [kg m^2]."""

DJ_AMPLITUDE = np.diag([1.0, 2.0, 3.0])
DJ_FREQUENCY = np.diag([0.1, 0.2, 0.3])
D_AMPLITUDE = np.array([0.1, 0.2, 0.3])
D_FREQUENCY = np.array([0.1, 0.2, 0.3])

Q0 = np.array([0.8832, 0.3, -0.2, -0.3]) / np.linalg.norm([0.8832, 0.3, -0.2, -0.3])


def inertia_perturbation() -> Sinusoid:
    return Sinusoid(jnp.asarray(DJ_AMPLITUDE), jnp.asarray(DJ_FREQUENCY))


def disturbance() -> Sinusoid:
    return Sinusoid(jnp.asarray(D_AMPLITUDE), jnp.asarray(D_FREQUENCY))


def mrp_pd_loop(k1=2.0, k2=10.0, *, uncertain=True, shadow_switching=False) -> ClosedLoop:
    """MRP plant with Chen's inertia, optional dJ(t) and d(t), under tau = -k1 sigma - k2 omega."""
    plant = RigidBodyMRP(
        jnp.asarray(J0),
        inertia_perturbation() if uncertain else None,
        disturbance() if uncertain else None,
        shadow_switching=shadow_switching,
    )
    return ClosedLoop(plant, MRPPD(k1, k2))


def quat_pd_loop(kp=2.0, kd=10.0, *, uncertain=True) -> ClosedLoop:
    plant = RigidBodyQuaternion(
        jnp.asarray(J0),
        inertia_perturbation() if uncertain else None,
        disturbance() if uncertain else None,
    )
    return ClosedLoop(plant, QuaternionPD(kp, kd))


def mrp_x0() -> MRPState:
    q = jnp.asarray(Q0)
    return MRPState(sigma=jaxatt.rotations.mrp_from_quat(q), omega=jnp.array([0.02, -0.01, 0.03]))


def quat_x0() -> QuaternionState:
    return QuaternionState(q=jnp.asarray(Q0), omega=jnp.array([0.02, -0.01, 0.03]))


_BACKEND_COMPILES: list[str] = []


def _count_compile(event: str, duration: float, **kwargs) -> None:
    if event == "/jax/core/compile/backend_compile_duration":
        _BACKEND_COMPILES.append(str(kwargs.get("fun_name", "")))


jax.monitoring.register_event_duration_secs_listener(_count_compile)


def compile_count(name: str | None = None) -> int:
    """XLA compilations so far in this process, from JAX's public monitoring events; with
    `name`, only those of functions whose name contains it (e.g. "integrate",
    "_loss_and_grad"). Compare two readings to check that a call compiled nothing new."""
    if name is None:
        return len(_BACKEND_COMPILES)
    return sum(name in fun for fun in _BACKEND_COMPILES)


def sub_jaxprs(eqn):
    """The jaxprs nested in an equation's parameters (calls, loop bodies, branches)."""
    for value in eqn.params.values():
        for item in value if isinstance(value, tuple | list) else (value,):
            if isinstance(item, jex.ClosedJaxpr):
                yield item.jaxpr
            elif isinstance(item, jex.Jaxpr):
                yield item


def count_primitive(jaxpr, primitive: str) -> int:
    """How many `primitive` equations a jaxpr (or closed jaxpr) holds, nested calls and loops
    included."""
    jaxpr = getattr(jaxpr, "jaxpr", jaxpr)
    n = 0
    for eqn in jaxpr.eqns:
        n += eqn.primitive.name == primitive
        n += sum(count_primitive(sub, primitive) for sub in sub_jaxprs(eqn))
    return n


def primitives(closed_jaxpr) -> set[str]:
    """The names of every primitive in a closed jaxpr, nested jaxprs (calls, custom rules,
    loops) included."""
    names = set()

    def walk(jaxpr):
        for eqn in jaxpr.eqns:
            names.add(eqn.primitive.name)
            for param in eqn.params.values():
                inner = getattr(param, "jaxpr", param)
                if hasattr(inner, "eqns"):
                    walk(inner)

    walk(closed_jaxpr.jaxpr)
    return names


def ulps(value: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Error of `value` in units in the last place of `reference`. A subnormal reference counts
    as 0 of its sign: XLA:CPU flushes subnormal results to zero."""
    flushed = np.abs(reference) < np.finfo(np.float64).tiny
    reference = np.where(flushed, np.copysign(0.0, reference), reference)
    return np.abs(value - reference) / np.spacing(np.abs(reference))


def is_lbfgs(transformation, params) -> bool:
    """Whether an optax transformation has `optax.lbfgs()`'s state structure on `params` (what a
    stand-in `tune` received for `--optimizer lbfgs`; an Adam's state differs)."""
    import optax

    def structure(t):
        return jax.tree.structure(t.init(params))

    return structure(transformation) == structure(optax.lbfgs())
