"""The documentation cannot drift from the code.

- Every public name of `jaxatt` and of its public sub-packages has an entry (`::: path`) in the
  API reference (`docs/api/*.md`), and every entry names something that exists.
- Every fenced ```python block of the site's pages (`docs/**/*.md`) and of README.md runs, in
  order, one namespace per page, in float64 (the conftest enables it), in a scratch folder.
- README's quick start and the getting-started page give the same two commands, and the test
  command among them is the one `.ci/run` runs.

`mkdocs build --strict` (run by `.ci/run`) checks the rest: cross-references, missing pages.
"""

import importlib
import pkgutil
import re
import textwrap
import types
from pathlib import Path

import pytest

import jaxatt


ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
API = DOCS / "api"

_ENTRY = re.compile(r"^::: +([\w.]+)\s*$", re.M)  # a mkdocstrings entry
_ANCHOR = re.compile(r"\[\]\(\)\{#([\w.]+)\}")  # an autorefs alias: `[](){#jaxatt.simulate}`
# A fenced block at any indentation (inside a list or an admonition too): indent, language, code.
_FENCE = re.compile(r"^([ \t]*)```[ \t]*([\w+-]*)[^\n]*\n(.*?)^\1```[ \t]*$", re.M | re.S)
_PYTHON = ("python", "py", "python3")


def public_modules() -> list[types.ModuleType]:
    """`jaxatt` and every sub-package whose name does not start with an underscore."""
    names = [m.name for m in pkgutil.iter_modules(jaxatt.__path__) if m.ispkg]
    return [jaxatt] + [
        importlib.import_module(f"jaxatt.{n}") for n in sorted(names) if not n.startswith("_")
    ]


def public_names(module: types.ModuleType) -> dict[str, object]:
    """A module's public names: every attribute not starting with an underscore, except
    modules from outside it (e.g. `importlib`) and plain (non-package) submodules. `jaxatt`
    declares its exports with `from ._x import Name as Name` (no `__all__`), so this is what
    a user can import."""
    names = {}
    for name, value in vars(module).items():
        if name.startswith("_"):
            continue
        if isinstance(value, types.ModuleType) and not (
            value.__name__.startswith(module.__name__ + ".") and hasattr(value, "__path__")
        ):
            continue  # outside modules, and plain submodules such as `jaxatt.cli` (an entry
            # point, documented as commands; it is an attribute only once something imports it)
        names[name] = value
    return names


