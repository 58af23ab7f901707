"""jaxatt: differentiable spacecraft attitude and relative-motion control in JAX."""

import importlib.metadata

from . import numerics as numerics


try:
    __version__ = importlib.metadata.version("jaxatt")
except importlib.metadata.PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0"
