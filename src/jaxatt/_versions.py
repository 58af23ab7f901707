"""The versions a result was computed with: `jaxatt --version` and the demo's report.

A number jaxatt reports depends on them: JAX's random bits (its default changed in 0.5) draw
the Monte Carlo samples, and XLA's code generation rounds differently from one jaxlib to the
next. Read from the installed distributions' metadata, so nothing is imported.
"""

import importlib.metadata
import platform


PACKAGES = ("jaxatt", "jax", "jaxlib", "equinox", "diffrax", "optax", "numpy")
"""The distributions whose versions are reported, jaxatt first."""


def versions() -> dict[str, str]:
    """`{distribution: version}` for `PACKAGES` ("not installed" where one is missing; jaxatt
    run from a source tree without installing reads "0.0.0", as `jaxatt.__version__`), and the
    Python version under `"python"`."""
    found = {}
    for name in PACKAGES:
        try:
            found[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            found[name] = "0.0.0" if name == "jaxatt" else "not installed"
    found["python"] = platform.python_version()
    return found


def versions_line() -> str:
    """One line: `jaxatt X (jax Y, jaxlib Z, ..., python W)`."""
    found = versions()
    rest = ", ".join(f"{name} {version}" for name, version in found.items() if name != "jaxatt")
    return f"jaxatt {found['jaxatt']} ({rest})"
