"""The library's source at another git revision, for benchmarks that run two versions in
worker processes (`bench_defaults.py`, `bench_single.py`, `bench_tuning_path.py`), each worker
importing its own version first on `PYTHONPATH`, and the parts those benchmarks share."""

import json
import os
import pathlib
import subprocess
import sys
import tempfile
from collections.abc import Callable


ROOT = pathlib.Path(__file__).resolve().parents[1]


def unpack_source(revision: str, folder: pathlib.Path) -> pathlib.Path:
    """`src/` of `revision` (`git archive`) unpacked into `folder`; returns `folder / "src"`,
    the path to put first on a worker's `PYTHONPATH`."""
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", revision, "src"], check=True, capture_output=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return pathlib.Path(folder) / "src"


def run_version(script: pathlib.Path, worker_args: list[str], src: pathlib.Path) -> None:
    """Run the benchmark `script` in its worker mode (`worker_args`) in a new interpreter with
    `src` (a library version) first on `PYTHONPATH` and the benchmarks folder second."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(src), str(script.parent)]))
    print(f"worker: jaxatt from {src}", flush=True)
    subprocess.run([sys.executable, str(script), *worker_args], env=env, check=True)


def tuning_provenance() -> dict:
    """What a tuning benchmark's result starts with: its command line, the jax and optax
    versions and the load average when it was written."""
    import jax
    import optax

    return {
        "command": " ".join(sys.argv),
        "jax": jax.__version__,
        "optax": optax.__version__,
        "load_average": os.getloadavg(),
    }


def write_result(path: str | os.PathLike, result: dict) -> pathlib.Path:
    """Write a benchmark's `result` as indented JSON to `path` (folders made); returns it."""
    out = pathlib.Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1))
    return out


def run_both(run_worker: Callable, args, revision: str) -> tuple[dict, dict]:
    """`run_worker(args, src, out)` for the library of `revision` (unpacked into a temporary
    folder), then for this checkout's `src/`: `(baseline, new)`, each what it returned."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        base = run_worker(args, unpack_source(revision, tmp), tmp / "base.json")
        new = run_worker(args, ROOT / "src", tmp / "new.json")
    return base, new
