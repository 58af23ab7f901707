"""The linear sliding surface of quaternion attitude tracking."""

from jaxtyping import Array, ArrayLike, Float

from .._custom_types import Quaternion, Vec3
from .._validation import check_gain_shape, check_positive
from ..rotations import quat_kinematics
from ._base import AbstractSlidingSurface


class LinearSurface(AbstractSlidingSurface):
    r"""$s = e_\omega + \lambda e_v$, Chen et al. (2022) eq. (14).

    On $s = 0$ the attitude error obeys $\dot e_v = -\tfrac{\lambda}{2}(e_0 I + e_v^\times)e_v$,
    which converges exponentially on the hemisphere $e_0 > 0$ (Lemma 1 as corrected in SPEC
    000.3, E8). $\dot h = \lambda\dot e_v$ with $\dot e_v = \tfrac12(e_0 I + e_v^\times)e_\omega$
    (eq. 12).

    **Arguments:**
    - `slope`: $\lambda > 0$ [1/s], a scalar or per-axis (3,) array.

    !!! cite
        Chen Q, Zhu J, Tao M. Two-phase power reaching law based spacecraft attitude control.
        Control and Decision 37(5), 2022, eq. (14).
    """

    slope: Float[Array, "*k"]

    def __init__(self, slope: ArrayLike):
        self.slope = check_gain_shape(
            "LinearSurface", "slope", check_positive("LinearSurface", "slope", slope)
        )

    def __call__(self, e: Quaternion, e_omega: Vec3) -> Vec3:
        return e_omega + self.slope * e[1:]

    def attitude_term_rate(self, e: Quaternion, e_omega: Vec3) -> Vec3:
        return self.slope * quat_kinematics(e, e_omega)[1:]
