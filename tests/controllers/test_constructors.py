"""Bad arguments to the controllers that have no test file of their own (their behaviour is
tested with their scenarios): each is refused eagerly with a `ValueError` naming the class and
the argument, before anything compiles."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.controllers import (
    AdaptiveTerminalSixDof,
    FractionalSlidingMode,
    SafeApproachSlidingMode,
    TimeVaryingSlidingMode,
)
from jaxatt.plants import RelativeOrbit
from jaxatt.reaching import Exponential, Saturation
from jaxatt.scenarios import wu2018, yue2018


def safe_approach(**changes):
    limits = dict(force_limit=wu2018.FORCE_LIMIT, torque_limit=wu2018.TORQUE_LIMIT)
    settings = {**wu2018.GAINS, **limits, **changes}
    return SafeApproachSlidingMode(wu2018.plant(j2=False), wu2018.safety(), **settings)


def six_dof(**changes):
    return AdaptiveTerminalSixDof(**{**yue2018.PRINTED_GAINS, **changes})


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
    ],
)
def test_bad_controller_arguments_are_refused(build, match, no_jaxtyping):
    with pytest.raises(ValueError, match=match):
        build()


def test_safe_approach_builds_under_vmap():
    """`float(gamma)` raised a ConcretizationTypeError for a traced gamma (STYLE behaviour 4)."""
    laws = eqx.filter_vmap(lambda g: safe_approach(gamma=g))(jnp.array([0.5, 0.6]))
    np.testing.assert_array_equal(laws.gamma, [0.5, 0.6])
