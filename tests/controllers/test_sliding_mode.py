"""SlidingModeTracking: the composed law makes s follow its reaching law (autodiff as oracle)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.controllers import AxisRobustTerm, NormRobustTerm, SlidingModeTracking
from jaxatt.plants import QuaternionState, RigidBodyQuaternion, Sinusoid
from jaxatt.reaching import DoublePower, Exponential, Tanh, TwoPhasePower
from jaxatt.references import IntegratedReference
from jaxatt.simulation import ClosedLoop, ClosedLoopState
from jaxatt.sliding import FractionalSurface, LinearSurface

from ..helpers import J0


LAWS = [
    TwoPhasePower(1.2, 1.2, 31 / 11, 5 / 9),
    Exponential(1.2, 0.01, switching=Tanh(0.05)),
    DoublePower(1.2, 0.8, 31 / 11, 5 / 9),
]
ROBUST = [None, NormRobustTerm(0.35, 0.01), AxisRobustTerm(0.35, 0.01)]


def _nominal_loop(law, robust, feedforward=True):
    """Nominal plant (J = J0, no disturbance, no saturation): D = 0 exactly."""
    reference = IntegratedReference(
        jnp.array([1.0, 0, 0, 0]),
        Sinusoid(0.05 * jnp.ones(3), jnp.pi * jnp.array([0.01, 0.02, 0.03])),
    )
    controller = SlidingModeTracking(
        LinearSurface(5.0), law, jnp.asarray(J0), robust, surface_feedforward=feedforward
    )
    return ClosedLoop(RigidBodyQuaternion(jnp.asarray(J0)), controller, reference)


def _state(key):
    k1, k2, k3 = jax.random.split(key, 3)
    q = jax.random.normal(k1, (4,))
    qd = jax.random.normal(k2, (4,))
    return ClosedLoopState(
        QuaternionState(q / jnp.linalg.norm(q), 0.1 * jax.random.normal(k3, (3,))),
        qd / jnp.linalg.norm(qd),
        None,
    )


def _s_and_s_dot(loop, t, y):
    """s(t, y) and its exact time derivative along the closed-loop vector field (jax.jvp)."""

    def s_of(t, y):
        return loop.signals(t, y, None)["s"]

    y_dot = loop(t, y, None)
    return jax.jvp(s_of, (t, y), (jnp.ones_like(t), y_dot))


@pytest.mark.parametrize("law", LAWS, ids=lambda law: type(law).__name__)
@pytest.mark.parametrize("robust", ROBUST, ids=lambda r: type(r).__name__)
def test_sliding_variable_follows_reaching_law(law, robust):
    loop = _nominal_loop(law, robust)
    for seed in range(3):
        y = _state(jax.random.key(seed))
        t = jnp.asarray(1.7 + seed)
        s, s_dot = _s_and_s_dot(loop, t, y)
        expected = law.rate(s) - (0 if robust is None else robust(s))
        np.testing.assert_allclose(s_dot, expected, rtol=1e-10, atol=1e-12)


def test_literal_eq57_omits_surface_feedforward_and_breaks_the_law():
    law = Exponential(1.2, 0.01)
    y = _state(jax.random.key(3))
    t = jnp.asarray(0.4)
    loop = _nominal_loop(law, None, feedforward=False)
    s, s_dot = _s_and_s_dot(loop, t, y)
    e_dot_term = loop.controller.surface.attitude_term_rate(
        *(lambda sig: (sig["attitude_error"], sig["rate_error"]))(loop.signals(t, y, None))
    )
    # Literal (57): s_dot = r(s) + lambda e_v_dot, i.e. off by exactly the omitted term.
    np.testing.assert_allclose(s_dot, law.rate(s) + e_dot_term, rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(e_dot_term)) > 1e-3


def test_linear_surface_rate_matches_autodiff():
    surface = LinearSurface(jnp.array([5.0, 4.0, 3.0]))
    y = _state(jax.random.key(5))
    e = y.plant.q
    e_omega = jnp.array([0.1, -0.2, 0.05])
    e_dot = 0.5 * jnp.concatenate(
        [-(e[1:] @ e_omega)[None], e[0] * e_omega + jnp.cross(e[1:], e_omega)]
    )
    _, h_dot = jax.jvp(lambda e: surface(e, jnp.zeros(3)), (e,), (e_dot,))
    np.testing.assert_allclose(surface.attitude_term_rate(e, e_omega), h_dot, rtol=1e-12)


@pytest.mark.parametrize(
    "build, needle",
    [
        (lambda: LinearSurface(-1.0), "LinearSurface: `slope` must be positive"),
        (lambda: NormRobustTerm(0.35, 0.0), "NormRobustTerm: `eps` must be positive"),
        (
            lambda: SlidingModeTracking(LinearSurface(1.0), LAWS[0], -jnp.eye(3)),
            "SlidingModeTracking: `inertia` must be a symmetric positive-definite",
        ),
        # Unchecked before (review, 2026-12-05): step 0 gave inf, a NaN or negative step NaN,
        # capacity 0 an IndexError; the order's message named `alpha`.
        (lambda: FractionalSurface(1.0, 0.5, 0.0, 10), "FractionalSurface: `step` must be"),
        (lambda: FractionalSurface(1.0, 0.5, float("nan"), 10), "`step` must be positive"),
        (lambda: FractionalSurface(1.0, 0.5, 0.01, 0), "`capacity` must be a positive integer"),
        (lambda: FractionalSurface(1.0, 1.5, 0.01, 10), "FractionalSurface: `order` must lie"),
    ],
)
def test_bad_sliding_mode_configuration_raises(build, needle):
    with pytest.raises(ValueError) as info:
        build()
    assert needle in str(info.value)


def test_wrong_component_type_is_a_type_error(no_jaxtyping):
    with pytest.raises(TypeError, match="SlidingModeTracking: `reaching_law` has the wrong type"):
        SlidingModeTracking(LinearSurface(1.0), "two-phase", jnp.eye(3))
    # A number where a switching function goes (the boundary-layer width, say) failed only
    # when the law was first evaluated: 'float' object has no attribute 'signed_power'.
    for law in (TwoPhasePower, DoublePower):
        with pytest.raises(TypeError, match="`switching` must be a jaxatt.reaching switching"):
            law(1.2, 1.2, 31 / 11, 5 / 9, 0.1)
    with pytest.raises(TypeError, match="Exponential: `switching` must be"):
        Exponential(1.0, 1.0, 0.1)
