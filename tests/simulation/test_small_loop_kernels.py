"""`jaxatt.enable_small_loop_kernels`: XLA:CPU compiles the time loops of one trajectory as one
kernel each, with the numbers of XLA's default threshold (to rounding: the
same program, other machine code; 1e-12 relative to each state's largest entry leaves room for
a few ulps amplified over 1000 RK4 steps of a sliding motion). A call that comes too late, a
bad threshold and a threshold the user set in `XLA_FLAGS` are each what the docstring says.

The process-wide option can only be set before JAX's CPU backend starts, so the two
configurations run in child processes (each under this process's other compiler options), and
so do the calls after the backend started, in a child started without the option (`.ci/run`
sets it for the suite)."""

import importlib.metadata
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import jaxatt
from jaxatt import _small_loops
from jaxatt._small_loops import (
    FIRST_SAFE_JAXLIB,
    OPTION,
    jaxlib_version,
    threshold_in_flags,
    without_threshold,
)


SCRIPT = """
import json, os, sys
import jax
import jaxatt
try:
    threshold = jaxatt.enable_small_loop_kernels() if sys.argv[1] == "on" else None
except RuntimeError as error:
    print(json.dumps({"refused": str(error)}))
    raise SystemExit(0)
flags = os.environ.get("XLA_FLAGS", "")
jax.config.update("jax_enable_x64", True)
import equinox as eqx
import numpy as np
from jaxatt import simulate
from jaxatt.scenarios import chen2022_two_phase_power as chen

loop = chen.build("M1")
run = eqx.filter_jit(lambda loop, x0: simulate(loop, x0, 0.0, 1.0, dt=1e-3, save_every=100))
compiled = run.lower(loop, chen.initial_state("D1")).compile().compiled.as_text()
one = run(loop, chen.initial_state("D1"))
leaves = lambda states: [np.asarray(leaf) for leaf in jax.tree.leaves(states)]
print(json.dumps({
    "threshold": threshold,
    "flags": flags,
    "small_calls": compiled.count('xla_cpu_small_call="true"'),
    "one": np.concatenate([leaf[-1].ravel() for leaf in leaves(one.states)]).tolist(),
    "one_status": int(one.status),
}))
"""


def _flags_without_the_option() -> str:
    return without_threshold(os.environ.get("XLA_FLAGS", ""))


