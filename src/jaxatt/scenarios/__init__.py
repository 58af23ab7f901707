"""Scenarios: one public module per paper (plus the built-in demo), each with `build(...)` and
`reproduce(out_dir, *, short=False)`. `REGISTRY` maps the CLI names to modules."""

from types import ModuleType

from . import (
    chen2022_tuning as chen2022_tuning,
    chen2022_two_phase_power as chen2022_two_phase_power,
    rigid_body_pd as rigid_body_pd,
    yu2022_ftac_mrp as yu2022_ftac_mrp,
)


TUNING: dict[str, ModuleType] = {"chen2022": chen2022_tuning}
"""Tuning problems for `jaxatt tune NAME` (modules with a `run(out_dir, ...)`)."""

REGISTRY: dict[str, ModuleType] = {
    "rigid_body_pd": rigid_body_pd,
    "chen2022": chen2022_two_phase_power,
    "yu2022": yu2022_ftac_mrp,
}
