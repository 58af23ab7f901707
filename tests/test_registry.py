"""Every plant and controller (the library's and the stand-ins') through the generic checks.

A new component joins by adding a case to `CASES`: a closed loop, a batch of three initial
states, and the path of one array parameter. Each case must satisfy, on a short Euler run:

- `vmap` equals a loop: `monte_carlo` over the batch equals `simulate` sample by sample (with
  the plant's default metrics, which every library plant declares on its own signals);
- jit compiles once per structure: changing the parameter's value compiles nothing new;
- gradients are finite: of a scalar loss of the final state and the controls, with respect to
  every array of the closed loop, from the batch's first state and from rest at the origin of
  the state space (zero errors and rates: the library's safe primitives at singular points);
- bad input raises before compiling: a NaN in the initial state is a `ValueError` naming it.

And no library closed loop calls LAPACK in its step (checked on the lowered program).
"""

import functools
import inspect
import re

import equinox as eqx
import jax
import jax.extend.core as jex
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest

import jaxatt
from jaxatt import montecarlo as mc
from jaxatt.controllers import (
    MRPPD,
    FiniteTimeMRP,
    OpenLoop,
    QuaternionPD,
    RateConstrainedFiniteTimeMRP,
)
from jaxatt.plants import (
    AgentsState,
    MRPState,
    QuaternionState,
    RigidBodyMRP,
    RigidBodyQuaternion,
    Sinusoid,
)
from jaxatt.scenarios import (
    chen2022_two_phase_power as chen,
    duan2024 as duan,
    flyaround,
    shi2024,
    wu2018,
    yu2022_ftac_mrp as yu,
    yue2018,
    zhang2017,
    zhang2021_hover as zhang,
    zhang2021_tuning as zhang_tuning,
)
from jaxatt.simulation import ClosedLoop, Euler, FirstOrderLag, Saturation

from . import standins
from .helpers import J0, compile_count, sub_jaxprs


T1, DT = 0.1, 0.01  # ten Euler steps: enough to exercise every term, cheap to compile


def _quaternions(n=3, seed=0):
    return mc.quaternion_states(jr.key(seed), n, max_rate=0.1, max_angle=2.0)


def _mrps(n=3, seed=1):
    return mc.mrp_states(jr.key(seed), n, max_rate=0.1, max_angle=2.5)


def _translations(agents=()):
    keys = jr.split(jr.key(2))
    return standins.TranslationState(
        jr.uniform(keys[0], (3, *agents, 3), minval=-1, maxval=1),
        0.1 * jr.normal(keys[1], (3, *agents, 3)),
    )


def _flexible_states():
    q = _quaternions()
    return standins.FlexibleState(q.q, q.omega, 0.01 * jnp.ones((3, 2)), jnp.zeros((3, 2)))


def _slosh_states():
    q = _quaternions()
    rest = jax.vmap(shi2024.plant().rest_state)(q.q, q.omega)
    return eqx.tree_at(lambda x: x.n, rest, 0.01 * jnp.ones((3, 3)))


def _yu_batch():
    return mc.barrier_states(
        jr.key(4), 3, max_sigma=0.9, rate_limit=0.4, exponent=5 / 3, max_ratio=0.9
    )


def _relative_orbits():
    keys = jr.split(jr.key(5), 3)
    return zhang2017.RelativeOrbitState(
        jr.uniform(keys[0], (3,), maxval=6.0),
        jr.uniform(keys[1], (3, 3), minval=-60, maxval=60),
        jr.normal(keys[2], (3, 3)),
    )


def _six_dof_states():
    from jaxatt.plants import SixDofState

    q = _quaternions()
    keys = jr.split(jr.key(6))
    return SixDofState(
        jr.uniform(keys[0], (3, 3), minval=-20, maxval=20),
        0.1 * jr.normal(keys[1], (3, 3)),
        q.q,
        q.omega,
    )


