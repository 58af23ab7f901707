"""The versions a result was computed with: `jaxatt --version`, and every scenario's report
(`"versions"` in `metrics.json`, `tuning.json`, `summary.json`; a sentence in `report.md`,
which names the process's `XLA_FLAGS` too, as the JSON reports' `"xla_flags"` does).

A number jaxatt reports depends on them: JAX's random bits (its default changed in 0.5) draw
the Monte Carlo samples, and XLA's code generation rounds differently from one jaxlib to the
next. Read from the installed distributions' metadata, so nothing is imported.
"""

import importlib.metadata
import os
import platform


PACKAGES = ("jaxatt", "jax", "jaxlib", "equinox", "diffrax", "optax", "numpy")
"""The distributions whose versions are reported, jaxatt first."""


def versions(also: tuple[str, ...] = ()) -> dict[str, str]:
    """`{distribution: version}` for `PACKAGES` and then the distributions `also` (those a
    particular result depends on besides, e.g. the LMI solvers `("cvxpy", "clarabel")`);
    jaxatt's is `jaxatt.__version__`, "not installed" where one is missing; and the Python
    version under `"python"`."""
    from . import __version__

    found = {"jaxatt": __version__}
    for name in (*PACKAGES[1:], *also):
        try:
            found[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            found[name] = "not installed"
    found["python"] = platform.python_version()
    return found


def xla_flags_phrase() -> str:
    """The process's `XLA_FLAGS` as a report names them: "XLA_FLAGS `...`" (quoted, stripped)
    or "XLA_FLAGS unset" (unset or blank)."""
    flags = os.environ.get("XLA_FLAGS", "").strip()
    return f"XLA_FLAGS `{flags}`" if flags else "XLA_FLAGS unset"


def versions_line() -> str:
    """One line (`jaxatt --version`): `jaxatt X (jax Y, jaxlib Z, ..., python W; XLA_FLAGS
    unset)`, the process's `XLA_FLAGS` as `xla_flags_phrase` names them."""
    found = versions()
    rest = ", ".join(f"{name} {version}" for name, version in found.items() if name != "jaxatt")
    return f"jaxatt {found['jaxatt']} ({rest}; {xla_flags_phrase()})"


def versions_sentence() -> str:
    """`Computed with jaxatt X, jax Y, ..., python W; XLA_FLAGS unset.`: `versions()` and the
    process's `XLA_FLAGS` (quoted as set, or "unset") as the last sentence of a Markdown report
    (`report.md`), the same record its JSON report holds (`"versions"`, `"xla_flags"`). XLA's
    options change how its code rounds, and a tuning path can follow the rounding."""
    found = ", ".join(f"{k} {v}" for k, v in versions().items())
    return f"Computed with {found}; {xla_flags_phrase()}."
