"""The benchmark scripts are run by hand (benchmarks/README.md), not by the suite, so a broken
import would go unnoticed until someone records numbers. Each script's `--help` imports
everything it needs at module level (jax, jaxatt, the shared helpers) and must exit 0. All of
them run in one fresh interpreter (as `python benchmarks/bench_x.py --help` would, benchmarks/
first on sys.path), so JAX and jaxatt are imported once. `bench_quick.py` (the former
`jaxatt bench`) also runs for real at a tiny size."""

import json
import pathlib
import subprocess
import sys


BENCHMARKS = pathlib.Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p.name for p in BENCHMARKS.glob("bench_*.py"))

CHILD = r"""
import contextlib, io, json, runpy, sys
bench_dir, scripts = sys.argv[1], json.loads(sys.argv[2])
sys.path.insert(0, bench_dir)
report = {}
for script in scripts:
    sys.argv = [script, "--help"]
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            runpy.run_path(f"{bench_dir}/{script}", run_name="__main__")
        report[script] = "no SystemExit"
    except SystemExit as stop:
        report[script] = "ok" if stop.code in (0, None) and "usage:" in out.getvalue() else (
            f"exit {stop.code}")
    except Exception as error:
        report[script] = f"{type(error).__name__}: {error}"
print(json.dumps(report))
"""


def test_every_benchmark_script_imports_and_parses_help():
    assert {"bench_montecarlo.py", "bench_gradient.py", "bench_scaling.py"} <= set(SCRIPTS)
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(BENCHMARKS), json.dumps(SCRIPTS)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=BENCHMARKS.parent,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report == {script: "ok" for script in SCRIPTS}


def test_bench_quick_prints_a_checked_table():
    done = subprocess.run(
        [sys.executable, str(BENCHMARKS / "bench_quick.py"), "--batches", "8", "--horizon", "0.05"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=BENCHMARKS.parent,
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    out = done.stdout
    assert "jaxatt/scan" in out and "float64" in out
    rows = [line for line in out.splitlines() if line.strip().startswith("8 |")]
    assert len(rows) == 1
