"""Two processes joined by `jax.distributed` give the one-process Monte Carlo.

The test runs the multi-host recipe that `docs/scaling.md` shows, `examples/
multihost_monte_carlo.py`, as it is: twice with `--num-processes 2` (process ids 0 and 1, a
coordinator on a free local port, one CPU device each, so the batch is sharded over two
processes) and once with `--num-processes 1` (no `jax.distributed`), all three at once, small
batch and horizon. An odd batch exercises the padding to a multiple of the device count.
"""

import json
import os
import pathlib
import socket
import subprocess
import sys

import numpy as np
import pytest


EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "multihost_monte_carlo.py"
ARGS = ["--samples", "5", "--horizon", "1", "--dt", "1e-2", "--save-every", "10"]
TIMEOUT = 240  # s; a process that waits for a dead peer is killed, never hangs the suite


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def _env() -> dict:
    env = dict(os.environ)
    env["JAX_PLATFORMS"] = "cpu"
    # One CPU device per process; drop a forced device count the caller may have set.
    env["XLA_FLAGS"] = " ".join(
        f
        for f in env.get("XLA_FLAGS", "").split()
        if not f.startswith("--xla_force_host_platform_device_count")
    )
    src = str(pathlib.Path(__file__).resolve().parents[2] / "src")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    return env


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("distributed")
    coordinator = f"localhost:{_free_port()}"
    commands = {
        "two_0": ["--coordinator", coordinator, "--num-processes", "2", "--process-id", "0"],
        "two_1": ["--coordinator", coordinator, "--num-processes", "2", "--process-id", "1"],
        "one": ["--num-processes", "1"],
    }
    procs = {}
    for name, extra in commands.items():
        cmd = [sys.executable, str(EXAMPLE), *extra, *ARGS, "--json", str(out / f"{name}.json")]
        procs[name] = subprocess.Popen(
            cmd, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
    logs = {}
    try:
        for name, proc in procs.items():
            logs[name] = proc.communicate(timeout=TIMEOUT)[0]
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    for name, proc in procs.items():
        assert proc.returncode == 0, f"{name} failed:\n{logs.get(name, '')[-4000:]}"
    results = {}
    for name in ("two_0", "one"):
        results[name] = json.loads((out / f"{name}.json").read_text())
    # Only process 0 writes; process 1 must not have.
    assert not (out / "two_1.json").exists()
    results["log"] = logs["two_0"]
    return results


def test_two_processes_share_one_batch_over_both_devices(runs):
    two = runs["two_0"]
    assert two["processes"] == 2 and two["devices"] == 2
    assert two["batch_devices"] == 2  # the batch really was split over both processes
    assert runs["one"]["processes"] == 1 and runs["one"]["batch_devices"] == 1
    assert "2 process(es), 2 device(s)" in runs["log"]
    assert "| settling_time |" in runs["log"]  # process 0 printed the gathered table


def test_two_processes_equal_the_one_process_run(runs):
    one, two = runs["one"], runs["two_0"]
    assert two["status"] == one["status"] == [0] * 5
    assert set(two["metrics"]) == set(one["metrics"])
    for name, expected in one["metrics"].items():
        got = np.asarray(two["metrics"][name], dtype=float)
        assert got.shape == (5,), name
        np.testing.assert_allclose(got, np.asarray(expected, dtype=float), rtol=1e-12, err_msg=name)
