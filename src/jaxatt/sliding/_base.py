"""The sliding-surface interface."""

import abc

import equinox as eqx

from .._custom_types import Quaternion, Vec3


class AbstractSlidingSurface(eqx.Module):
    r"""A sliding variable $s = e_\omega + h(e)$ of the attitude-tracking errors.

    $e = q_d^{-1}\otimes q$ is the error quaternion and $e_\omega = \omega - C(e)\omega_d$ the
    rate error. Surfaces of this form have $\partial s/\partial e_\omega = I$, so a tracking
    controller that wants $\dot s = r(s)$ needs only $\dot e_\omega$ (from the dynamics) and
    $\dot h$ along the error kinematics $\dot e = \tfrac12 E(e) e_\omega$, which each surface
    gives in closed form:

    - `__call__(e, e_omega) -> s`;
    - `attitude_term_rate(e, e_omega) -> dh/dt`.

    Terminal, integral, time-varying and fractional surfaces join by implementing this
    interface (with their own state where they need one); controllers do not change.
    """

    @abc.abstractmethod
    def __call__(self, e: Quaternion, e_omega: Vec3) -> Vec3:
        """The sliding variable $s$."""

    @abc.abstractmethod
    def attitude_term_rate(self, e: Quaternion, e_omega: Vec3) -> Vec3:
        """$\\dot h(e)$ along $\\dot e = \\tfrac12 E(e)e_\\omega$."""