def _euler_states():
    from jaxatt.plants import EulerAngleState

    keys = jr.split(jr.key(8))
    return EulerAngleState(
        jr.uniform(keys[0], (3, 3), minval=-0.5, maxval=0.5), 0.05 * jr.normal(keys[1], (3, 3))
    )


def _safe_approach_starts():
    starts = jnp.array([[48.5, -1.4, 0.2], [40.0, 0.5, -0.3], [30.0, 0.0, 0.6]])
    return jax.tree.map(lambda *x: jnp.stack(x), *[wu2018.initial_state(p) for p in starts])


def _attitude_law_cases():
    from jaxatt.controllers import (
        AdaptiveTanhMRP,
        AdaptiveTanhQuaternion,
        DecoupledSlidingMode,
        FeedbackLinearization,
    )
    from jaxatt.plants import Constant, RigidBodyEuler
    from jaxatt.reaching import Exponential, Tanh
    from jaxatt.references import EulerAngleTrajectory
    from jaxatt.sliding import ExponentialDecay, GlobalSurface, TerminalSurface

    inertia = jnp.diag(jnp.array([10.0, 12.0, 14.0]))
    surface = GlobalSurface(TerminalSurface(1.0, 0.5, 0.6), ExponentialDecay(1.0))
    return {
        "Euler angles + decoupling + global terminal SMC (SPEC 001(b))": (
            lambda: ClosedLoop(
                RigidBodyEuler(inertia),
                FeedbackLinearization(
                    inertia, DecoupledSlidingMode(surface, Exponential(2.0, 0.05, Tanh(0.01)))
                ),
                EulerAngleTrajectory(Constant(jnp.array([0.1, -0.2, 0.3]))),
            ),
            _euler_states,
            "controller.outer.surface.decay.time_constant",
        ),
        "adaptive tanh sliding mode, quaternion (SPEC 001(f))": (
            lambda: ClosedLoop(
                RigidBodyQuaternion(J0), AdaptiveTanhQuaternion(J0, 1.0, 10.0, 20.0, 0.01)
            ),
            _quaternions,
            "controller.gain",
        ),
        "adaptive tanh sliding mode, MRP (SPEC 001(f))": (
            lambda: ClosedLoop(RigidBodyMRP(J0), AdaptiveTanhMRP(J0, 1.0, 10.0, 20.0, 0.01)),
            _mrps,
            "controller.slope",
        ),
        "safe approach, J2 plant (Wu 2018, reconstructed)": (
            lambda: wu2018.build(),
            _safe_approach_starts,
            "controller.k_h",
        ),
    }


def _relative_orbit_cases():
    from jaxatt.controllers import FractionalSlidingMode
    from jaxatt.plants import ClohessyWiltshire, TschaunerHempel
    from jaxatt.reaching import Exponential

    cw = ClohessyWiltshire(7e6)
    return {
        "fly-around: relative orbit + attitude, body-fixed thrust (Zhu & Yang 2009)": (
            lambda: flyaround.build(),
            lambda: flyaround.dispersed_starts(jr.key(7), 3),
            "controller.translation.surface.slope",
        ),
        "6-DOF + adaptive terminal SMC (Yue 2018 eqs. 24-25)": (
            lambda: yue2018.build(yue2018.TUNED_GAINS),
            _six_dof_states,
            "controller.k3",
        ),
        "6-DOF + terminal SMC with the known mass (Yue 2018 eq. 22)": (
            lambda: yue2018.build(adaptive=False),
            _six_dof_states,
            "controller.force_bound",
        ),
        "Tschauner-Hempel + fractional PD^alpha on a CW model (Zhang 2017 eq. 17)": (
            lambda: ClosedLoop(
                TschaunerHempel(7e6, 0.2),
                FractionalSlidingMode(cw, 0.5, Exponential(1.0, 0.3), 0.8, DT, T1),
            ),
            _relative_orbits,
            "controller.surface.order",
        ),
    }


