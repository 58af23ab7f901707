r"""Two-body orbits, gravity models and relative-pose errors.

Every function acts on ONE sample (a `(3,)` position, a scalar element); batch with
`jax.vmap`. Units are SI (m, m/s, s, rad); `mu` defaults to the Earth's
[`MU_EARTH`][] $= 3.986004418\times10^{14}$ m^3/s^2.

- *Elements* ([`OrbitalElements`][]): semi-major axis `a` [m], eccentricity `e`, inclination
  `i`, right ascension of the ascending node `raan`, argument of periapsis `argp` and true
  anomaly `nu` [rad], in the inertial frame of the state vectors.
  [`elements_to_state`][] / [`state_to_elements`][] convert; [`kepler_propagate`][] moves the
  elements forward in closed form (elliptic orbits).
- *Gravity*: [`point_mass_gravity`][] $-\mu r/\|r\|^3$ and [`j2_gravity`][] (the $J_2$
  perturbation about the inertial $z$ axis).
- *Relative pose* (Zhang et al. 2021 eqs. 1-7): [`relative_pose_errors`][] gives the chaser's
  position, velocity, attitude and rate errors relative to a point fixed in a (tumbling)
  target's body frame, in chaser body axes.
- *Relative motion* about a Keplerian target, in its Hill frame (x radial out, y along-track,
  z orbit normal): [`relative_acceleration`][] (exact, any eccentricity, or linearised),
  [`clohessy_wiltshire_stm`][] and [`tschauner_hempel_stm`][] (closed-form transitions),
  [`hill_frame`][], [`inertial_to_hill`][], [`hill_to_inertial`][].
"""

from ._constants import J2_EARTH as J2_EARTH, MU_EARTH as MU_EARTH, R_EARTH as R_EARTH
from ._elements import (
    OrbitalElements as OrbitalElements,
    elements_to_state as elements_to_state,
    kepler_propagate as kepler_propagate,
    mean_motion as mean_motion,
    mean_to_true_anomaly as mean_to_true_anomaly,
    state_to_elements as state_to_elements,
    true_to_mean_anomaly as true_to_mean_anomaly,
)
from ._gravity import j2_gravity as j2_gravity, point_mass_gravity as point_mass_gravity
from ._relative_motion import (
    anomaly_rates as anomaly_rates,
    clohessy_wiltshire_stm as clohessy_wiltshire_stm,
    coriolis_matrices as coriolis_matrices,
    hill_frame as hill_frame,
    hill_rotation as hill_rotation,
    hill_to_inertial as hill_to_inertial,
    inertial_to_hill as inertial_to_hill,
    linear_relative_gravity as linear_relative_gravity,
    relative_acceleration as relative_acceleration,
    relative_gravity as relative_gravity,
    semi_latus_rectum as semi_latus_rectum,
    tschauner_hempel_stm as tschauner_hempel_stm,
)
from ._relative_pose import (
    PoseErrors as PoseErrors,
    relative_pose_errors as relative_pose_errors,
)