@pytest.fixture(scope="module")
def children():
    env = dict(os.environ, XLA_FLAGS=_flags_without_the_option())
    out = {}
    for mode in ("off", "on"):
        done = subprocess.run(
            [sys.executable, "-c", SCRIPT, mode],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr[-3000:]
        out[mode] = json.loads(done.stdout.strip().splitlines()[-1])
    return out


def _close(a, b) -> None:
    a, b = np.asarray(a), np.asarray(b)
    scale = np.max(np.abs(a), axis=-1, keepdims=True)
    np.testing.assert_array_less(np.abs(a - b) / scale, 1e-12)


def _imports_compute() -> bool:
    """optimistix before 0.1 (the floor's 0.0.11, which diffrax 0.7.0 accepts) computes an array
    at import, so importing jaxatt starts JAX's backend and the call comes too late."""
    version = importlib.metadata.version("optimistix")
    return tuple(int(part) for part in version.split(".")[:2]) < (0, 1)


def test_the_time_loop_compiles_as_one_kernel_with_the_same_numbers(children):
    on, off = children["on"], children["off"]
    if jaxlib_version() < FIRST_SAFE_JAXLIB:
        # (the oldest versions' jaxlib 0.6.2) The call refuses before anything changes.
        assert "aborts the process on some loops compiled as one kernel" in on["refused"]
        assert off["small_calls"] == 0
        return
    if _imports_compute():
        # The call refuses, saying why and what to do instead (the environment variable).
        assert "importing jaxatt itself computes" in on["refused"]
        assert f"XLA_FLAGS=--xla_backend_extra_options={OPTION}=1000000" in on["refused"]
        assert off["small_calls"] == 0
        return
    assert on["threshold"] == jaxatt._small_loops.DEFAULT_BYTES_PER_ITERATION == 1_000_000
    assert on["flags"].endswith(f"--xla_backend_extra_options={OPTION}=1000000")
    assert threshold_in_flags(on["flags"]) == 1_000_000
    # Under XLA's default threshold no loop of the trajectory is folded; with the option on,
    # the time loops are (the step loop and the loop over save intervals).
    assert off["small_calls"] == 0
    assert on["small_calls"] >= 1
    assert on["one_status"] == off["one_status"] == 0
    _close(on["one"], off["one"])


# Calls after the backend started, in a child whose backend starts without the option (this
# process may have it: `.ci/run` sets it for the suite, and then the call confirms it).
LATE = """
import json, os
import jax.numpy as jnp
import jaxatt
from jaxatt._small_loops import OPTION


def attempt(flags):
    if flags is None:
        os.environ.pop("XLA_FLAGS", None)
    else:
        os.environ["XLA_FLAGS"] = flags
    try:
        outcome = {"returned": jaxatt.enable_small_loop_kernels()}
    except (RuntimeError, ValueError) as error:
        outcome = {"error": type(error).__name__, "message": str(error)}
    return {**outcome, "flags_after": os.environ.get("XLA_FLAGS")}


# The order of the checks is tested on every jaxlib: the one that refuses old jaxlibs (tested
# below) is lifted here, where no loop is ever folded (the backend starts without the option).
jaxatt._small_loops.FIRST_SAFE_JAXLIB = (0, 0, 0)
base = os.environ.get("XLA_FLAGS", "")
jnp.zeros(1).block_until_ready()  # the backend has started
print(json.dumps({
    "base": base,
    "as_started": attempt(base),
    "unset": attempt(None),
    "checked": attempt(f"--xla_backend_extra_options={OPTION}=50000"),
}))
"""


@pytest.fixture(scope="module")
def late():
    done = subprocess.run(
        [sys.executable, "-c", LATE],
        env=dict(os.environ, XLA_FLAGS=_flags_without_the_option()),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_a_call_after_the_backend_started_raises_and_leaves_xla_flags_as_they_were(late):
    started = late["as_started"]
    assert started["error"] == "RuntimeError"
    assert "before the first JAX computation" in started["message"]
    assert started["flags_after"] == late["base"]
    unset = late["unset"]
    assert unset["error"] == "RuntimeError" and "had already started" in unset["message"]
    assert unset["flags_after"] is None


# (Floats, strings and None are refused by the suite's runtime type checks before the body's own
# check, which refuses them too for a user without them.)
@pytest.mark.parametrize("bad", [1024, 4095, 0, -1, True])
def test_a_bad_threshold_is_refused_before_anything_changes(bad, monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_use_fusion_emitters=false")
    with pytest.raises(ValueError, match="`bytes_per_iteration` must be an integer of at least"):
        jaxatt.enable_small_loop_kernels(bad)
    assert os.environ["XLA_FLAGS"] == "--xla_cpu_use_fusion_emitters=false"


def test_a_threshold_set_in_xla_flags_is_kept(monkeypatch, late):
    # (On a jaxlib that runs folded loops: the refusal of older ones is tested below.)
    monkeypatch.setattr(_small_loops, "jaxlib_version", lambda: FIRST_SAFE_JAXLIB)
    # Below 4096 bytes the probe cannot tell the setting from XLA's default: kept, unchecked.
    flags = f"--xla_backend_extra_options=xla_cpu_use_multi_output_fusion,{OPTION}=2048"
    monkeypatch.setenv("XLA_FLAGS", flags)
    assert jaxatt.enable_small_loop_kernels() == 2048
    assert os.environ["XLA_FLAGS"] == flags
    # From 4096 on it is checked: the child's backend started without it.
    checked = late["checked"]
    assert checked["error"] == "RuntimeError"
    assert f"XLA_FLAGS sets {OPTION}=50000, but" in checked["message"]
    assert checked["flags_after"] == f"--xla_backend_extra_options={OPTION}=50000"
    monkeypatch.setenv("XLA_FLAGS", f"--xla_backend_extra_options={OPTION}=lots")
    with pytest.raises(ValueError, match="not an integer number of bytes"):
        jaxatt.enable_small_loop_kernels()


def test_a_jaxlib_that_aborts_on_folded_loops_is_refused_before_anything_changes(monkeypatch):
    flags = "--xla_cpu_use_fusion_emitters=false"
    monkeypatch.setenv("XLA_FLAGS", flags)
    monkeypatch.setattr(_small_loops, "jaxlib_version", lambda: (0, 7, 1))
    with pytest.raises(RuntimeError, match=r"jaxlib 0\.7\.1 aborts the process") as refused:
        jaxatt.enable_small_loop_kernels()
    assert "Small loops stay separate kernels" in str(refused.value)
    assert "jaxlib >= 0.7.2" in str(refused.value)
    assert os.environ["XLA_FLAGS"] == flags
    # A threshold the user set is refused too (it is kept, unchecked, on a safe jaxlib).
    flags = f"--xla_backend_extra_options={OPTION}=2048"
    monkeypatch.setenv("XLA_FLAGS", flags)
    with pytest.raises(RuntimeError, match=f"XLA_FLAGS sets {OPTION}=2048 in this process"):
        jaxatt.enable_small_loop_kernels()
    assert os.environ["XLA_FLAGS"] == flags
    monkeypatch.setattr(_small_loops, "jaxlib_version", lambda: FIRST_SAFE_JAXLIB)
    assert jaxatt.enable_small_loop_kernels() == 2048


def test_jaxlib_version_is_the_installed_release():
    import jaxlib.version

    assert ".".join(map(str, jaxlib_version())) == jaxlib.version.__version__.split(".dev")[0]


# What FIRST_SAFE_JAXLIB records, checked on the jaxlib installed: with the threshold set before
# the backend starts, a few thousand uniform random numbers (threefry's loop, split across
# threads) abort the process before 0.7.2 and are computed from it on.
ABORTS = """
import jax
import jax.random as jr

print(float(jr.uniform(jr.key(1), (1000, 4)).sum()))
"""


def test_the_first_safe_jaxlib_is_where_folded_parallel_loops_stop_aborting():
    env = dict(os.environ)
    env["XLA_FLAGS"] = f"{_flags_without_the_option()} --xla_backend_extra_options={OPTION}=1000000"
    done = subprocess.run(
        [sys.executable, "-c", ABORTS], env=env, capture_output=True, text=True, timeout=300
    )
    if jaxlib_version() < FIRST_SAFE_JAXLIB:
        assert done.returncode != 0
        assert "ParallelForkJoin" in done.stderr or "runtime_fork_join" in done.stderr
    else:
        assert done.returncode == 0, done.stderr[-3000:]
        assert 1800 < float(done.stdout.strip().splitlines()[-1]) < 2200  # 4000 draws, mean 1/2


def test_the_last_setting_in_xla_flags_is_the_one_read():
    assert without_threshold(f"--a=1 --xla_backend_extra_options=x,{OPTION}=9  --b") == "--a=1 --b"
    assert threshold_in_flags("") is None
    assert threshold_in_flags("--xla_cpu_use_fusion_emitters=false") is None
    flags = f"--xla_backend_extra_options={OPTION}=5000 --xla_backend_extra_options=a,{OPTION}=7000"
    assert threshold_in_flags(flags) == 7000