CASES = {
    "quaternion PD": (
        lambda: ClosedLoop(RigidBodyQuaternion(J0), QuaternionPD(2.0, 10.0)),
        _quaternions,
        "controller.kp",
    ),
    "Chen M1 sliding mode (saturated, tracking)": (
        lambda: chen.build("M1"),
        _quaternions,
        "controller.reaching_law.rho",
    ),
    "MRP PD, shadow switching, first-order lag": (
        lambda: ClosedLoop(
            RigidBodyMRP(J0), MRPPD(2.0, 10.0), actuator=FirstOrderLag(jnp.array([0.1, 0.2, 0.3]))
        ),
        _mrps,
        "actuator.time_constant",
    ),
    "FT (Yu eq. 23)": (
        lambda: ClosedLoop(RigidBodyMRP(J0, shadow_switching=False), FiniteTimeMRP(3.0, 1.0, 0.5)),
        _mrps,
        "controller.alpha1",
    ),
    "FTAC (Yu eq. 6), saturated": (
        lambda: ClosedLoop(
            RigidBodyMRP(yu.inertia(), shadow_switching=False),
            RateConstrainedFiniteTimeMRP(0.03, 0.01, 0.5, 0.4),
            actuator=Saturation(0.5),
        ),
        _yu_batch,
        "controller.rate_limit",
    ),
    "FTAC + super-twisting observer (Yu eq. 29)": (
        lambda: yu.build("FTAC", allow_inadmissible=False),
        _yu_batch,
        "observer.rho1",
    ),
    "Shi 2024: slosh + modes, ISM observer, TVSMC, ZV smoother": (
        lambda: shi2024.build("case1_smoother"),
        _slosh_states,
        "controller.controller.kp",
    ),
    "open loop": (
        lambda: ClosedLoop(
            RigidBodyQuaternion(J0), OpenLoop(Sinusoid(jnp.array([0.1, 0.0, -0.2]), 0.5))
        ),
        _quaternions,
        "controller.torque.amplitude",
    ),
    "two-layer consensus, sampled inter-layer link (Duan 2024)": (
        lambda: duan.build(tau=0.03, dt=DT),
        lambda: AgentsState(jr.normal(jr.key(5), (3, 3, 4))),
        "controller.network.rho1",
    ),
    "relative pose, finite-time prescribed performance (Zhang 2021)": (
        lambda: zhang.build("finite_time_ppf"),
        lambda: zhang_tuning.initial_states(jr.key(6), 3),
        "controller.envelope.exponent",
    ),
    "stand-in: point mass PD": (
        lambda: ClosedLoop(standins.PointMass(2.0), standins.TranslationPD(4.0, 3.0)),
        _translations,
        "controller.kd",
    ),
    "stand-in: Laplacian consensus": (
        lambda: ClosedLoop(
            standins.Agents(3),
            standins.ConsensusPD(np.diag([1.0, 2, 1]) - np.eye(3, k=1) - np.eye(3, k=-1), 1.5, 2.0),
        ),
        lambda: _translations((3,)),
        "controller.kp",
    ),
    "stand-in: flexible body + Chen M1's law": (
        lambda: ClosedLoop(
            standins.FlexibleBody(
                J0,
                jnp.array([[1.2, 0.4, -0.3], [0.2, -0.8, 0.9]]),
                jnp.array([1.5, 4.0]),
                jnp.array([0.02, 0.05]),
            ),
            chen.build("M1").controller,
        ),
        _flexible_states,
        "plant.frequencies",
    ),
    "stand-in: fractional PD memory": (
        lambda: ClosedLoop(standins.PointMass(1.0), standins.FractionalPD(4.0, 2.0, 0.7, DT, 5)),
        _translations,
        "controller.alpha",
    ),
    **_relative_orbit_cases(),
    **_attitude_law_cases(),
}


