"""Test configuration: float64 first (before any array exists), strict promotion, a key fixture.

The suite compiles exactly what users run: no compiler flag is set here. `.ci/run` sets three in
the open (`XLA_FLAGS="--xla_cpu_use_fusion_emitters=false --xla_backend_optimization_level=0
--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=500000"`, XLA:CPU's
faster-compiling code generator, no LLVM optimization, and one kernel per small time loop;
docs/testing.md), and `tests/test_xla_codegen.py` checks that they give the numbers of XLA's
defaults.
"""

import gc
import os


os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("JAXATT_SHORT", "1")
# The CLI turns the persistent compilation cache on by default; tests neither read nor write
# the user's cache (tests/simulation/test_compile_cache.py uses its own folders).
os.environ.setdefault("JAXATT_CACHE_DIR", "off")

import jax  # noqa: E402


jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

import jax.random as jr  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture
def key():
    return jr.key(0)


_CACHE_OPTIONS = (
    "jax_enable_compilation_cache",
    "jax_compilation_cache_dir",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
)


@pytest.fixture
def no_jaxtyping():
    """Switch off the jaxtyping call-time checks so the library's own ValueErrors are reached.

    (The suite type-checks jaxatt's annotations: `--jaxtyping-packages` in pyproject.toml. A
    wrong type or rank is then rejected by the annotation; users, who run without the hook,
    meet the ValueError the test checks.)
    """
    import jaxtyping

    jaxtyping.config.update("jaxtyping_disable", True)
    try:
        yield
    finally:
        jaxtyping.config.update("jaxtyping_disable", False)


@pytest.fixture(autouse=True)
def _compilation_cache_options_restored():
    """A test that changes JAX's persistent-compilation-cache options (a docs block calling
    `jaxatt.enable_compilation_cache()`, the CLI's cache tests) has them put back before the
    next test: off, or `.ci/run`'s shared folder for the run (docs/testing.md). A worker left
    reading and writing a test's own folder for the rest of the suite once crashed in XLA's
    executable deserialization (CI, stop 22)."""
    saved = {name: getattr(jax.config, name) for name in _CACHE_OPTIONS}
    yield
    if any(getattr(jax.config, name) != value for name, value in saved.items()):
        for name, value in saved.items():
            jax.config.update(name, value)
        from jax.experimental.compilation_cache import compilation_cache

        compilation_cache.reset_cache()


def _memory_map_count() -> int | None:
    """How many memory mappings this process holds (Linux: lines of /proc/self/maps)."""
    try:
        with open("/proc/self/maps", "rb") as maps:
            return maps.read().count(b"\n")
    except OSError:
        return None


def _memory_map_limit() -> int | None:
    """The kernel's per-process limit on memory mappings (Linux: vm.max_map_count)."""
    try:
        with open("/proc/sys/vm/max_map_count") as limit:
            return int(limit.read())
    except (OSError, ValueError):
        return None


_MAP_LIMIT = _memory_map_limit()


def pytest_runtest_teardown(item, nextitem):
    """Compiled programs stay under the memory-map limit. Every program XLA:CPU compiles
    holds memory mappings for its machine code (about 5 for a small program, more for a
    closed loop; for the programs of tests/simulation/test_simulate.py 1.6x more with XLA's
    default fusion emitters than with its IR emitters), and JAX keeps every compiled program
    for the life of the process. A pytest worker compiles about a thousand programs: one
    reached 43 000 mappings by the end of a CI-configured run. At the kernel's limit
    (vm.max_map_count, 65 530 by default) XLA's JIT fails to allocate ("LLVM compilation
    error: Cannot allocate memory") and the process dies with a segfault while the error
    propagates: the crash that hit 6 of 9 runs of the suite with XLA's defaults
    (docs/testing.md). When a worker is past half the limit, its compiled programs are
    dropped (`jax.clear_caches()`) and the tests after compile what they need again.

    Only between modules, never between two tests of one module: a module's shared programs
    must stay compiled, and tests count their traces (tests/reaching/test_convergence_times.py
    asserts one trace for all laws; a clear between its tests failed it in a CI run)."""
    if _MAP_LIMIT is None or (nextitem is not None and nextitem.path == item.path):
        return
    count = _memory_map_count()
    if count is not None and count > _MAP_LIMIT // 2:
        jax.clear_caches()
        gc.collect()


# Scheduling for `pytest -n 2`. Nearly all of the suite's time is XLA compilation, and a
# worker compiles a program once, so the work is handed out by test module: tests of one
# module (sharing fixtures, closed loops and horizons) run on one worker and compile their
# programs once. Modules whose tests share nothing (each notebook runs in its own kernel; each
# registry case builds and compiles its own closed loop) are
# handed out test by test. The longest units go first: started last, one would leave the other
# worker idle. (pytest-xdist's `--dist loadgroup` cannot be used: with pytest 9.2 its
# `xdist_group` markers are silently ignored, because node ids can no longer be rewritten.)
SPREAD_MODULES = ("tests/test_notebooks.py", "tests/test_registry.py")
FIRST_MODULES = (  # longest first
    "tests/test_notebooks.py",
    "tests/test_registry.py",
    "tests/test_cli.py",
    "tests/scenarios/test_zhang2021_gradients.py",
    "tests/scenarios/test_wu2018.py",
    "tests/test_docs.py",
)
# Modules that compile the same programs as another module join its unit: the Chen tests
# simulate the short reproduction that `jaxatt demo --short` runs (2 programs, 10 s).
JOIN_UNIT_OF = {"tests/scenarios/test_chen2022.py": "tests/test_cli.py"}


def pytest_addoption(parser):
    parser.addoption(
        "--full-notebooks",
        action="store_true",
        help="run only the notebooks in full mode (JAXATT_SHORT=0): every number their text "
        "states is asserted there (5 min 19 s with -n 2 on 2 cores; not in CI)",
    )


def pytest_collection_modifyitems(config, items):
    """Collection order is the order work is handed out: `FIRST_MODULES` first. Tests marked
    `full_notebooks` run with `--full-notebooks` and then alone; without it they are
    deselected (reported as such, never skipped)."""
    full = config.getoption("--full-notebooks")
    marked = [item.get_closest_marker("full_notebooks") is not None for item in items]
    keep = [item for item, m in zip(items, marked) if m == full]
    dropped = [item for item, m in zip(items, marked) if m != full]
    if dropped:
        config.hook.pytest_deselected(items=dropped)
        items[:] = keep

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
