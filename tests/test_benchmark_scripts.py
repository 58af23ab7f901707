"""The benchmark scripts are run by hand (benchmarks/README.md), not by the suite, so a broken
import would go unnoticed until someone records numbers. Each script's `--help` imports
everything it needs at module level (jax, jaxatt, the shared helpers) and must exit 0. All of
them run in one fresh interpreter (as `python benchmarks/bench_x.py --help` would, benchmarks/
first on sys.path), so JAX and jaxatt are imported once. `bench_quick.py` (the former
`jaxatt bench`) also runs for real at a tiny size. The GPU run prepared for a session that is
lent an accelerator (`benchmarks/gpu_run.sh`) is checked without a GPU: the arguments it passes
to `bench_montecarlo.py` must parse there, in the same interpreter."""

import json
import os
import pathlib
import subprocess
import sys

import pytest

from jaxatt._small_loops import OPTION, without_threshold


BENCHMARKS = pathlib.Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p.name for p in BENCHMARKS.glob("bench_*.py"))

CHILD = r"""
import contextlib, io, json, runpy, sys
bench_dir, scripts, gpu_lines = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3])
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
montecarlo = runpy.run_path(f"{bench_dir}/bench_montecarlo.py", run_name="bench_montecarlo")
gpu_runs = []
for line in gpu_lines:
    try:
        args = montecarlo["parse_args"](line.split())
        gpu_runs.append({"batches": args.batches, "horizon": args.horizon, "dtype": args.dtype})
    except SystemExit as stop:
        gpu_runs.append(f"exit {stop.code}")
# monte_carlo's batch_size reaches the programs the benchmarks time: their compiler options
# are those of the samples run at once (a chunk), and bench_roofline refuses a chunk of 0.
import _quick
import numpy as np
batch = {"q": np.zeros((2000, 4))}  # options read the first leaf's length
options = {
    str(size): _quick.make_jaxatt("monte_carlo", 0.01, 1e-3, 10, size).options(batch)
    for size in (None, 1500, 500)
}
roofline = runpy.run_path(f"{bench_dir}/bench_roofline.py", run_name="bench_roofline")
try:
    roofline["parse_args"](["--batch-size", "0"])
    refused = "parsed"
except SystemExit as stop:
    refused = f"exit {stop.code}"
print(json.dumps({"help": report, "gpu_runs": gpu_runs, "options": options, "refused": refused}))
"""


@pytest.fixture(scope="module")
def child_report():
    gpu = subprocess.run(
        ["bash", str(BENCHMARKS / "gpu_run.sh")],
        env={"DRY_RUN": "1", "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert gpu.returncode == 0, gpu.stderr
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            CHILD,
            str(BENCHMARKS),
            json.dumps(SCRIPTS),
            json.dumps(gpu.stdout.splitlines()),
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=BENCHMARKS.parent,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_every_benchmark_script_imports_and_parses_help(child_report):
    assert {"bench_montecarlo.py", "bench_gradient.py", "bench_scaling.py"} <= set(SCRIPTS)
    assert child_report["help"] == {script: "ok" for script in SCRIPTS}


def test_the_prepared_gpu_run_passes_arguments_bench_montecarlo_accepts(child_report):
    # issue 18: batches up to 10^6, in float32 and in float64
    assert child_report["gpu_runs"] == [
        {"batches": [1000, 10000, 100000, 1000000], "horizon": 2.0, "dtype": dtype}
        for dtype in ("float32", "float64")
    ]


def test_the_benchmarks_chunked_programs_compile_with_the_chunks_options(child_report):
    # bench_roofline.py --batch-size: the chunked program is compiled with the options
    # monte_carlo picks for a chunk (512-bit vectors for a scalarized loop from 1000 samples
    # at once, none below), not for the whole batch.
    from jaxatt.simulation import Performance

    def expected(n):
        return json.loads(json.dumps(Performance().resolve(n).compiler_options()))

    options = child_report["options"]
    assert options["None"] == options["1500"] == expected(2000) != expected(500)
    assert options["500"] == expected(500)
    assert child_report["refused"] == "exit 2"


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


def test_bench_single_compares_the_one_kernel_loops_with_xlas_default(tmp_path):
    # Both workers run this checkout, the second after jaxatt.enable_small_loop_kernels(); a
    # process whose XLA_FLAGS already set the threshold is refused (the baseline would not be
    # XLA's default).
    out = tmp_path / "small.json"
    command = [sys.executable, str(BENCHMARKS / "bench_single.py"), "--small-loop-kernels"]
    command += ["--families", "rigid_body_pd", "--steps", "20", "--save-every", "20"]
    command += ["--repeat", "1", "--out", str(out)]
    # (`.ci/run` sets the threshold for the suite: the workers start without it.)
    env = dict(os.environ, XLA_FLAGS=without_threshold(os.environ.get("XLA_FLAGS", "")))
    done = subprocess.run(command, capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    result = json.loads(out.read_text())
    assert result["ok"] and result["baseline_commit"] is None
    assert result["baseline"]["small_loop_threshold"] is None
    assert result["new"]["small_loop_threshold"] == 1_000_000
    assert [row["family"] for row in result["rows"]] == ["rigid_body_pd"]
    flags = f"--xla_backend_extra_options={OPTION}=5000"
    refused = subprocess.run(
        command, capture_output=True, text=True, timeout=300, env=dict(env, XLA_FLAGS=flags)
    )
    assert refused.returncode == 2 and f"XLA_FLAGS already sets {OPTION}" in refused.stderr