def _index(tree, k):
    return jax.tree.map(lambda x: x[k], tree)


def _at_rest(x0):
    """The origin of a state space: every leaf zero, a quaternion `q` the identity. Where
    |x|^a, norms, sign and the envelopes' ratios meet 0 (errors and rates exactly zero for the
    regulation cases; the identity at rest for the tracking ones)."""

    def origin(path, leaf):
        if jax.tree_util.keystr(path).endswith(".q") and leaf.shape[-1:] == (4,):
            return jnp.zeros_like(leaf).at[..., 0].set(1.0)
        return jnp.zeros_like(leaf)

    return jax.tree_util.tree_map_with_path(origin, x0)


AT_REST = {  # cases whose origin is not a valid state: the rest state closest to it
    # the target at the chaser's position would put both at the Earth's centre: zero errors
    "relative pose, finite-time prescribed performance (Zhang 2021)": lambda x0: (
        zhang.initial_state(*(jnp.zeros(3),) * 4)
    ),
    # the origin is the target, inside the keep-out sphere: at rest at the docking point r_d
    "safe approach, J2 plant (Wu 2018, reconstructed)": lambda x0: eqx.tree_at(
        lambda x: x.orbit.rho, _at_rest(x0), jnp.asarray(wu2018.R_D)
    ),
}


def _final(traj):
    return sum(jnp.sum(leaf[-1] ** 2) for leaf in jax.tree.leaves(traj.states.plant)) + jnp.sum(
        traj.signals["u"] ** 2
    )


@eqx.filter_jit
def _grad(loop, x0):
    def loss(loop):
        return _final(jaxatt.simulate(loop, x0, 0.0, T1, dt=DT, solver=Euler(), throw=False))

    return eqx.filter_grad(loss)(loop)


@pytest.mark.parametrize("name", list(CASES))
def test_generic_contract(name):
    make_loop, make_x0s, path = CASES[name]
    loop, x0s = make_loop(), make_x0s()
    common = dict(dt=DT, solver=Euler())

    # vmap = loop (monte_carlo's batch runner against simulate, sample by sample), with the
    # plant's default metrics (the stand-ins may declare none).
    defaults = loop.default_metrics(1e-2)
    metrics = None if defaults else {"peak": jaxatt.metrics.Peak("u")}
    batch = mc.monte_carlo(loop, x0s, 0.0, T1, metrics=metrics, keep_trajectories=True, **common)
    assert bool(np.all(batch.successful)), batch.status
    assert set(batch.metrics) == set(defaults or metrics)
    for metric, values in batch.metrics.items():  # a successful sample has no NaN metric
        assert not np.any(np.isnan(values)), (name, metric)
    singles = [jaxatt.simulate(loop, _index(x0s, k), 0.0, T1, **common) for k in range(3)]
    for k, single in enumerate(singles):
        for a, b in zip(
            jax.tree.leaves(_index(batch.trajectories.states, k)), jax.tree.leaves(single.states)
        ):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)

    # One compilation per structure: a new value of a parameter compiles nothing.
    select = jaxatt._paths.path_selector(path)
    other = eqx.tree_at(select, loop, select(loop) * 1.1)
    before = compile_count()
    changed = jaxatt.simulate(other, _index(x0s, 0), 0.0, T1, **common)
    assert compile_count() == before, f"{name}: changing {path} recompiled"
    assert not all(  # and the new value is used
        np.array_equal(a, b)
        for a, b in zip(jax.tree.leaves(changed.states), jax.tree.leaves(singles[0].states))
    )

    # Finite gradients with respect to every array of the closed loop.
    grads = _grad(loop, _index(x0s, 0))
    leaves = jax.tree.leaves(eqx.filter(grads, eqx.is_array))
    assert leaves and all(bool(jnp.all(jnp.isfinite(g))) for g in leaves), name
    assert any(bool(jnp.any(g != 0)) for g in leaves), name
    # ... and at rest (the same compiled gradient, another start), where the safe primitives
    # meet their singular points: exact zeros in |x|^a, sign, norms and ratios.
    at_rest = AT_REST.get(name, _at_rest)(_index(x0s, 0))
    assert jaxatt.simulate(loop, at_rest, 0.0, T1, **common).successful  # a valid start
    rest_grads = jax.tree_util.tree_leaves_with_path(eqx.filter(_grad(loop, at_rest), eqx.is_array))
    nonfinite = [jax.tree_util.keystr(p) for p, g in rest_grads if not jnp.all(jnp.isfinite(g))]
    assert not nonfinite, (name, nonfinite)

    # Bad input raises before compiling, naming the argument.
    first, *rest = jax.tree.leaves(_index(x0s, 0))
    bad = jax.tree.unflatten(
        jax.tree.structure(_index(x0s, 0)), [first.at[(0,) * first.ndim].set(jnp.nan), *rest]
    )
    before = compile_count()
    with pytest.raises(ValueError, match=r"`x0(\.\w+)+` must be finite"):
        jaxatt.simulate(loop, bad, 0.0, T1, **common)
    assert compile_count() == before


