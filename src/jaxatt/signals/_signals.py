"""Known functions of time: disturbance torques, inertia perturbations, open-loop commands.

A signal is an `eqx.Module` called as `signal(t)`; its amplitudes, frequencies and phases are
array fields, so they can be sampled in a Monte Carlo batch (`vmap`) or differentiated. Signals
add with `+` (a [`Sum`][]). Derivatives with respect to time come from `jax.jvp` (see
`jaxatt.references.IntegratedReference`), so no signal needs a hand-written derivative.
"""

import abc
import collections

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._custom_types import RealScalarLike
from .._validation import check, check_finite, check_positive, check_scalar


class AbstractSignal(eqx.Module):
    """A deterministic function of time `t` [s] returning an array of fixed shape."""

    @abc.abstractmethod
    def __call__(self, t: RealScalarLike) -> Float[Array, "..."]:
        """The signal's value at time `t`."""

    @abc.abstractmethod
    def bound(self) -> Float[Array, "..."] | None:
        """An elementwise bound $b \\ge |s(t)|$ valid for every $t$, or `None` if unknown.

        Used for checks that must hold along a whole run, e.g. that $J_0 + \\Delta J(t)$ stays
        positive definite ([`jaxatt.plants.RigidBody`][]).
        """

    def __add__(self, other: "AbstractSignal") -> "Sum":
        if not isinstance(other, AbstractSignal):
            return NotImplemented
        return Sum((self, other))


class Constant(AbstractSignal):
    """`value`, at every time. `Constant(jnp.zeros(3))` is "no disturbance"."""

    value: Float[Array, "..."]

    def __init__(self, value: Float[ArrayLike, "..."]):
        self.value = check_finite("Constant", "value", value)

    def __call__(self, t: RealScalarLike) -> Float[Array, "..."]:
        del t
        return self.value

    def bound(self) -> Float[Array, "..."]:
        return jnp.abs(self.value)


class Sinusoid(AbstractSignal):
    r"""$a \sin(\omega t + \varphi) + c$, elementwise; the four arrays broadcast together.

    **Arguments:**
    - `amplitude`: $a$, any shape (e.g. `(3,)` for a torque [N m], `(3, 3)` for an inertia
      perturbation [kg m^2]).
    - `frequency`: angular frequency $\omega$ [rad/s].
    - `phase`: $\varphi$ [rad], default 0 (use $\pi/2$ for a cosine).
    - `offset`: $c$, default 0.

    !!! example
        Chen et al. (2022)'s inertia uncertainty $\Delta J = \mathrm{diag}(\sin 0.1t,
        2\sin 0.2t, 3\sin 0.3t)$ is
        `Sinusoid(jnp.diag(jnp.array([1., 2, 3])), jnp.diag(jnp.array([.1, .2, .3])))`.
    """

    amplitude: Float[Array, "..."]
    frequency: Float[Array, "..."]
    phase: Float[Array, "..."]
    offset: Float[Array, "..."]

    def __init__(
        self,
        amplitude: Float[ArrayLike, "..."],
        frequency: Float[ArrayLike, "..."],
        phase: Float[ArrayLike, "..."] = 0.0,
        offset: Float[ArrayLike, "..."] = 0.0,
    ):
        self.amplitude = check_finite("Sinusoid", "amplitude", amplitude)
        self.frequency = check_finite("Sinusoid", "frequency", frequency)
        self.phase = check_finite("Sinusoid", "phase", phase)
        self.offset = check_finite("Sinusoid", "offset", offset)
        try:
            jnp.broadcast_shapes(
                self.amplitude.shape, self.frequency.shape, self.phase.shape, self.offset.shape
            )
        except ValueError:
            raise ValueError(
                "Sinusoid: `amplitude`, `frequency`, `phase` and `offset` must broadcast "
                f"together, got shapes {self.amplitude.shape}, {self.frequency.shape}, "
                f"{self.phase.shape}, {self.offset.shape}."
            ) from None

    def __call__(self, t: RealScalarLike) -> Float[Array, "..."]:
        shape = jnp.broadcast_shapes(
            self.amplitude.shape, self.frequency.shape, self.phase.shape, self.offset.shape
        )
        value = self.amplitude * jnp.sin(self.frequency * t + self.phase) + self.offset
        return jnp.broadcast_to(value, shape)

    def bound(self) -> Float[Array, "..."]:
        shape = jnp.broadcast_shapes(
            self.amplitude.shape, self.frequency.shape, self.phase.shape, self.offset.shape
        )
        return jnp.broadcast_to(jnp.abs(self.amplitude) + jnp.abs(self.offset), shape)


