"""jaxatt: differentiable spacecraft attitude and relative-motion control in JAX.

The top level exports the verbs and containers; components live in sub-packages:
`jaxatt.numerics`, `jaxatt.rotations`, `jaxatt.plants`, `jaxatt.references`,
`jaxatt.controllers`, `jaxatt.simulation` (closed loops, actuators, solvers),
`jaxatt.metrics`, `jaxatt.scenarios`, `jaxatt.plot`.

jaxatt never changes JAX's configuration: enable float64 yourself, first, when you need it
(`jax.config.update("jax_enable_x64", True)`), as the CLI, notebooks and tests do.
"""

import importlib.metadata

from . import (
    controllers as controllers,
    metrics as metrics,
    montecarlo as montecarlo,
    numerics as numerics,
    plants as plants,
    references as references,
    rotations as rotations,
    scenarios as scenarios,
    simulation as simulation,
)
from .simulation import (
    RESULTS as RESULTS,
    ClosedLoop as ClosedLoop,
    Trajectory as Trajectory,
    simulate as simulate,
)


def __getattr__(name: str):
    # `jaxatt.plot` imports matplotlib, so it loads on first use rather than with `jaxatt`.
    if name == "plot":
        import importlib

        return importlib.import_module(".plot", __name__)
    raise AttributeError(f"module 'jaxatt' has no attribute {name!r}")


try:
    __version__ = importlib.metadata.version("jaxatt")
except importlib.metadata.PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"
