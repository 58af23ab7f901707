"""The one writer of the scenarios' JSON reports (`metrics.json`, `tuning.json`).

A scenario returns its metrics as computed (an unsettled time is `inf`); the file holds their
JSON-safe form, `json_safe` of the returned dict (`inf` and NaN as `null`)."""

import json
import pathlib

from .._json import json_safe as json_safe


def write_json(path: str | pathlib.Path, tree) -> None:
    """Write `tree` to `path` as strict JSON (indent 2): non-finite floats become `null`
    (`json_safe`), and the encoder runs with `allow_nan=False`, so a NaN or infinity that
    reaches it another way raises `ValueError` instead of writing invalid JSON."""
    pathlib.Path(path).write_text(json.dumps(json_safe(tree), indent=2, allow_nan=False))