class Pulse(AbstractSignal):
    r"""A rectangular pulse of height `amplitude` on $[t_s, t_s + w)$, optionally repeated.

    With `period = P` the pulse repeats on $[t_s + kP, t_s + kP + w)$ for $k = 0, 1, \dots$;
    the default `period=None` is a single pulse. Its derivative in time is 0 almost everywhere
    (and gains that only scale it get gradients as usual).

    **Arguments:**
    - `amplitude`: pulse height, any shape.
    - `start`: $t_s$ [s], a scalar.
    - `width`: $w > 0$ [s], a scalar.
    - `period`: $P > w$ [s], a scalar, or `None`.
    """

    amplitude: Float[Array, "..."]
    start: Float[Array, ""]
    width: Float[Array, ""]
    period: Float[Array, ""] | None

    def __init__(
        self,
        amplitude: Float[ArrayLike, "..."],
        start: RealScalarLike,
        width: RealScalarLike,
        period: RealScalarLike | None = None,
    ):
        self.amplitude = check_finite("Pulse", "amplitude", amplitude)
        # `start`, `width` and `period` are one number each: a (3,) one broadcast against the
        # amplitude and silently gave a different pulse per entry.
        self.start = check_finite("Pulse", "start", check_scalar("Pulse", "start", start))
        self.width = check_positive("Pulse", "width", check_scalar("Pulse", "width", width))
        if period is None:
            self.period = None
        else:
            width_value = self.width
            self.period = check(
                "Pulse",
                "period",
                check_scalar("Pulse", "period", period),
                lambda xp, p: p > width_value,
                "must exceed `width`",
            )

    def __call__(self, t: RealScalarLike) -> Float[Array, "..."]:
        elapsed = t - self.start
        if self.period is not None:
            elapsed = jnp.where(elapsed >= 0, jnp.mod(elapsed, self.period), elapsed)
        on = (elapsed >= 0) & (elapsed < self.width)
        return jnp.where(on, self.amplitude, jnp.zeros_like(self.amplitude))

    def bound(self) -> Float[Array, "..."]:
        return jnp.abs(self.amplitude)


class Sum(AbstractSignal):
    """The sum of several signals of the same shape (also written `a + b`)."""

    terms: tuple[AbstractSignal, ...]

    def __init__(self, terms: tuple[AbstractSignal, ...] | list[AbstractSignal]):
        terms = tuple(terms)
        if not terms or not all(isinstance(term, AbstractSignal) for term in terms):
            raise ValueError("Sum: `terms` must be a non-empty sequence of signals.")
        flat: list[AbstractSignal] = []
        for term in terms:
            flat.extend(term.terms if isinstance(term, Sum) else (term,))
        self.terms = tuple(flat)

    def __call__(self, t: RealScalarLike) -> Float[Array, "..."]:
        total = self.terms[0](t)
        for term in self.terms[1:]:
            total = total + term(t)
        return total

    def bound(self) -> Float[Array, "..."] | None:
        bounds = [term.bound() for term in self.terms]
        if any(b is None for b in bounds):
            return None
        total = bounds[0]
        for b in bounds[1:]:
            total = total + b
        return total


_OUTPUT_SHAPES: collections.OrderedDict[int, tuple[AbstractSignal, tuple[int, ...]]] = (
    collections.OrderedDict()
)
_OUTPUT_SHAPES_KEPT = 64


def _output_shape(signal: AbstractSignal) -> tuple[int, ...]:
    """The shape of `signal(0.0)`, traced once per signal object: signals are immutable, so a
    module rebuilt around the same signal (`batch_field` rebuilds one per sample to check it)
    reuses the answer instead of tracing again (about 2 ms a trace). The cache holds the last
    `_OUTPUT_SHAPES_KEPT` signals by identity, each with a reference so its id stays its own."""
    hit = _OUTPUT_SHAPES.get(id(signal))
    if hit is not None and hit[0] is signal:
        return hit[1]
    shape = tuple(jax.eval_shape(signal, 0.0).shape)
    _OUTPUT_SHAPES[id(signal)] = (signal, shape)
    if len(_OUTPUT_SHAPES) > _OUTPUT_SHAPES_KEPT:
        _OUTPUT_SHAPES.popitem(last=False)
    return shape


def check_signal_shape(
    where: str, name: str, signal: AbstractSignal, shape: tuple[int, ...]
) -> None:
    """Evaluate `signal` at t = 0 abstractly and require `shape` (a trace-time check)."""
    if not isinstance(signal, AbstractSignal):
        raise ValueError(
            f"{where}: `{name}` must be a jaxatt.signals signal (Constant, Sinusoid, Pulse, Sum, "
            f"...), got {type(signal).__name__}."
        )
    out = _output_shape(signal)
    if out != tuple(shape):
        raise ValueError(f"{where}: `{name}` must return arrays of shape {shape}, got shape {out}.")
