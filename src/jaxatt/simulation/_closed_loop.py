r"""The closed-loop contract, and `ClosedLoop`: plant, reference, observer, controller, actuator.

```
            reference r(t) ─────────────────────────┐
                                                    v
 plant x ──measure──> y ──> observer ──estimate──> controller ──u_cmd──> actuator ──u──> plant
                      │                                ^
                      └────────────────────────────────┘
```

`simulate`, `monte_carlo` and the tuning objectives depend only on [`AbstractClosedLoop`][]:
initial state, vector field, held (sampled) outputs, discrete updates, status, events and
named signals. They never inspect what the state means.
"""

import abc

import equinox as eqx
import jax.numpy as jnp
import jax.tree_util as jtu
from jaxtyping import Array, Bool, Int, PyTree

from .._custom_types import RealScalarLike
from ..controllers import AbstractController
from ..metrics import AbstractMetric
from ..observers import AbstractObserver, ObservedMeasurement
from ..plants import AbstractPlant
from ..references import AbstractReference
from ._actuators import AbstractActuator, Ideal
from ._status import Status


class AbstractClosedLoop(eqx.Module):
    r"""What `simulate`, `monte_carlo` and the tuning objectives need of a closed loop.

    The state `y` is any pytree; `held` is what a zero-order hold keeps constant over a
    sample period (`None` under continuous control).

    - `check_state(x0, name, batch_shape)` and `check_initial(t0, x0)`: host-side checks of
      concrete initial values, before anything is compiled;
    - `init(t0, x0) -> y0`; optionally `init_delayed(t0, x0) -> y0`, the state at `t0` under
      `ZeroOrderHold(period, delay=True)`, where the actuator receives zeros over the first
      period (default: `init`);
    - `hold(t, y) -> held`: the sampled outputs (command and flight-software derivatives);
    - `vector_field(t, y, held) -> y_dot`;
    - `physics_update(t, y) -> (y, events)`: the discrete maps of the physical parts after a
      completed step, and the named events they raised;
    - `flight_update(t, y) -> y`: the discrete maps of the flight software (controller,
      observer), after every step under continuous control and at sample instants under a
      hold;
    - `status(t, y) -> Int[]`: a [`Status`][] code (0 when all is well);
    - `signals(t, y, held) -> dict`: named outputs recorded at the save times; `"u"` is the
      applied control by convention;
    - `default_metrics(tolerance)` (optional): what `monte_carlo` records when given no
      metrics.

    Under continuous control `held = None` means "the outputs at $(t, y)$": `vector_field(t, y,
    hold(t, y))` and `signals(t, y, hold(t, y))` must equal `vector_field(t, y, None)` and
    `signals(t, y, None)`. The streaming loop relies on it to evaluate the flight software once
    per step for both the signals and the solver's first stage.
    """

    @abc.abstractmethod
    def check_state(self, x0: PyTree, name: str, batch_shape: tuple[int, ...] = ()) -> PyTree:
        """Validate and convert a user-supplied initial state (or a batch of them)."""

    @abc.abstractmethod
    def check_initial(self, t0: float, x0: PyTree) -> None:
        """Refuse an inadmissible concrete initial state with a `ValueError`."""

    @abc.abstractmethod
    def init(self, t0: RealScalarLike, x0: PyTree[Array]) -> PyTree[Array]:
        """The closed-loop state at `t0`."""

    def init_delayed(self, t0: RealScalarLike, x0: PyTree[Array]) -> PyTree[Array]:
        """The closed-loop state at `t0` when the first command reaches the actuator one period
        late (it receives zeros until then); default: `init`."""
        return self.init(t0, x0)

    @abc.abstractmethod
    def hold(self, t: RealScalarLike, y: PyTree[Array]) -> PyTree[Array]:
        """The outputs a zero-order hold keeps over one sample period."""

    @abc.abstractmethod
    def vector_field(self, t: RealScalarLike, y: PyTree[Array], held: PyTree) -> PyTree[Array]:
        """$\\dot y$; `held` is `None` under continuous control."""

    @abc.abstractmethod
    def physics_update(
        self, t: RealScalarLike, y: PyTree[Array]
    ) -> tuple[PyTree[Array], dict[str, Bool[Array, ""]]]:
        """Discrete maps of the physical parts after a completed step, and their events."""

    @abc.abstractmethod
    def flight_update(self, t: RealScalarLike, y: PyTree[Array]) -> PyTree[Array]:
        """Discrete maps of the flight software (controller, observer)."""

    @abc.abstractmethod
    def status(self, t: RealScalarLike, y: PyTree[Array]) -> Int[Array, ""]:
        """A [`Status`][] code for the state `y` at `t`."""

    @abc.abstractmethod
    def signals(self, t: RealScalarLike, y: PyTree[Array], held: PyTree) -> dict[str, Array]:
        """Named outputs at a save time."""

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """Metric objects `monte_carlo` records when given none (default: none)."""
        del tolerance
        return {}

    def __call__(self, t: RealScalarLike, y: PyTree[Array], args: PyTree) -> PyTree[Array]:
        """`vector_field` with diffrax's `(t, y, args)` signature (`args` = held outputs)."""
        return self.vector_field(t, y, args)


