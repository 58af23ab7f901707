"""`ConstantAttitude`: its zero rates are known when the program is traced, and a closed loop
regulated with it computes what it computed with traced zeros."""

from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jaxtyping import Array

from jaxatt import simulate
from jaxatt.references import AbstractReference, AttitudeReference, ConstantAttitude
from jaxatt.scenarios import rigid_body_pd, yu2022_ftac_mrp
from jaxatt.simulation import ClosedLoop

from ..helpers import count_primitive


class TracedZeroRates(AbstractReference):
    """`ConstantAttitude` as it was: rates made with `jnp.zeros`, arrays of the program."""

    q_d: Array
    output_type: ClassVar[type] = AttitudeReference

    def init(self, t0):
        return None

    def __call__(self, t, state):
        zero = jnp.zeros(3, self.q_d.dtype)
        return AttitudeReference(self.q_d, zero, zero), None


def test_the_rates_are_numpy_constants_and_the_attitude_an_array():
    reference, state = ConstantAttitude()(0.0, None)
    assert state is None
    for rate in (reference.omega_d, reference.omega_d_dot):
        assert isinstance(rate, np.ndarray) and rate.dtype == reference.q_d.dtype
        np.testing.assert_array_equal(rate, np.zeros(3))
    assert isinstance(reference.q_d, jax.Array)  # a leaf: tunable, vmappable
    assert len(jax.tree.leaves(ConstantAttitude())) == 1


@pytest.mark.parametrize("scenario", ["rigid_body_pd", "yu2022"])
def test_a_regulation_loop_gives_what_it_gave_with_traced_zero_rates(scenario):
    """rigid_body_pd (MRP PD law: `rate_error_mrp` at every stage) and Yu 2022's finite-time
    law (its feed-forward rotates the desired rate and acceleration) over 0.3 s: every state
    and signal as with the reference's rates traced, and fewer products in the program. The
    values are the same numbers; a program fused differently may round its last bits
    differently, and Yu's finite-time law amplifies such differences while it converges."""
    x0 = jax.tree.map(
        lambda a: 0.3 * a[0], rigid_body_pd.random_initial_states(jax.random.key(3), 1)
    )
    loop = rigid_body_pd.build() if scenario == "rigid_body_pd" else yu2022_ftac_mrp.build()
    traced = ClosedLoop(
        loop.plant,
        loop.controller,
        TracedZeroRates(jnp.array([1.0, 0, 0, 0])),
        observer=loop.observer,
        actuator=loop.actuator,
    )

    def run(loop, x0):
        trajectory = simulate(loop, x0, 0.0, 0.3, dt=1e-3, save_every=10, throw=False)
        return trajectory.states, trajectory.signals

    known, with_traced = jax.jit(run)(loop, x0), jax.jit(run)(traced, x0)
    for a, b in zip(jax.tree.leaves(known), jax.tree.leaves(with_traced), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-15)
    # The flight software alone (controller and observer, no recorded signal) computes fewer
    # products: the PD law's `rate_error_mrp`, Yu's feed-forward.
    in_flight = [
        count_primitive(jax.make_jaxpr(lp.hold)(0.0, lp.init(0.0, x0)), "dot_general")
        for lp in (loop, traced)
    ]
    assert in_flight[0] < in_flight[1]
