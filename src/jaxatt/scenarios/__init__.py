"""Applications: one module per reproduced paper (plus the built-in example and the demo).

Every scenario module exposes `build(...)`, `reproduce(out_dir, *, short=False)` and its
per-trajectory metrics, and registers them as one typed [`Scenario`][] (`SCENARIO`);
tuning problems are [`TuningProblem`][]s (`PROBLEM`). `REGISTRY` and `TUNING` map the CLI
names (`jaxatt reproduce NAME`, `jaxatt tune NAME`) to them. The library (`import jaxatt`)
never imports this package.
"""

from . import (
    chen2022_tuning as chen2022_tuning,
    chen2022_two_phase_power as chen2022_two_phase_power,
    demo as demo,
    flyaround as flyaround,
    rigid_body_pd as rigid_body_pd,
    yu2022_ftac_mrp as yu2022_ftac_mrp,
    yue2018 as yue2018,
    zhang2017 as zhang2017,
)
from ._protocol import Scenario as Scenario, TuningProblem as TuningProblem


REGISTRY: dict[str, Scenario] = {
    scenario.name: scenario
    for scenario in (
        rigid_body_pd.SCENARIO,
        chen2022_two_phase_power.SCENARIO,
        yu2022_ftac_mrp.SCENARIO,
        zhang2017.SCENARIO,
        yue2018.SCENARIO,
        flyaround.SCENARIO,
    )
}
"""Scenarios by CLI name (`jaxatt reproduce NAME`)."""

TUNING: dict[str, TuningProblem] = {chen2022_tuning.PROBLEM.name: chen2022_tuning.PROBLEM}
"""Tuning problems by CLI name (`jaxatt tune NAME`)."""
