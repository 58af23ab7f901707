"""The persistent compilation cache accepts jaxatt's programs and a new process reuses them.

JAX refuses to write a program that holds a host callback (an `eqx.error_if`, a
`jax.debug.print`) to its persistent cache, so every compiled program jaxatt builds itself
(`simulate`, the Monte Carlo batch with its metrics, a tuning step's loss and gradient) must be
free of them: failures come back as status codes and are raised on the host.
"""

import json
import os
import pathlib
import subprocess
import sys
import textwrap

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxatt
from jaxatt import cli, tune
from jaxatt.controllers import MRPPD
from jaxatt.metrics import ConvergenceTime, Peak, SettlingTime, TimeOutside
from jaxatt.montecarlo._batch import run_batch
from jaxatt.plants import MRPState, RigidBodyMRP
from jaxatt.simulation import ClosedLoop, Performance, Simulation
from jaxatt.simulation._compiled import compiled
from jaxatt.simulation._loop import integrate
from jaxatt.tune._loop import _loss_and_grad, _program


J = jnp.diag(jnp.array([20.0, 17.0, 15.0]))
METRICS = {
    "settling": SettlingTime("attitude_error_vector", 1e-3),
    "outside": TimeOutside("attitude_error_vector", 1e-2),
    "convergence": ConvergenceTime("attitude_error_vector", 1e-3),  # default window: traced
    "peak": Peak("u"),
}


def _loop():
    return ClosedLoop(RigidBodyMRP(J), MRPPD(60.0, 50.0))


def _x0s(n):
    sigma = jnp.tile(jnp.array([0.1, -0.2, 0.3]), (n, 1)) * jnp.arange(1, n + 1)[:, None] / n
    return MRPState(sigma, jnp.zeros((n, 3)))


def test_jaxatts_compiled_programs_hold_no_host_callback():
    # The programs `simulate`, `monte_carlo` and a tuning step compile (after their host-side
    # checks), lowered with the arguments those entry points pass.
    loop, x0s = _loop(), _x0s(3)
    x0 = MRPState(x0s.sigma[0], x0s.omega[0])
    sim = Simulation(0.0, 0.1, 1e-2)
    params = {"k1": tune.Parameter("controller.k1", tune.Positive())}
    objective = tune.SettlingObjective(t1=0.1, dt=1e-2, tolerance=1e-3)
    u = dict(tune.initial_unconstrained(loop, params))
    plain, scalarized = Performance(scalarize=False), Performance(scalarize=True)
    programs = {
        "simulate": compiled(integrate, plain, ()).lower(loop, x0, sim.with_performance(plain)),
        "monte_carlo": compiled(run_batch, plain, ()).lower(
            loop, x0s, sim.with_performance(plain), METRICS
        ),
        "monte_carlo, scalarized": compiled(run_batch, scalarized, ()).lower(
            loop, x0s, sim.with_performance(scalarized), METRICS, stream=True
        ),
        "tune step": _program(_loss_and_grad, objective, (u, x0s)).lower(
            u, loop, params, objective, x0s
        ),
    }
    programs = {name: lowered.as_text() for name, lowered in programs.items()}
    for name, text in programs.items():
        assert "stablehlo" in text, name  # really the lowered program
        assert "callback" not in text, f"{name}: the compiled program holds a host callback"
    # The check can fail: a traced argument check (the library's `eqx.error_if`) is seen.
    flagged = eqx.filter_jit(lambda x: jaxatt.metrics.settling_time(jnp.arange(3.0), x, x[0]))
    assert "callback" in flagged.lower(jnp.ones(3)).as_text()


