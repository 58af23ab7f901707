"""`ConstantAttitude`: its zero rates are known when the program is traced, and a closed loop
regulated with it computes what it computed with traced zeros."""

from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from jaxatt import simulate
from jaxatt.references import AbstractReference, AttitudeReference, ConstantAttitude
from jaxatt.scenarios import rigid_body_pd
from jaxatt.simulation import ClosedLoop


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


def test_a_regulation_loop_gives_what_it_gave_with_traced_zero_rates():
    """rigid_body_pd (MRP PD law: `rate_error_mrp` at every stage) over 0.3 s: every state and
    signal as with the reference's rates traced (the formula's product with zero computed)."""
    loop = rigid_body_pd.build()
    traced = ClosedLoop(
        loop.plant,
        loop.controller,
        TracedZeroRates(jnp.array([1.0, 0, 0, 0])),
        actuator=loop.actuator,
    )
    x0 = jax.tree.map(
        lambda a: 0.5 * a[0], rigid_body_pd.random_initial_states(jax.random.key(3), 1)
    )

    @jax.jit
    def run(loop, x0):
        trajectory = simulate(loop, x0, 0.0, 0.3, dt=1e-3, save_every=10, throw=False)
        return trajectory.states, trajectory.signals

    for a, b in zip(jax.tree.leaves(run(loop, x0)), jax.tree.leaves(run(traced, x0)), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-15, atol=1e-15)
