"""Observer switches must be booleans: `bool()` turned the string "False" into True and
silently picked the other reading of the paper's equations."""

import jax.numpy as jnp
import pytest

from jaxatt.observers import IntegralSlidingModeObserver, SuperTwistingObserver
from jaxatt.plants import RigidBodyQuaternion


_J = jnp.diag(jnp.array([1.0, 2.0, 3.0]))


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize(
    ("build", "needle"),
    [
        (
            lambda flag: SuperTwistingObserver(_J, 1.0, 1.0, acceleration=flag),
            "SuperTwistingObserver: `acceleration` must be True or False",
        ),
        (
            lambda flag: IntegralSlidingModeObserver(
                _J, RigidBodyQuaternion(_J), literal_alpha2=flag
            ),
            "IntegralSlidingModeObserver: `literal_alpha2` must be True or False",
        ),
    ],
)
def test_observer_switches_must_be_booleans(build, needle):
    for flag in ("False", None, 1.0):
        with pytest.raises(ValueError, match=needle):
            build(flag)
    assert build(False) is not None and build(True) is not None