def resolve(path: str) -> object:
    """The object a dotted path names: the longest importable module, then attributes."""
    parts = path.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ModuleNotFoundError:
            continue
        for attr in parts[k:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(path)


def documented_paths(pages: dict[str, str]) -> set[str]:
    paths = set()
    for text in pages.values():
        paths.update(_ENTRY.findall(text))
        paths.update(_ANCHOR.findall(text))
    return paths


def undocumented(pages: dict[str, str]) -> list[str]:
    """Public names without an API entry. A name counts as documented when its own path has an
    entry, or when it re-exports a class, function or module that has one elsewhere (e.g.
    `jaxatt.plants.Sinusoid` is `jaxatt.signals.Sinusoid`) under the same name."""
    paths = documented_paths(pages)
    identities = set()
    for path in paths:
        obj = resolve(path)
        if isinstance(obj, (type, types.FunctionType, types.ModuleType)):
            identities.add((id(obj), path.rsplit(".", 1)[-1]))
    missing = []
    for module in public_modules():
        for name, value in public_names(module).items():
            path = f"{module.__name__}.{name}"
            if path in paths:
                continue
            if isinstance(value, (type, types.FunctionType, types.ModuleType)) and (
                (id(value), name) in identities
            ):
                continue
            missing.append(path)
    return missing


@pytest.fixture(scope="module")
def api_pages() -> dict[str, str]:
    return {p.name: p.read_text() for p in sorted(API.glob("*.md"))}


def test_every_public_name_is_in_the_api_reference(api_pages):
    assert undocumented(api_pages) == []


def test_every_api_entry_names_something_that_exists(api_pages):
    for path in sorted(documented_paths(api_pages)):
        resolve(path)  # raises AttributeError / ModuleNotFoundError for a stale entry


def test_a_missing_entry_is_reported(api_pages):
    # The check above is only meaningful if removing one entry makes it fail.
    for removed in ("jaxatt.metrics.settling_time", "jaxatt.controllers.PAPER_ALPHA_BAR"):
        pages = {k: v.replace(f"::: {removed}\n", "") for k, v in api_pages.items()}
        assert undocumented(pages) == [removed]
    pages = {k: v.replace("::: jaxatt.signals.Sinusoid\n", "") for k, v in api_pages.items()}
    assert sorted(undocumented(pages)) == ["jaxatt.plants.Sinusoid", "jaxatt.signals.Sinusoid"]


def fenced_blocks(path: Path) -> list[tuple[str, str]]:
    """(language, code) of every fenced block, the code dedented."""
    return [(lang, textwrap.dedent(code)) for _, lang, code in _FENCE.findall(path.read_text())]


_SNIPPET = re.compile(r'^--8<-- "([^"]+)"\s*$')


def python_blocks(path: Path) -> list[str]:
    """The page's Python blocks, except those that only include a file (pymdownx.snippets,
    `--8<-- "path"`): that file is code the suite runs elsewhere (it must exist and be run by a
    test, see `test_included_files_are_run_by_a_test`)."""
    return [
        code for lang, code in fenced_blocks(path) if lang in _PYTHON and not _SNIPPET.match(code)
    ]


def test_included_files_are_run_by_a_test():
    pages = [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]
    included = {
        m.group(1)
        for page in pages
        for _, code in fenced_blocks(page)
        if (m := _SNIPPET.match(code))
    }
    tests_text = "\n".join(p.read_text() for p in (ROOT / "tests").rglob("test_*.py"))
    for path in included:
        assert (ROOT / path).is_file(), path
        name = Path(path).name
        assert name in tests_text, f"{path} is shown in the docs but no test names it"


PAGES_WITH_CODE = [
    p
    for p in [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]
    if p.parent != API and python_blocks(p)
]


def test_there_are_code_blocks_to_run():
    # Not vacuous: were _FENCE to find nothing, test_code_blocks_run would be an empty
    # parametrisation (skipped, not failed) and the two block checks above would pass on no
    # blocks at all. README and the getting-started page both show Python.
    assert {ROOT / "README.md", DOCS / "getting-started.md"} <= set(PAGES_WITH_CODE)


@pytest.mark.parametrize("page", PAGES_WITH_CODE, ids=lambda p: str(p.relative_to(ROOT)))
def test_code_blocks_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # blocks may write checkpoints or figures
    # A block that turns the compilation cache on writes into this test's folder, not the
    # user's ~/.cache (conftest turns the cache off again after the test).
    monkeypatch.setenv("JAXATT_CACHE_DIR", str(tmp_path / "xla"))
    namespace: dict = {"__name__": "__docs__"}
    for k, code in enumerate(python_blocks(page)):
        exec(compile(code, f"{page.relative_to(ROOT)}[python block {k}]", "exec"), namespace)
    import matplotlib.pyplot as plt

    plt.close("all")


def test_no_python_hides_in_other_blocks():
    # Code that does not run is not allowed: Python goes in ```python blocks, which run.
    pages = [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]
    hidden = [
        (str(page.relative_to(ROOT)), lang)
        for page in pages
        for lang, code in fenced_blocks(page)
        if lang not in _PYTHON and re.search(r"^(import \w|from [\w.]+ import )", code, re.M)
    ]
    assert hidden == []


def bash_block_after(path: Path, heading: str) -> str:
    text = path.read_text()
    start = text.index(heading)
    _, lang, code = _FENCE.search(text, start).groups()
    assert lang == "bash", (path, heading)
    return code.strip()


def test_quick_start_is_the_same_everywhere():
    readme = bash_block_after(ROOT / "README.md", "## Quick start")
    site = bash_block_after(DOCS / "getting-started.md", "## Quick start")
    assert readme == site
    assert len(readme.splitlines()) == 2
    # The second command is the test suite: the one CI runs.
    test_command = readme.splitlines()[1].split("&&")[-1].strip()
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert test_command in [line.strip() for line in ci]