def _component_types(node, found=None) -> set[type]:
    found = set() if found is None else found
    if isinstance(node, eqx.Module):
        found.add(type(node))
        for field in node.__dataclass_fields__:
            _component_types(getattr(node, field, None), found)
    elif isinstance(node, (tuple, list)):
        for item in node:
            _component_types(item, found)
    return found


def test_the_registry_covers_every_public_plant_controller_observer_and_actuator():
    covered = set()
    for make_loop, _, _ in CASES.values():
        covered |= _component_types(make_loop())
    public = set()
    for package, base in (
        (jaxatt.plants, jaxatt.plants.AbstractPlant),
        (jaxatt.controllers, jaxatt.controllers.AbstractController),
        (jaxatt.observers, jaxatt.observers.AbstractObserver),
    ):
        for value in vars(package).values():
            if (
                isinstance(value, type)
                and issubclass(value, base)
                and value is not base
                and not inspect.isabstract(value)  # abstract families (their subclasses count)
            ):
                public.add(value)
    assert public - covered == set(), sorted(t.__name__ for t in public - covered)
    assert {MRPState, QuaternionState} <= {
        make_x0s().__class__ for _, make_x0s, _ in CASES.values()
    }


def test_every_library_plant_has_default_metrics_on_its_own_signals():
    """`monte_carlo(loop, x0s, t0, t1, dt=dt)` records the plant's `default_metrics` (the
    README's first call): every library plant declares some, and each reads a signal its closed
    loop has. Traced only (`jax.eval_shape` of the signals), nothing compiled."""
    missing = {}
    for name, (make_loop, make_x0s, _) in CASES.items():
        if name.startswith("stand-in"):
            continue
        loop = make_loop()
        signals = set(
            jax.eval_shape(
                lambda x, loop=loop: loop.signals(0.0, loop.init(0.0, x), None),
                _index(make_x0s(), 0),
            )
        )
        read = {metric.signal for metric in loop.default_metrics(1e-2).values()}
        if not read or not read <= signals:
            missing[name] = sorted(read - signals) or "no default metrics"
    assert missing == {}


def _plain(param) -> bool:
    """A parameter that tells equations apart by its repr (slice indices, dtypes), not a jaxpr."""
    if isinstance(param, tuple):
        return all(map(_plain, param))
    return not isinstance(param, jex.ClosedJaxpr | jex.Jaxpr)