class ClosedLoopState(eqx.Module):
    """Everything integrated together: the states of the plant, the reference, the controller,
    the observer and the actuator (`None` for a stateless component)."""

    plant: PyTree[Array]
    reference: PyTree[Array]
    controller: PyTree[Array]
    observer: PyTree[Array] = None
    actuator: PyTree[Array] = None


class HeldOutputs(eqx.Module):
    """What a zero-order hold keeps constant over a sample period: the command and the
    derivatives of the controller's and the observer's continuous states."""

    command: PyTree[Array]
    controller_dot: PyTree[Array]
    observer_dot: PyTree[Array]


def _check_type(where: str, name: str, value, kind) -> None:
    if not isinstance(value, kind):
        raise TypeError(f"{where}: `{name}` has the wrong type {type(value).__name__}.")


def _merge(out: dict, new: dict, owner: str) -> None:
    for key, value in new.items():
        if key in out:
            raise ValueError(
                f"ClosedLoop: the signal name {key!r} from the {owner} is already used by "
                "another component of the loop; rename one of them."
            )
        out[key] = value


def all_finite(tree: PyTree[Array]) -> Bool[Array, ""]:
    """Whether every floating entry of `tree` is finite."""
    leaves = [
        jnp.all(jnp.isfinite(leaf))
        for leaf in jtu.tree_leaves(tree)
        if jnp.issubdtype(jnp.result_type(leaf), jnp.inexact)
    ]
    return jnp.all(jnp.stack(leaves)) if leaves else jnp.array(True)


def _floating_dtypes(tree: PyTree) -> list:
    return [
        jnp.result_type(leaf)
        for leaf in jtu.tree_leaves(tree)
        if eqx.is_array(leaf) and jnp.issubdtype(jnp.result_type(leaf), jnp.floating)
    ]


def check_state_precision(where: str, closed_loop: PyTree, x0: PyTree, name: str) -> None:
    """Refuse an initial state with a floating leaf narrower than the precision the loop computes
    in (the promoted dtype of the loop's and the state's floating arrays).

    Such a state fails deep inside the time loop (the integrated state's dtype would change
    between steps: "scan body function carry input and carry output must have equal types").
    States built from Python numbers take JAX's default float and pass; the dtype is known at
    trace time, so this check also holds for traced states.
    """
    loop_dtypes = _floating_dtypes(closed_loop)
    if not loop_dtypes:
        return
    target = jnp.result_type(*loop_dtypes, *_floating_dtypes(x0))
    for path, leaf in jtu.tree_flatten_with_path(x0)[0]:
        if not eqx.is_array(leaf) or not jnp.issubdtype(jnp.result_type(leaf), jnp.floating):
            continue
        dtype = jnp.result_type(leaf)
        if dtype != target:
            raise ValueError(
                f"{where}: `{name}{jtu.keystr(path)}` is {dtype} but the closed loop computes in "
                f"{target} (the promoted dtype of its arrays and of `{name}`); build every array "
                f"in one precision (jnp.asarray(x, jnp.{target}))."
            )


