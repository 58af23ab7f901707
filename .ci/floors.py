"""Print pyproject.toml's runtime dependencies pinned at their floors, for `pip install`.

Every `name>=X` of `[project] dependencies` becomes `name==X` (JAX as `jax[cpu]==X`, which
brings its jaxlib), so `.ci/oldest` tests the oldest versions jaxatt declares it supports: a
floor nobody installs is a claim nobody checks. A dependency without a `>=` floor is an error.
"""

import pathlib
import re
import sys

import tomllib


# name, optional [extras], ">=", version: the only form the floors may take
_FLOOR = re.compile(r"([A-Za-z0-9_.-]+)(\[[^\]]*\])?\s*>=\s*([0-9][0-9A-Za-z.]*)")


def floors(pyproject: pathlib.Path) -> list[str]:
    pins = []
    for requirement in tomllib.loads(pyproject.read_text())["project"]["dependencies"]:
        match = _FLOOR.fullmatch(requirement)
        if match is None:
            sys.exit(f"floors: {requirement!r} has no single '>=' floor to install")
        name, extras, version = match.groups()
        if name == "jax":
            extras = "[cpu]"
        pins.append(f"{name}{extras or ''}=={version}")
    return pins


if __name__ == "__main__":
    root = pathlib.Path(__file__).resolve().parents[1]
    print(" ".join(floors(root / "pyproject.toml")))
