"""Print pyproject.toml's runtime dependencies pinned at their floors, for `pip install`.

`python .ci/floors.py [EXTRA ...]`: every `name>=X` of `[project] dependencies`, and of each
optional-dependency group named (`lmi`: cvxpy and Clarabel, which users install for the LMI
certificates), becomes `name==X` (JAX as `jax[cpu]==X`, which brings its jaxlib), so
`.ci/oldest` tests the oldest versions jaxatt declares it supports: a floor nobody installs is
a claim nobody checks. A requirement without a `>=` floor is an error.
"""

import pathlib
import re
import sys

import tomllib


# name, optional [extras], ">=", version: the only form the floors may take
_FLOOR = re.compile(r"([A-Za-z0-9_.-]+)(\[[^\]]*\])?\s*>=\s*([0-9][0-9A-Za-z.]*)")


def floors(pyproject: pathlib.Path, groups: list[str]) -> list[str]:
    project = tomllib.loads(pyproject.read_text())["project"]
    requirements = list(project["dependencies"])
    for group in groups:
        if group not in project["optional-dependencies"]:
            sys.exit(f"floors: pyproject.toml has no optional-dependency group {group!r}")
        requirements += project["optional-dependencies"][group]
    pins = []
    for requirement in requirements:
        match = _FLOOR.fullmatch(requirement)
        if match is None:
            sys.exit(f"floors: {requirement!r} has no single '>=' floor to install")
        name, extras, version = match.groups()
        if name == "jax":
            extras = "[cpu]"
        pin = f"{name}{extras or ''}=={version}"
        if pin not in pins:  # the test extra repeats the lmi extra's
            pins.append(pin)
    return pins


if __name__ == "__main__":
    root = pathlib.Path(__file__).resolve().parents[1]
    print(" ".join(floors(root / "pyproject.toml", sys.argv[1:])))