def _calls(jaxpr, primitive: str) -> dict[str, tuple[int, int]]:
    """`{function: (calls, distinct calls)}` of the `primitive` equations of `jaxpr`, keyed by
    their parameters (a `custom_jvp_call`'s function text), distinct by value numbering through
    nested `jit` calls: a call repeats an earlier one when it has the same inputs."""
    numbers, calls = {}, {}

    def key(var, env):
        if isinstance(var, jex.Literal):
            return ("literal", repr(var.val))
        return env.get(var, ("var", id(var)))

    def walk(jaxpr, inputs):
        env = dict(zip(jaxpr.invars, inputs))
        for eqn in jaxpr.eqns:
            ins = tuple(key(v, env) for v in eqn.invars)
            if eqn.primitive.name in ("pjit", "jit", "closed_call"):
                inner = eqn.params.get("jaxpr") or eqn.params.get("call_jaxpr")
                inner = inner.jaxpr if isinstance(inner, jex.ClosedJaxpr) else inner
                env.update(zip(eqn.outvars, walk(inner, list(ins))))
                continue
            if eqn.primitive.name == "custom_jvp_call":
                params = str(eqn.params["call_jaxpr"])
            else:
                params = repr(sorted((k, repr(v)) for k, v in eqn.params.items() if _plain(v)))
            signature = (eqn.primitive.name, params, ins)
            if eqn.primitive.name == primitive:
                total, distinct = calls.get(params, (0, 0))
                calls[params] = (total + 1, distinct + (signature not in numbers))
            number = numbers.setdefault(signature, len(numbers))
            env.update((out, ("value", number, k)) for k, out in enumerate(eqn.outvars))
        return [key(v, env) for v in jaxpr.outvars]

    walk(jaxpr, [("input", k) for k in range(len(jaxpr.invars))])
    return calls


def _sincos_text() -> str:
    """The function text of a float64 scalar `vectorized_sincos` call, as `_calls` keys it."""
    return str(
        jax.make_jaxpr(jaxatt.numerics.vectorized_sincos)(jnp.zeros(()))
        .eqns[0]
        .params["call_jaxpr"]
    )


@functools.cache
def _vector_field_jaxpr(name: str):
    """`(field, y0, jaxpr)` of one evaluation of the registry loop `name`'s vector field at
    its first start, traced once for the tests that read it."""
    make_loop, make_x0s, _ = CASES[name]
    loop = make_loop()
    y0 = loop.init(0.0, _index(make_x0s(), 0))
    field = lambda y, loop=loop: loop.vector_field(0.1, y, None)  # noqa: E731
    return field, y0, jax.make_jaxpr(field)(y0).jaxpr


def test_no_library_closed_loop_evaluates_a_power_twice_on_the_same_inputs():
    """Every |x|^a of the laws is `jaxatt.numerics.sig_pow`, a `jax.custom_jvp` call, and XLA
    does not always merge two calls on the same inputs: `RateConstrainedFiniteTimeMRP`
    computed chi(v) twice, and its compiled Monte Carlo step held 69 `exp`s instead of 57
    (1.11-1.15x slower; benchmarks/README.md). A component computes each power once and
    passes it on. Checked on the jaxpr of one vector-field evaluation; nothing compiled.
    (`vectorized_sincos` is left out: XLA merges its repeats, the test below.)"""
    sincos, repeated = _sincos_text(), {}
    for name in CASES:
        if name.startswith("stand-in"):
            continue
        _, _, jaxpr = _vector_field_jaxpr(name)
        calls = _calls(jaxpr, "custom_jvp_call")
        count = sum(total - distinct for text, (total, distinct) in calls.items() if text != sincos)
        if count:
            repeated[name] = count
    assert repeated == {}


_EXTREMA = ("max", "min", "reduce_max", "reduce_min", "clamp", "cummax", "cummin")


def _float_extrema(jaxpr, found: set[str]) -> set[str]:
    for eqn in jaxpr.eqns:
        if eqn.primitive.name in _EXTREMA and jnp.issubdtype(
            eqn.outvars[0].aval.dtype, jnp.floating
        ):
            found.add(eqn.primitive.name)
        for sub in sub_jaxprs(eqn):
            _float_extrema(sub, found)
    return found


