"""Test configuration: float64 first (before any array exists), strict promotion, a key fixture."""

import os


os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("JAXATT_SHORT", "1")

# XLA:CPU code generation. Most of the suite's time is compilation, and on jaxlib 0.10 the
# LLVM IR emitters this flag selects compile in 0.7-0.85x the time of the default MLIR fusion
# emitters (benchmarks/README.md; the suite: 453 s against 659 s). Same HLO, same results to
# rounding: tests/test_xla_codegen.py computes a closed loop, a scalarized batch and
# reverse-mode gradients under both and compares. The suite selects them unless XLA_FLAGS
# already says which, or JAXATT_TEST_XLA_DEFAULTS=1 asks for XLA's defaults. Set here, before
# XLA starts; xdist workers, notebook kernels and subprocesses inherit it.
LEGACY_EMITTERS = "--xla_cpu_use_fusion_emitters=false"


def _select_legacy_emitters() -> None:
    flags = os.environ.get("XLA_FLAGS", "")
    if os.environ.get("JAXATT_TEST_XLA_DEFAULTS") == "1" or "xla_cpu_use_fusion_emitters" in flags:
        return
    # XLA aborts the process on a flag it does not know: try it in a child first (once, in the
    # process that starts the xdist workers).
    import subprocess
    import sys

    env = dict(os.environ, XLA_FLAGS=f"{flags} {LEGACY_EMITTERS}".strip())
    probe = [sys.executable, "-c", "import jax; jax.devices()"]
    if subprocess.run(probe, env=env, capture_output=True).returncode == 0:
        os.environ["XLA_FLAGS"] = env["XLA_FLAGS"]


if "PYTEST_XDIST_WORKER" not in os.environ:
    _select_legacy_emitters()

import jax  # noqa: E402


jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

import jax.random as jr  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture
def key():
    return jr.key(0)


# Scheduling for `pytest -n 2`. Nearly all of the suite's time is XLA compilation, and a
# worker compiles a program once, so the work is handed out by test module: tests of one
# module (sharing fixtures, closed loops and horizons) run on one worker and compile their
# programs once. Modules whose tests share nothing (each notebook runs in its own kernel) are
# handed out test by test. The longest units go first: started last, one would leave the other
# worker idle. (pytest-xdist's `--dist loadgroup` cannot be used: with pytest 9.2 its
# `xdist_group` markers are silently ignored, because node ids can no longer be rewritten.)
SPREAD_MODULES = ("tests/test_notebooks.py",)
FIRST_MODULES = ("tests/test_notebooks.py", "tests/test_cli.py")  # longest first
# Modules that compile the same programs as another module join its unit: the Chen tests
# simulate the short reproduction that `jaxatt demo --short` runs (2 programs, 10 s).
JOIN_UNIT_OF = {"tests/scenarios/test_chen2022.py": "tests/test_cli.py"}


def pytest_collection_modifyitems(config, items):
    """Collection order is the order work is handed out: `FIRST_MODULES` first."""

    def rank(item) -> int:
        module = item.nodeid.split("::")[0]
        return FIRST_MODULES.index(module) if module in FIRST_MODULES else len(FIRST_MODULES)

    items.sort(key=rank)  # stable: the other modules keep their order


def pytest_xdist_make_scheduler(config, log):
    from xdist.scheduler import LoadScopeScheduling

    class ByModule(LoadScopeScheduling):
        """Each module is one unit of work, except `SPREAD_MODULES` (one unit per test) and
        `JOIN_UNIT_OF` (in another module's unit)."""

        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::")[0]
            return nodeid if module in SPREAD_MODULES else JOIN_UNIT_OF.get(module, module)

    config.option.loadscopereorder = False  # hand units out in collection order (see above)
    return ByModule(config, log)
