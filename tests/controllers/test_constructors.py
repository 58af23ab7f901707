"""Bad arguments to the controllers that have no test file of their own (their behaviour is
tested with their scenarios): each is refused eagerly with a `ValueError` naming the class and
the argument, before anything compiles."""

import equinox as eqx
import jax
import jax.numpy as jnp
import pytest

from jaxatt._validation import host_checked
from jaxatt.controllers import (
    MRPPD,
    AdaptiveTerminalSixDof,
    FractionalSlidingMode,
    ProximitySlidingMode,
    SafeApproachSlidingMode,
    SlidingModeTracking,
    TimeVaryingSlidingMode,
    TranslationalSlidingMode,
    TwoLayerConsensus,
)
from jaxatt.networks import SampledLink, SampleSchedule
from jaxatt.plants import AgentsState, Proximity, RelativeOrbit, SingleIntegratorAgents
from jaxatt.reaching import Exponential, Saturation
from jaxatt.scenarios import duan2024, wu2018, yue2018
from jaxatt.simulation import ClosedLoop, simulate
from jaxatt.sliding import LinearSurface, PDSurface


def safe_approach(**changes):
    limits = dict(force_limit=wu2018.FORCE_LIMIT, torque_limit=wu2018.TORQUE_LIMIT)
    settings = {**wu2018.GAINS, **limits, **changes}
    plant = Proximity(RelativeOrbit(7e6), 100.0, jnp.eye(3))
    return SafeApproachSlidingMode(plant, wu2018.safety(), **settings)


def six_dof(**changes):
    return AdaptiveTerminalSixDof(**{**yue2018.PRINTED_GAINS, **changes})


def proximity(**changes):
    law = Exponential(0.05, 1e-3, Saturation(1e-3))
    parts = dict(
        model=Proximity(RelativeOrbit(7e6), 100.0, jnp.eye(3)),
        translation=TranslationalSlidingMode(RelativeOrbit(7e6), PDSurface(0.05), law),
        attitude=SlidingModeTracking(LinearSurface(0.1), law, jnp.eye(3)),
    )
    return ProximitySlidingMode(**{**parts, **changes})


def consensus(network=None, link=None):
    network = duan2024.network() if network is None else network
    link = SampledLink(SampleSchedule.periodic(0.26, 0.01)) if link is None else link
    return TwoLayerConsensus(network, link)


def mismatched_consensus_run():
    """A 3 x 4 network on a plant of 3 groups of 5 agents."""
    loop = ClosedLoop(SingleIntegratorAgents(3, 5), consensus())
    return simulate(loop, AgentsState(jnp.zeros((3, 5))), 0.0, 0.02, dt=0.01)


@pytest.mark.parametrize(
    "build, match",
    [
        # a misspelt surface silently flew the terminal one
        (lambda: safe_approach(surface="integrl"), "SafeApproachSlidingMode: `surface` must be"),
        # float(gamma) raised TypeError for a list
        (lambda: safe_approach(gamma=[0.5, 0.6]), "SafeApproachSlidingMode: `gamma` must be a"),
        (lambda: safe_approach(gamma=1.5), r"SafeApproachSlidingMode: `gamma` must lie in \(0"),
        # (2,) gains and limits broadcast against the (3,) channels: a shape error mid-run
        (lambda: safe_approach(k1=[0.5, 0.5]), "SafeApproachSlidingMode: `k1` must be a scalar"),
        (
            lambda: safe_approach(force_limit=[20.0, 20.0]),
            "SafeApproachSlidingMode: `force_limit` must be a scalar",
        ),
        # documented scalars: a (3,) adaptation rate or exponent gave (3,) scalar states
        (lambda: six_dof(zeta0=[50.0] * 3), "AdaptiveTerminalSixDof: `zeta0` must be a scalar"),
        (lambda: six_dof(p=[0.6, 0.6]), "AdaptiveTerminalSixDof: `p` must be a scalar"),
        (lambda: six_dof(mass=[1.0] * 3), "AdaptiveTerminalSixDof: `mass` must be a scalar"),
        (lambda: TimeVaryingSlidingMode(p2_0=[1.2] * 3), "`p2_0` must be a scalar"),
        (lambda: TimeVaryingSlidingMode(k0=[2.0] * 3), "`k0` must be a scalar"),
        (
            lambda: FractionalSlidingMode(
                RelativeOrbit(7e6),
                1.0,
                Exponential(1.0, 1e-3, Saturation(1e-3)),
                [0.5, 0.5],
                0.1,
                1.0,
            ),
            "FractionalSlidingMode: `alpha` must be a scalar",
        ),
        # no type checks: the swapped arguments failed inside the first trace
        (
            lambda: consensus(network=SampledLink(SampleSchedule.periodic(0.26, 0.01))),
            "TwoLayerConsensus: `network` must be a jaxatt.networks.TwoLayerNetwork",
        ),
        (lambda: consensus(link="periodic"), "TwoLayerConsensus: `link` must be"),
        (mismatched_consensus_run, "TwoLayerConsensus: the network couples 3 groups of 4"),
        (lambda: proximity(model=RelativeOrbit(7e6)), "ProximitySlidingMode: `model` must be"),
        (lambda: proximity(translation=None), "ProximitySlidingMode: `translation` must be"),
        # an MRP law read `.sigma` of the chaser's QuaternionState inside the trace
        (lambda: proximity(attitude=MRPPD(1.0, 1.0)), "ProximitySlidingMode: `attitude`"),
    ],
)
def test_bad_controller_arguments_are_refused(build, match, no_jaxtyping):
    with pytest.raises(ValueError, match=match):
        build()


def test_safe_approach_builds_under_vmap():
    """`float(gamma)` raised a ConcretizationTypeError for a traced gamma (STYLE behaviour 4).
    (`eval_shape`: traced as `vmap` would, without running; under `host_checked`, as in a
    tuning step, so that no `error_if` is attached.)"""
    plant, safety = Proximity(RelativeOrbit(7e6), 100.0, jnp.eye(3)), wu2018.safety()
    settings = dict(wu2018.GAINS, force_limit=wu2018.FORCE_LIMIT, torque_limit=wu2018.TORQUE_LIMIT)

    def build(gamma):
        return SafeApproachSlidingMode(plant, safety, **{**settings, "gamma": gamma})

    with host_checked():  # as in jaxatt's own programs: no run-time check to attach
        laws = jax.eval_shape(eqx.filter_vmap(build), jax.ShapeDtypeStruct((2,), jnp.float64))
    assert laws.gamma.shape == (2,)
