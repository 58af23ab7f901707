r"""Euler-angle commands: desired 3-2-1 angles with their first two time derivatives."""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp

from .._custom_types import RealScalarLike, Vec3
from ..signals import AbstractSignal, Constant, check_signal_shape
from ._base import AbstractReference


class EulerAngleCommand(eqx.Module):
    r"""Desired 3-2-1 angles $y_d = (\phi_d, \theta_d, \psi_d)$ [rad] at one instant, with
    `rates` $\dot y_d$ [rad/s] and `accelerations` $\ddot y_d$ [rad/s^2]."""

    angles: Vec3
    rates: Vec3
    accelerations: Vec3


class EulerAngleTrajectory(AbstractReference):
    r"""Desired Euler angles $y_d(t)$ given by a signal of shape (3,), differentiated by autodiff.

    $\dot y_d$ and $\ddot y_d$ come from nested `jax.jvp` of the signal in $t$ (exact, no
    finite differences), so any [`jaxatt.signals.AbstractSignal`][] (a `Constant` set point, a
    `Sinusoid`, a `Sum`) is a reference for the decoupled double integrators of
    [`jaxatt.controllers.FeedbackLinearization`][]. No internal state.

    **Arguments:** `angles`: the signal $y_d(t)$, shape (3,) [rad]; default the constant zero.
    """

    angles: AbstractSignal
    output_type: ClassVar[type] = EulerAngleCommand

    def __init__(self, angles: AbstractSignal | None = None):
        if angles is None:
            angles = Constant(jnp.zeros(3))
        check_signal_shape("EulerAngleTrajectory", "angles", angles, (3,))
        self.angles = angles

    def init(self, t0: RealScalarLike) -> None:
        del t0
        return None

    def __call__(self, t: RealScalarLike, state: None) -> tuple[EulerAngleCommand, None]:
        del state
        t = jnp.asarray(t, dtype=jnp.result_type(float))

        def value_and_rate(t):
            return jax.jvp(self.angles, (t,), (jnp.ones_like(t),))

        (angles, rates), (_, accelerations) = jax.jvp(value_and_rate, (t,), (jnp.ones_like(t),))
        return EulerAngleCommand(angles, rates, accelerations), None
