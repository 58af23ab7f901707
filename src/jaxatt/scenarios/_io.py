"""The one writer of the scenarios' JSON reports (`metrics.json`, `tuning.json`,
`summary.json`), and what every report records besides its numbers.

One representation, in the file and in Python: every `reproduce()` (and tuning `run()`, and the
demo) returns what `write_json` returns, which is exactly what `json.load` reads back from the
file it wrote. A number that is not finite is `null` in the file and `None` in the returned
dict: for a time (a settling, convergence or entry time) it means never, the event did not
happen within the horizon (computed as `inf`). For another field, its docstring says what its
`null` stands for: a value that is not finite (NaN for an inconclusive LMI bound in
`duan2024`), a field that does not apply (`observer_error_final` without an observer) or a
stage short mode skips. Tuples and arrays are lists, NumPy scalars Python numbers
(docs/getting-started.md states this for users).

Read a run's status first. Each run's block carries it (`result`, `status` or
`successful`); in a run that did not end successfully the other numbers are not results: a
`null` there may mean "failed", not "never", and a number computed from samples after the
failure time is not physical, except after a constraint violation, whose physics goes on
(Wu 2018's run without avoidance reports how deep it went). The claims and summaries built
from these blocks check the status themselves."""

import json
import os
import pathlib

from .._json import json_safe as json_safe
from .._versions import versions


def write_json(path: str | pathlib.Path, tree):
    """Write `tree` to `path` as strict JSON (indent 2) and return what a reader of the file
    gets (`json.loads` of the text written): non-finite floats become `null`/`None`
    (`json_safe`), tuples and arrays lists. The encoder runs with `allow_nan=False`, so a NaN
    or infinity that reaches it another way raises `ValueError` instead of writing invalid
    JSON."""
    text = json.dumps(json_safe(tree), indent=2, allow_nan=False)
    pathlib.Path(path).write_text(text)
    return json.loads(text)


def write_report(path: str | pathlib.Path, report: dict, *, also: tuple[str, ...] = ()) -> dict:
    """Write a scenario's `report` (a reproduction's metrics, a tuning run's report, the demo's
    summary) with `write_json`, adding the key `"versions"` (`jaxatt._versions.versions(also)`:
    jaxatt, JAX, jaxlib, Equinox, diffrax, optax, NumPy, then the distributions `also` that
    this report's numbers depend on besides, such as the LMI solvers, then Python) and the key
    `"xla_flags"` (the process's `XLA_FLAGS`, `""` when unset: XLA's options change how its
    code rounds, e.g. `jaxatt.enable_small_loop_kernels`, and a tuning path can follow the
    rounding), and return what a reader of the file gets. A `report` that already has either
    key is a `ValueError` (the record would be overwritten)."""
    for key in ("versions", "xla_flags"):
        if key in report:
            raise ValueError(
                f"write_report: `report` already has the key {key!r}, which write_report "
                f"records itself; rename that field of the report written to {str(path)!r}."
            )
    provenance = {"versions": versions(also), "xla_flags": os.environ.get("XLA_FLAGS", "")}
    return write_json(path, {**report, **provenance})
