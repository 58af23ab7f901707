"""The library's source at another git revision, for benchmarks that time two versions in
worker processes (`bench_defaults.py`, `bench_single.py`), each worker importing its own
version first on `PYTHONPATH`."""

import pathlib
import subprocess


ROOT = pathlib.Path(__file__).resolve().parents[1]


def unpack_source(revision: str, folder: pathlib.Path) -> pathlib.Path:
    """`src/` of `revision` (`git archive`) unpacked into `folder`; returns `folder / "src"`,
    the path to put first on a worker's `PYTHONPATH`."""
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", revision, "src"], check=True, capture_output=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return pathlib.Path(folder) / "src"