def test_no_library_closed_loop_takes_an_extremum_whose_derivative_tests_equality():
    """JAX's derivatives of `max`, `min`, `reduce_max`, `reduce_min` and `clamp` (`jnp.max`,
    `jnp.maximum`, `jnp.clip`) find the chosen operand by bitwise equality with the result, and
    give NaN or a silent zero when XLA computes the operand twice and the copies round
    differently (Zhang 2021's tuning gradient was NaN; tests/numerics/test_extrema.py). The
    library's closed loops take their extrema from `jaxatt.numerics` (`amax`, `maximum`,
    `clip`: selects), so no float extremum primitive is left in any vector field. Traced
    only, nothing compiled."""
    found = {}
    for name in CASES:
        if name.startswith("stand-in"):
            continue
        _, _, jaxpr = _vector_field_jaxpr(name)
        extrema = _float_extrema(jaxpr, set())
        if extrema:
            found[name] = sorted(extrema)
    assert found == {}
    # The check can fail: `jnp.clip` and `jnp.max` are seen, an integer `max` is not.
    seen = jax.make_jaxpr(lambda x: (jnp.clip(x, -1, 1), jnp.max(x)))(jnp.ones(3))
    floats = _float_extrema(seen.jaxpr, set())
    assert "reduce_max" in floats and floats & {"max", "min", "clamp"}
    assert not _float_extrema(jax.make_jaxpr(lambda k: jnp.maximum(k, 2))(1).jaxpr, set())


def test_no_library_closed_loop_calls_lapack_in_its_step():
    """XLA:CPU runs `jnp.linalg.solve`, `inv`, `eigvalsh`, `svd` as a LAPACK call per matrix:
    per sample and stage in a batch, outside the fused elementwise code (a 6x6 `eigvalsh` made
    Zhang 2021's Monte Carlo of 1000 samples 2.6-2.9x slower, two 3x3 `solve`s Wu 2018's 1.8x;
    benchmarks/README.md). The library's closed loops use closed forms (`jaxatt.numerics`);
    the stand-ins (test code) may do as they like. Lowered only, nothing compiled."""
    calls = {}
    for name, (make_loop, make_x0s, _) in CASES.items():
        if name.startswith("stand-in"):
            continue
        loop, x0 = make_loop(), _index(make_x0s(), 0)
        run = jax.jit(
            lambda x, loop=loop: (
                jaxatt.simulate(loop, x, 0.0, T1, dt=DT, solver=Euler(), throw=False).states
            )
        )
        found = set(re.findall(r"custom_call @(\w*lapack\w*)", run.lower(x0).as_text()))
        if found:
            calls[name] = sorted(found)
    assert calls == {}
    # The check can fail: a LAPACK call in a step is seen.
    solve = jax.jit(lambda a, b: jnp.linalg.solve(a, b)).lower(jnp.eye(3), jnp.ones(3))
    assert re.search(r"custom_call @\w*lapack", solve.as_text())


def test_xla_merges_the_repeated_sines_of_a_closed_loop():
    """The sines of one angle are asked for by several components of a step (the plant's
    anomaly rates and gravity, the reference, the controller's model): 5 to 23
    `vectorized_sincos` calls on 1 to 10 distinct inputs per vector field. XLA's common
    subexpression elimination merges them: with fusion turned off (fusion copies producers
    into each consumer, whatever their origin), the compiled vector field holds at most one
    `round-nearest-even` (the reduction's n = round(2x/pi)) per distinct call."""
    sincos, checked = _sincos_text(), 0
    for name in CASES:
        field, y0, jaxpr = _vector_field_jaxpr(name)
        total, distinct = _calls(jaxpr, "custom_jvp_call").get(sincos, (0, 0))
        if total <= distinct:
            continue
        compiled = jax.jit(field).lower(y0).compile({"xla_disable_hlo_passes": "fusion"})
        rounds = len(re.findall(r"round-nearest-even\(", compiled.as_text()))
        assert 1 <= rounds <= distinct < total, name
        checked += 1
    assert checked >= 3