SCRIPT = textwrap.dedent(
    """
    import json, sys
    import jax
    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    import jaxatt
    from jaxatt.controllers import MRPPD
    from jaxatt.metrics import ConvergenceTime, SettlingTime
    from jaxatt.montecarlo import monte_carlo
    from jaxatt.plants import MRPState, RigidBodyMRP
    from jaxatt.simulation import ClosedLoop, simulate
    from jaxatt.simulation._performance import _xla_knows_no_library_fusions

    folder = jaxatt.enable_compilation_cache(sys.argv[1])
    # Counted from here: what compiles before the cache is on is not jaxatt's to cache (on JAX
    # 0.6, importing diffrax compiles optimistix's module-level `jnp.array(0.0)`).
    events = []
    jax.monitoring.register_event_listener(lambda event, **kw: events.append(event))
    loop = ClosedLoop(RigidBodyMRP(jnp.diag(jnp.array([20.0, 17.0, 15.0]))), MRPPD(60.0, 50.0))
    x0s = MRPState(jnp.array([[0.1, -0.2, 0.3], [0.3, 0.1, -0.2]]), jnp.zeros((2, 3)))
    metrics = {"settling": SettlingTime("attitude_error_vector", 1e-3),
               "convergence": ConvergenceTime("attitude_error_vector", 1e-3)}
    mc = monte_carlo(loop, x0s, 0.0, 0.5, dt=1e-2, metrics=metrics)
    # A failing run raises on the host from the (cached) program: no callback needed.
    try:
        simulate(loop, MRPState(x0s.sigma[0], jnp.array([1e200, 0.0, 0.0])), 0.0, 0.5, dt=1e-2)
        failure = None
    except jaxatt.SimulationFailed as e:
        failure = [e.status.name, e.failure_time]
    print("RESULT" + json.dumps({
        "requests": events.count("/jax/compilation_cache/compile_requests_use_cache"),
        "hits": events.count("/jax/compilation_cache/cache_hits"),
        "entries": len(list(folder.iterdir())),
        "metrics": {k: v.tolist() for k, v in mc.metrics.items()},
        "failure": failure,
        # jaxatt asks XLA once per process whether it knows an option (an empty program): an
        # XLA without YNNPACK (`.ci/oldest`'s) refuses it, a request that caches nothing.
        "refused": 0 if _xla_knows_no_library_fusions() else 1,
    }))
    """
)


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("xla_cache")
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    # The child's only cache is `folder`: with the suite's (`.ci/run` sets one for every
    # process), a program another process wrote there was a hit in the first, "empty" run.
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    src = str(pathlib.Path(__file__).resolve().parents[2] / "src")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    runs = []
    for _ in range(2):
        done = subprocess.run(
            [sys.executable, "-c", SCRIPT, str(folder)],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr[-4000:]
        line = next(ln for ln in done.stdout.splitlines() if ln.startswith("RESULT"))
        runs.append(json.loads(line[len("RESULT") :]))
    return runs


def test_a_new_process_loads_every_program_from_the_cache(two_runs):
    first, second = two_runs
    assert first["requests"] > 0 and first["hits"] == 0  # empty folder: everything compiled
    assert first["entries"] >= first["requests"] - 1  # and written (none refused)
    assert second["requests"] == first["requests"]
    assert second["hits"] == second["requests"] - second["refused"]  # nothing compiled again
    assert second["entries"] == first["entries"]


def test_cached_programs_give_the_same_results_and_still_report_failures(two_runs):
    first, second = two_runs
    for name, values in first["metrics"].items():
        np.testing.assert_array_equal(second["metrics"][name], values, err_msg=name)
    assert np.all(np.isfinite(first["metrics"]["convergence"]))
    assert first["failure"] == second["failure"]
    assert first["failure"][0] == "nonfinite_state" and first["failure"][1] == pytest.approx(1e-2)


def test_cli_turns_the_cache_on_where_asked_and_off_on_request(tmp_path, monkeypatch):
    # tests/conftest.py restores JAX's cache options after this test.
    def setup(argv):
        jax.config.update("jax_compilation_cache_dir", None)
        cli._setup_cache(cli.build_parser().parse_args(argv))
        return jax.config.jax_compilation_cache_dir

    monkeypatch.delenv("JAXATT_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert setup(["demo"]) == str(tmp_path / "xdg" / "jaxatt" / "xla")  # on by default
    assert setup(["demo", "--cache-dir", str(tmp_path / "a")]) == str(tmp_path / "a")
    assert (tmp_path / "a").is_dir()
    assert setup(["reproduce", "x", "--no-cache"]) is None
    assert not jax.config.jax_enable_compilation_cache
    # --no-cache also turns off a cache that JAX's own variables enabled
    # (JAX_COMPILATION_CACHE_DIR, as .ci/run sets); JAXATT_CACHE_DIR=off leaves such a cache on.
    jax.config.update("jax_enable_compilation_cache", True)
    jax.config.update("jax_compilation_cache_dir", str(tmp_path / "jax"))
    cli._setup_cache(cli.build_parser().parse_args(["demo", "--no-cache"]))
    assert not jax.config.jax_enable_compilation_cache
    jax.config.update("jax_enable_compilation_cache", True)
    monkeypatch.setenv("JAXATT_CACHE_DIR", "off")
    cli._setup_cache(cli.build_parser().parse_args(["demo"]))
    assert jax.config.jax_enable_compilation_cache
    assert jax.config.jax_compilation_cache_dir == str(tmp_path / "jax")
    monkeypatch.delenv("JAXATT_CACHE_DIR")
    monkeypatch.setenv("JAXATT_CACHE_DIR", str(tmp_path / "env"))
    assert setup(["tune", "chen2022"]) == str(tmp_path / "env")
    monkeypatch.setenv("JAXATT_CACHE_DIR", "off")
    assert setup(["demo"]) is None
    assert setup(["demo", "--cache-dir", str(tmp_path / "b")]) == str(tmp_path / "b")
    with pytest.raises(ValueError, match="min_compile_time"):
        jaxatt.enable_compilation_cache(tmp_path, min_compile_time=-1.0)
