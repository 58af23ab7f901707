"""Signal constructors refuse arguments that would give a plausible but wrong signal."""

import jax.numpy as jnp
import pytest

from jaxatt.signals import Pulse


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        # Each gave one pulse per entry (staggered, of different widths or periods) instead of
        # the documented single pulse train.
        ({"start": jnp.array([0.0, 1.0, 2.0]), "width": 1.0}, "`start` must be a scalar"),
        ({"start": 0.0, "width": jnp.array([1.0, 2.0, 3.0])}, "`width` must be a scalar"),
        (
            {"start": 0.0, "width": 1.0, "period": jnp.array([2.0, 3.0, 4.0])},
            "`period` must be a scalar",
        ),
    ],
)
def test_pulse_timing_arguments_must_be_scalars(kwargs, needle):
    with pytest.raises(ValueError, match=f"Pulse: {needle}"):
        Pulse(jnp.ones(3), **kwargs)


def test_pulse_with_scalar_timing_is_unchanged():
    pulse = Pulse(jnp.array([1.0, 0.0, -1.0]), start=1.0, width=0.5, period=2.0)
    assert jnp.array_equal(pulse(3.2), jnp.array([1.0, 0.0, -1.0]))
    assert jnp.array_equal(pulse(3.6), jnp.zeros(3))
