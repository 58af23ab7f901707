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
    duan2024 as duan2024,
    flyaround as flyaround,
    rigid_body_pd as rigid_body_pd,
    shi2024 as shi2024,
    shi2024_tuning as shi2024_tuning,
    wu2018 as wu2018,
    yu2022_ftac_mrp as yu2022_ftac_mrp,
    yue2018 as yue2018,
    zhang2017 as zhang2017,
    zhang2021_hover as zhang2021_hover,
    zhang2021_tuning as zhang2021_tuning,
)
from ._protocol import (
    OPTIMIZERS as OPTIMIZERS,
    ChosenOptimizer as ChosenOptimizer,
    Scenario as Scenario,
    TuningProblem as TuningProblem,
    select_optimizer as select_optimizer,
)


REGISTRY: dict[str, Scenario] = {
    scenario.name: scenario
    for scenario in (
        rigid_body_pd.SCENARIO,
        chen2022_two_phase_power.SCENARIO,
        yu2022_ftac_mrp.SCENARIO,
        zhang2021_hover.SCENARIO,
        duan2024.SCENARIO,
        shi2024.SCENARIO,
        zhang2017.SCENARIO,
        yue2018.SCENARIO,
        flyaround.SCENARIO,
        wu2018.SCENARIO,
    )
}
"""Scenarios by CLI name (`jaxatt reproduce NAME`)."""

TUNING: dict[str, TuningProblem] = {
    problem.name: problem
    for problem in (
        chen2022_tuning.PROBLEM,
        zhang2021_tuning.PROBLEM,
        zhang2021_tuning.FINITE_TIME_PROBLEM,
        shi2024_tuning.PROBLEM,
    )
}
"""Tuning problems by CLI name (`jaxatt tune NAME`)."""
