r"""Attitude mathematics: Hamilton quaternions, modified Rodrigues parameters, errors.

Every function acts on ONE sample (a `(4,)` quaternion, a `(3,)` MRP or rate); batch with
`jax.vmap`. Outputs keep the input dtype (float32 in, float32 out). Norms, normalizations
and divisions by norms go through [`jaxatt.numerics`][] (or a double `where`), so gradients
are finite at the identity and at rotations by $\pi$; each docstring states what happens at
its singular points.

**Conventions** (SPEC.md, "Decisions taken" and "General conventions"):

- *Quaternions* are Hamilton quaternions, scalar first: $q = [q_0, q_1, q_2, q_3]
  = [q_0, q_v]$, with $i^2 = j^2 = k^2 = ijk = -1$ and product
  $p \otimes q = [p_0 q_0 - p_v^\top q_v,\; p_0 q_v + q_0 p_v + p_v \times q_v]$.
- *Attitude:* `q` is the attitude of the body frame B relative to the inertial frame N:
  body components map to inertial components by $v_N = q \otimes v_B \otimes q^*$
  ([`quat_rotate`][]). For a rotation by $\phi$ about the unit axis $\hat n$,
  $q = [\cos(\phi/2), \hat n \sin(\phi/2)]$; $q$ and $-q$ are the same attitude.
- *Composition:* if `p` is the attitude of A relative to N and `q` that of B relative to A,
  $p \otimes q$ is the attitude of B relative to N.
- *Angular velocity* `omega` is the rate of B relative to N in body components [rad/s].
  Quaternion kinematics: $\dot q = \tfrac12 E(q)\,\omega = \tfrac12 q \otimes [0, \omega]$,
  $E(q) = \begin{bmatrix} -q_v^\top \\ q_0 I_3 + [q_v\times]\end{bmatrix}$.
- *Direction cosine matrices:* [`quat_to_dcm`][] and [`mrp_to_dcm`][] return the attitude
  matrix $C_{BN}$, which maps N-frame components to B-frame components
  ($v_B = C_{BN} v_N$):
  $C(q) = (q_0^2 - q_v^\top q_v) I_3 + 2 q_v q_v^\top - 2 q_0 [q_v\times]$,
  $C(\sigma) = I_3 + \frac{8[\sigma\times]^2 - 4(1 - \sigma^\top\sigma)[\sigma\times]}
  {(1 + \sigma^\top\sigma)^2}$. The two agree through [`mrp_from_quat`][];
  $C(p \otimes q) = C(q)\,C(p)$ and $\dot C = -[\omega\times] C$.
  $[v\times]$ is [`skew`][]`(v)`, with $[v\times] w = v \times w$.
- *MRPs:* $\sigma = q_v / (1 + q_0) = \hat n \tan(\phi/4)$; the shadow set
  $-\sigma/\|\sigma\|^2$ is the MRP of $-q$ (same attitude). [`mrp_from_quat`][] is literal
  (no canonicalization, $\|\sigma\| > 1$ when $q_0 < 0$); [`mrp_switch`][] picks
  $\|\sigma\| \le 1$. MRP kinematics: $\dot\sigma = G(\sigma)\,\omega$,
  $G(\sigma) = \tfrac14[(1 - \sigma^\top\sigma) I_3 + 2[\sigma\times] + 2\sigma\sigma^\top]$.
- *Euler angles* (3-2-1, roll-pitch-yaw, ordered $(\phi, \theta, \psi)$):
  $C_{BN} = R_1(\phi)R_2(\theta)R_3(\psi)$, kinematics $\dot a = R(\phi, \theta)\omega$,
  singular at $\cos\theta = 0$ (see `jaxatt.rotations._euler`).
- *Tracking errors* (SPEC seed 000 eqs. 7-10): $e = q_d^{-1} \otimes q$ is the attitude of
  B relative to the desired frame D, $e_\omega = \omega - C(e)\,\omega_d$ with
  $C(e) = C_{BD}$ = `quat_to_dcm(e)` mapping desired-frame to body-frame components; the MRP
  error satisfies $C(\sigma_e) = C(\sigma)\,C(\sigma_d)^\top$.
"""

from ._errors import (
    attitude_error_mrp as attitude_error_mrp,
    attitude_error_quat as attitude_error_quat,
    rate_error as rate_error,
    rate_error_mrp as rate_error_mrp,
)
from ._euler import (
    euler321_body_rates as euler321_body_rates,
    euler321_from_dcm as euler321_from_dcm,
    euler321_kinematics as euler321_kinematics,
    euler321_kinematics_matrix as euler321_kinematics_matrix,
    euler321_to_dcm as euler321_to_dcm,
    euler321_to_quat as euler321_to_quat,
)
from ._mrp import (
    mrp_compose as mrp_compose,
    mrp_from_dcm as mrp_from_dcm,
    mrp_from_quat as mrp_from_quat,
    mrp_kinematics as mrp_kinematics,
    mrp_kinematics_matrix as mrp_kinematics_matrix,
    mrp_shadow as mrp_shadow,
    mrp_switch as mrp_switch,
    mrp_to_dcm as mrp_to_dcm,
    quat_from_mrp as quat_from_mrp,
)
from ._quaternion import (
    quat_angle as quat_angle,
    quat_canonical as quat_canonical,
    quat_conjugate as quat_conjugate,
    quat_from_axis_angle as quat_from_axis_angle,
    quat_from_dcm as quat_from_dcm,
    quat_identity as quat_identity,
    quat_inverse as quat_inverse,
    quat_kinematics as quat_kinematics,
    quat_kinematics_matrix as quat_kinematics_matrix,
    quat_multiply as quat_multiply,
    quat_normalize as quat_normalize,
    quat_rotate as quat_rotate,
    quat_to_axis_angle as quat_to_axis_angle,
    quat_to_dcm as quat_to_dcm,
)
from ._skew import skew as skew, vee as vee
