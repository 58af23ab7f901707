"""Dotted paths to fields of a module: `"controller.reaching_law.rho"`, `"terms[0].amplitude"`.

A path is a string, so it is hashable and compares by value: two tuning problems that name
the same fields are equal static arguments and share their compiled programs (a lambda
selector compares by identity and would compile again).
"""

import re
from collections.abc import Callable

from jaxtyping import PyTree


_TOKEN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)|\[(-?\d+|'[^']*'|\"[^\"]*\")\]")


def parse_path(path: str) -> tuple[tuple[str, str | int], ...]:
    """`("attr", name)` and `("item", key)` steps of a dotted path; `ValueError` if malformed."""
    if not isinstance(path, str) or not path:
        raise ValueError(f"path: a field path must be a non-empty string, got {path!r}.")
    parts: list[tuple[str, str | int]] = []
    position = 0
    for segment in path.split("."):
        if not segment:
            raise ValueError(f"path: empty segment in {path!r}.")
        offset = 0
        while offset < len(segment):
            match = _TOKEN.match(segment, offset)
            if match is None or (offset == 0) != (match.group(1) is not None):
                raise ValueError(
                    f"path: cannot parse {path!r} at character {position + offset} (use "
                    "attribute names separated by dots, and [k] for tuple or dict entries)."
                )
            if match.group(1) is not None:
                parts.append(("attr", match.group(1)))
            else:
                index = match.group(2)
                parts.append(("item", int(index) if index[0] not in "'\"" else index[1:-1]))
            offset = match.end()
        position += len(segment) + 1
    return tuple(parts)


def get_path(tree: PyTree, path: str):
    """The field of `tree` at `path`."""
    node = tree
    for kind, key in parse_path(path):
        node = getattr(node, key) if kind == "attr" else node[key]
    return node


def path_selector(path: str) -> Callable[[PyTree], PyTree]:
    """A function `tree -> get_path(tree, path)`, for `eqx.tree_at`."""
    parse_path(path)  # fail early on a malformed path

    def select(tree):
        return get_path(tree, path)

    return select
