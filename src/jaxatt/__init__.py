"""jaxatt: differentiable spacecraft attitude and relative-motion control in JAX.

The top level exports the verbs and containers; components live in sub-packages:
`jaxatt.numerics`, `jaxatt.rotations`, `jaxatt.signals`, `jaxatt.references`,
`jaxatt.orbits`, `jaxatt.plants`, `jaxatt.sliding`, `jaxatt.reaching`, `jaxatt.performance`,
`jaxatt.networks`, `jaxatt.safety`, `jaxatt.shaping`, `jaxatt.controllers`,
`jaxatt.observers`, `jaxatt.simulation` (the closed-loop contract, actuators, solvers),
`jaxatt.metrics`, `jaxatt.montecarlo`. `jaxatt.tune` (optax), `jaxatt.plot` (matplotlib) and
the applications in `jaxatt.scenarios` load on first use: `import jaxatt` imports the core
only.

jaxatt never changes JAX's configuration on import: enable float64 yourself, first, when you need it
(`jax.config.update("jax_enable_x64", True)`), as the CLI, notebooks and tests do, and the
persistent compilation cache with `jaxatt.enable_compilation_cache()` (the CLI turns it on), and
XLA:CPU's one-kernel small loops with `jaxatt.enable_small_loop_kernels()` (before the first
computation).
"""

import importlib
import importlib.metadata

from . import (
    controllers as controllers,
    metrics as metrics,
    montecarlo as montecarlo,
    networks as networks,
    numerics as numerics,
    observers as observers,
    orbits as orbits,
    performance as performance,
    plants as plants,
    reaching as reaching,
    references as references,
    rotations as rotations,
    safety as safety,
    shaping as shaping,
    signals as signals,
    simulation as simulation,
    sliding as sliding,
)
from ._compilation_cache import (
    disable_compilation_cache as disable_compilation_cache,
    enable_compilation_cache as enable_compilation_cache,
)
from ._small_loops import enable_small_loop_kernels as enable_small_loop_kernels
from .simulation import (
    AbstractClosedLoop as AbstractClosedLoop,
    ClosedLoop as ClosedLoop,
    SimulationFailed as SimulationFailed,
    Status as Status,
    Trajectory as Trajectory,
    simulate as simulate,
)


_LAZY = ("plot", "scenarios", "tune")


def __getattr__(name: str):
    # These load on first use: `plot` imports matplotlib, `tune` optax, `scenarios` every
    # application.
    if name in _LAZY:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'jaxatt' has no attribute {name!r}")


try:
    __version__ = importlib.metadata.version("jaxatt")
except importlib.metadata.PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"