class ClosedLoop(AbstractClosedLoop):
    r"""Plant, reference, (observer,) controller and actuator as one vector field.

    At time $t$, with $y = (x_p, x_r, x_c, x_o, x_a)$:

    $$r, \dot x_r = \text{reference}(t, x_r),\quad m = \text{plant.measure}(t, x_p),\quad
    \hat d = \text{observer.estimate}(t, m, x_o),$$
    $$u_{cmd}, \dot x_c = \text{controller}(t, m\ [\text{or } (m, \hat d)], r, x_c),\quad
    \dot x_o = \text{observer}(t, m, u_{cmd}, x_o),$$
    $$u, \dot x_a = \text{actuator}(t, u_{cmd}, x_a),\quad
    \dot x_p = \text{plant.vector\_field}(t, x_p, u).$$

    **Arguments:**
    - `plant`: an [`jaxatt.plants.AbstractPlant`][].
    - `controller`: an [`jaxatt.controllers.AbstractController`][] reading what the plant's
      `measure` returns (checked here).
    - `reference`: an [`jaxatt.references.AbstractReference`][]; default: the plant's
      `default_reference()` (the identity attitude for rigid bodies).
    - `actuator`: an [`AbstractActuator`][] (e.g. [`Saturation`][], [`FirstOrderLag`][]);
      default ideal.
    - `observer`: an [`jaxatt.observers.AbstractObserver`][] or `None`. Its estimate reaches
      controllers that read [`jaxatt.observers.ObservedMeasurement`][] (e.g.
      [`jaxatt.controllers.ObserverCompensated`][]).

    **Signals** at the save times: `"u"` (applied control), `"u_cmd"` (commanded), then the
    plant's, the reference's, the controller's, the observer's and the actuator's named
    signals (a name used twice is an error).

    **Status** after every completed step: `nonfinite_state` if any state is NaN or infinite,
    `invalid_plant` if `plant.valid` fails, `constraint_violated` if `controller.admissible`
    fails (in that order of precedence).
    """

    plant: AbstractPlant
    controller: AbstractController
    reference: AbstractReference
    actuator: AbstractActuator
    observer: AbstractObserver | None

    def __init__(
        self,
        plant: AbstractPlant,
        controller: AbstractController,
        reference: AbstractReference | None = None,
        actuator: AbstractActuator | None = None,
        observer: AbstractObserver | None = None,
    ):
        where = "ClosedLoop"
        _check_type(where, "plant", plant, AbstractPlant)
        _check_type(where, "controller", controller, AbstractController)
        _check_type(where, "reference", reference, (AbstractReference, type(None)))
        _check_type(where, "actuator", actuator, (AbstractActuator, type(None)))
        _check_type(where, "observer", observer, (AbstractObserver, type(None)))
        reference = plant.default_reference() if reference is None else reference
        controller.check_measurement(plant.measurement_type, observer is not None)
        if observer is not None and not issubclass(
            plant.measurement_type, observer.measurement_type
        ):
            raise ValueError(
                f"ClosedLoop: {type(observer).__name__} reads "
                f"{observer.measurement_type.__name__} measurements, but the plant measures "
                f"{plant.measurement_type.__name__}."
            )
        if not issubclass(reference.output_type, controller.reference_type):
            raise ValueError(
                f"ClosedLoop: {type(controller).__name__} reads "
                f"{controller.reference_type.__name__} references, but "
                f"{type(reference).__name__} produces {reference.output_type.__name__}."
            )
        self.plant = plant
        self.controller = controller
        self.reference = reference
        self.actuator = Ideal() if actuator is None else actuator
        self.observer = observer

    # --- Host-side checks and defaults -----------------------------------------------------

    def check_state(self, x0: PyTree, name: str = "x0", batch_shape: tuple[int, ...] = ()):
        x0 = self.plant.check_state(x0, name, batch_shape)
        check_state_precision("ClosedLoop", self, x0, name)
        return x0

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """The plant's default metrics (see `AbstractPlant.default_metrics`)."""
        return self.plant.default_metrics(tolerance)

    def check_initial(self, t0: float, x0: PyTree) -> None:
        if type(self.controller).check_initial is AbstractController.check_initial:
            return  # nothing to check: skip computing the initial inputs
        measurement, reference = _initial_inputs(self, t0, x0)
        self.controller.check_initial(t0, measurement, reference)

    # --- Pieces of the loop ----------------------------------------------------------------

    @property
    def _reads_estimate(self) -> bool:
        return issubclass(self.controller.measurement_type, ObservedMeasurement)

    def _controller_inputs(self, t, y: ClosedLoopState):
        """(reference output, plant measurement, what the controller reads)."""
        reference, _ = self.reference(t, y.reference)
        measurement = self.plant.measure(t, y.plant)
        if self.observer is not None and self._reads_estimate:
            estimate = self.observer.estimate(t, measurement, y.observer)
            return reference, measurement, ObservedMeasurement(measurement, estimate)
        return reference, measurement, measurement

    def _flight(self, t, y: ClosedLoopState) -> HeldOutputs:
        """The flight software's outputs: command, controller and observer derivatives."""
        reference, measurement, reads = self._controller_inputs(t, y)
        command, controller_dot = self.controller(t, reads, reference, y.controller)
        observer_dot = None
        if self.observer is not None:
            observer_dot = self.observer(t, measurement, command, y.observer)
        return HeldOutputs(command, controller_dot, observer_dot)

    # --- The contract ----------------------------------------------------------------------

    def init(self, t0: RealScalarLike, x0: PyTree[Array]) -> ClosedLoopState:
        return self._init(t0, x0, delayed=False)

    def init_delayed(self, t0: RealScalarLike, x0: PyTree[Array]) -> ClosedLoopState:
        """As `init`, but the actuator starts from the zero command it receives over the first
        period (a `FirstOrderLag` starts at rest, not at a command that has not reached it)."""
        return self._init(t0, x0, delayed=True)

    def _init(self, t0, x0, *, delayed: bool) -> ClosedLoopState:
        reference_state = self.reference.init(t0)
        observer_state = None
        if self.observer is not None:
            observer_state = self.observer.init(t0, self.plant.measure(t0, x0))
        y = ClosedLoopState(x0, reference_state, None, observer_state, None)
        reference, _, reads = self._controller_inputs(t0, y)
        controller_state = self.controller.init(t0, reads, reference)
        y = ClosedLoopState(x0, reference_state, controller_state, observer_state, None)
        command = self._flight(t0, y).command
        if delayed:
            command = jtu.tree_map(jnp.zeros_like, command)
        actuator_state = self.actuator.init(t0, command)
        return ClosedLoopState(
            x0, reference_state, controller_state, observer_state, actuator_state
        )

    def hold(self, t: RealScalarLike, y: ClosedLoopState) -> HeldOutputs:
        return self._flight(t, y)

    def vector_field(
        self, t: RealScalarLike, y: ClosedLoopState, held: HeldOutputs | None
    ) -> ClosedLoopState:
        _, reference_dot = self.reference(t, y.reference)
        flight = self._flight(t, y) if held is None else held
        applied, actuator_dot = self.actuator(t, flight.command, y.actuator)
        plant_dot = self.plant.vector_field(t, y.plant, applied)
        return ClosedLoopState(
            plant_dot, reference_dot, flight.controller_dot, flight.observer_dot, actuator_dot
        )

    def physics_update(
        self, t: RealScalarLike, y: ClosedLoopState
    ) -> tuple[ClosedLoopState, dict[str, Bool[Array, ""]]]:
        plant = self.plant.update(t, y.plant)
        events = self.plant.events(t, y.plant, plant)
        y = ClosedLoopState(
            plant,
            self.reference.update(t, y.reference),
            y.controller,
            y.observer,
            self.actuator.update(t, y.actuator),
        )
        return y, dict(events)

    def flight_update(self, t: RealScalarLike, y: ClosedLoopState) -> ClosedLoopState:
        reference, measurement, reads = self._controller_inputs(t, y)
        controller = self.controller.update(t, reads, reference, y.controller)
        observer = y.observer
        if self.observer is not None:
            observer = self.observer.update(t, measurement, y.observer)
        return ClosedLoopState(y.plant, y.reference, controller, observer, y.actuator)

    def status(self, t: RealScalarLike, y: ClosedLoopState) -> Int[Array, ""]:
        reference, _, reads = self._controller_inputs(t, y)
        finite = all_finite(y)
        valid = jnp.asarray(self.plant.valid(t, y.plant))
        admissible = jnp.asarray(self.controller.admissible(t, reads, reference, y.controller))
        code = jnp.where(
            ~finite,
            int(Status.nonfinite_state),
            jnp.where(
                ~valid,
                int(Status.invalid_plant),
                jnp.where(~admissible, int(Status.constraint_violated), 0),
            ),
        )
        return code.astype(jnp.int32)

    def signals(
        self, t: RealScalarLike, y: ClosedLoopState, held: HeldOutputs | None
    ) -> dict[str, Array]:
        reference, measurement, reads = self._controller_inputs(t, y)
        command = self._flight(t, y).command if held is None else held.command
        applied, _ = self.actuator(t, command, y.actuator)
        out = {"u": applied, "u_cmd": command}
        _merge(out, self.plant.signals(t, y.plant, reference), "plant")
        _merge(out, self.reference.signals(t, y.reference), "reference")
        _merge(out, self.controller.signals(t, reads, reference, y.controller), "controller")
        if self.observer is not None:
            _merge(out, self.observer.signals(t, measurement, y.observer), "observer")
        _merge(out, self.actuator.signals(t, command, y.actuator), "actuator")
        return out


@eqx.filter_jit
def _initial_inputs(loop: ClosedLoop, t0: float, x0: PyTree[Array]):
    """The controller's inputs at `t0` (for host-side initial checks), in one small program."""
    y0 = loop.init(t0, x0)
    reference, _, reads = loop._controller_inputs(t0, y0)
    return reads, reference