_SCALAR_LIBRARY_CALLS = (  # not `log`: the scalarizer replaces it (tests/numerics/test_log.py)
    "acos",
    "asin",
    "atan",
    "atan2",
    "atanh",
    "cos",
    "log1p",
    "pow",
    "sin",
    "tan",
)


def _state_dependent_primitives(jaxpr, tainted: list[bool], found: set[str]) -> list[bool]:
    """Add to `found` the primitives of `jaxpr`'s equations with an input that depends on a
    `tainted` input (what `vmap` over those inputs would batch); returns the outputs' taints.
    Calls (`jit`, `custom_jvp_call`, ...) are followed argument by argument; loops and branches
    conservatively: every output depends on every input."""
    env = dict(zip(jaxpr.invars, tainted))

    def taint(var) -> bool:
        return not isinstance(var, jex.Literal) and env.get(var, False)

    for eqn in jaxpr.eqns:
        ins = [taint(v) for v in eqn.invars]
        if not any(ins):
            continue
        found.add(eqn.primitive.name)
        subs = list(sub_jaxprs(eqn))
        outs = [True] * len(eqn.outvars)
        for sub in subs:
            if len(subs) == 1 and len(sub.invars) == len(ins) and len(sub.outvars) == len(outs):
                outs = _state_dependent_primitives(sub, ins, found)  # a call
            else:
                _state_dependent_primitives(sub, [True] * len(sub.invars), found)
        env.update(zip(eqn.outvars, outs))
    return [taint(v) for v in jaxpr.outvars]


def test_no_library_closed_loop_takes_a_c_library_function_of_its_state():
    """Gravity takes its |r|^3 from a square root, the prescribed-performance transformation
    its atanh from `vectorized_atanh`, anomalies and Euler angles their sines from
    `vectorized_sincos`, Smith's eigenvalue formula (Zhang 2021, Yue 2018 eq. 22) its arccos
    from `vectorized_arccos`: no float64 `acos`, `asin`, `atan`, `atan2`, `atanh`, `cos`,
    `log1p`, `pow`, `sin` or `tan` of the state (XLA:CPU's scalar C-library calls, one per
    sample in a batch) is left in any library closed loop's vector field. `log` may stay: the
    scalarizer replaces it by `jaxatt.numerics.vectorized_log`, and in the plain layout XLA's
    is the faster one. Calls on time or the parameters alone are computed once per step for
    the whole batch and do not count: the check follows the state's dependents through one
    traced evaluation (what `vmap` over a batch of states would batch). Traced only, nothing
    compiled."""
    calls = {}
    for name in CASES:
        if name.startswith("stand-in"):
            continue
        _, _, jaxpr = _vector_field_jaxpr(name)
        found = set()
        _state_dependent_primitives(jaxpr, [True] * len(jaxpr.invars), found)
        if found & set(_SCALAR_LIBRARY_CALLS):
            calls[name] = sorted(found & set(_SCALAR_LIBRARY_CALLS))
    assert calls == {}

    # The check can fail: a power of the state is seen through a call, and a sine through a
    # loop; the logarithm, power and sines of time alone are not.
    def field(x, t):
        looped = jax.lax.fori_loop(0, 2, lambda k, y: jnp.sin(y), x)
        return jax.jit(lambda x: x**1.5)(x) + looped + jnp.log(t) ** 1.5 + jnp.sin(jnp.cos(t))

    seen = jax.make_jaxpr(field)(1.0, 0.3).jaxpr
    of_state, of_time = set(), set()
    _state_dependent_primitives(seen, [True, False], of_state)
    _state_dependent_primitives(seen, [False, True], of_time)
    assert {"pow", "sin"} <= of_state and not of_state & {"log", "cos"}
    assert {"log", "pow", "sin", "cos"} <= of_time
