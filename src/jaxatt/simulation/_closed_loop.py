"""The closed loop: plant + reference + controller + actuator, as one diffrax-style vector field."""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, PyTree

from .._custom_types import RealScalarLike
from ..controllers import AbstractController
from ..plants import AbstractPlant, QuaternionState
from ..references import AbstractReference, AttitudeReference, ConstantAttitude
from ._actuators import AbstractActuator, Ideal


class ClosedLoopState(eqx.Module):
    """Everything integrated together: the plant's, the reference's and the controller's states."""

    plant: PyTree[Array]
    reference: PyTree[Array]
    controller: PyTree[Array]


class HeldControl(eqx.Module):
    """A control and controller-state derivative held constant over a sample period."""

    control: Array
    controller_dot: PyTree[Array]


class ClosedLoop(eqx.Module):
    r"""$\dot y = f(t, y)$ for $y$ = (plant, reference, controller) states.

    $u_{cmd}, \dot x_c = \text{controller}(t, x_p, r(t), x_c)$, $u = \text{actuator}(u_{cmd})$,
    $\dot x_p = \text{plant}(t, x_p, u)$. Used as `ClosedLoop(...)(t, y, args)`: `args` is
    `None` under continuous control and a [`HeldControl`][] under a zero-order hold.

    **Arguments:**
    - `plant`: an [`jaxatt.plants.AbstractPlant`][].
    - `controller`: an [`jaxatt.controllers.AbstractController`][].
    - `reference`: an [`jaxatt.references.AbstractReference`][]; default: hold the identity.
    - `actuator`: an actuator model (e.g. [`Saturation`][]); default ideal.
    """

    plant: AbstractPlant
    controller: AbstractController
    reference: AbstractReference
    actuator: AbstractActuator

    def __init__(
        self,
        plant: AbstractPlant,
        controller: AbstractController,
        reference: AbstractReference | None = None,
        actuator: AbstractActuator | None = None,
    ):
        for name, value, kind in (
            ("plant", plant, AbstractPlant),
            ("controller", controller, AbstractController),
            ("reference", reference, (AbstractReference, type(None))),
            ("actuator", actuator, (AbstractActuator, type(None))),
        ):
            if not isinstance(value, kind):
                raise TypeError(f"ClosedLoop: `{name}` has the wrong type {type(value).__name__}.")
        if not issubclass(plant.state_type, controller.measurement_type):
            raise ValueError(
                f"ClosedLoop: {type(controller).__name__} needs a plant whose state is a "
                f"{controller.measurement_type.__name__}, but {type(plant).__name__} has "
                f"{plant.state_type.__name__}; pair the controller with the matching plant "
                "(RigidBodyQuaternion -> QuaternionState, RigidBodyMRP -> MRPState)."
            )
        self.plant = plant
        self.controller = controller
        self.reference = ConstantAttitude() if reference is None else reference
        self.actuator = Ideal() if actuator is None else actuator

    def init(self, t0: RealScalarLike, plant_state: PyTree[Array]) -> ClosedLoopState:
        """The closed-loop state at `t0` from the plant's initial state."""
        reference_state = self.reference.init(t0)
        reference, _ = self.reference(t0, reference_state)
        controller_state = self.controller.init(t0, plant_state, reference)
        return ClosedLoopState(plant_state, reference_state, controller_state)

    def control(self, t: RealScalarLike, y: ClosedLoopState) -> HeldControl:
        """The commanded control and controller-state derivative at `(t, y)`."""
        reference, _ = self.reference(t, y.reference)
        u_cmd, controller_dot = self.controller(t, y.plant, reference, y.controller)
        return HeldControl(u_cmd, controller_dot)

    def __call__(self, t: RealScalarLike, y: ClosedLoopState, args: HeldControl | None):
        reference, reference_dot = self.reference(t, y.reference)
        if args is None:
            u_cmd, controller_dot = self.controller(t, y.plant, reference, y.controller)
        else:
            u_cmd, controller_dot = args.control, args.controller_dot
        plant_dot = self.plant.vector_field(t, y.plant, self.actuator(u_cmd), None)
        return ClosedLoopState(plant_dot, reference_dot, controller_dot)

    def post_step(self, y: ClosedLoopState) -> ClosedLoopState:
        return ClosedLoopState(self.plant.post_step(y.plant), y.reference, y.controller)

    def signals(
        self, t: RealScalarLike, y: ClosedLoopState, held: HeldControl | None
    ) -> dict[str, Array]:
        """Signals recorded at a save time.

        `u` (applied control), `u_cmd` (commanded), `attitude_error` and `rate_error` (from
        the plant's `tracking_error`), `disturbance`, `quat_norm_error` ($\\|q\\|-1$, quaternion
        plants only), and the controller's `diagnostics`.
        """
        reference: AttitudeReference
        reference, _ = self.reference(t, y.reference)
        if held is None:
            u_cmd, _ = self.controller(t, y.plant, reference, y.controller)
        else:
            u_cmd = held.control
        attitude_error, rate_error = self.plant.tracking_error(y.plant, reference)
        out = {
            "u": self.actuator(u_cmd),
            "u_cmd": u_cmd,
            "attitude_error": attitude_error,
            "rate_error": rate_error,
            "disturbance": self.plant.disturbance_at(t),
        }
        if isinstance(y.plant, QuaternionState):
            out["quat_norm_error"] = jnp.sqrt(jnp.sum(y.plant.q**2)) - 1
        out.update(self.controller.diagnostics(t, y.plant, reference, y.controller))
        return out
