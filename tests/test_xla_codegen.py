"""The test suite compiles with three XLA:CPU settings that `.ci/run` sets in the open
(docs/testing.md): the LLVM IR emitters instead of the default MLIR fusion emitters
(`--xla_cpu_use_fusion_emitters=false`, which compile jaxatt's closed loops 15-22 % faster,
benchmarks/README.md), LLVM's optimization level 0 instead of 2
(`--xla_backend_optimization_level=0`, which compiles them about 30 % faster and runs them
1.5-1.8x slower, a scalarized batch 6x), and the small-loop threshold of
`jaxatt.enable_small_loop_kernels`, at half its default (`--xla_backend_extra_options=
xla_cpu_small_while_loop_byte_threshold=500000`: a time loop of one trajectory runs as one
kernel, 2-4x faster at level 0). A user who runs jaxatt with none of them gets the same
numbers: Chen's M1 closed
loop (sliding, saturated, |s|^a), a scalarized vmapped batch of it and reverse-mode gradients
of its loss terms, computed here and in a child process under the other configuration (XLA's
defaults if this process has any setting, all three if it has none), must agree.

Both compile the same HLO; only the machine code differs (instruction order, vectorization, the
inlined math functions, `jaxatt.numerics.vectorized_log` among them, and for the third setting
one kernel per loop instead of one call per operation). Each result is compared
relative to its largest component (the final sliding variable's components are 1e-6 to 3e-4 of
a signal that starts near 1). Measured on jaxlib 0.10.2 (2026-12-04): the two emitters alone
agreed to 2.1e-15, both settings against XLA's defaults to 1.4e-14 (the sliding variable after
2000 RK4 steps; the gradient of the reaching law's two powers, evaluated at fixed inputs, bit
for bit); 1e-12 leaves room for a few more ulps amplified over the 2000 RK4 steps of a sliding
motion and still catches any real code-generation difference. The law's gradient was evaluated
at the run's s until `vectorized_log`: the sum of |s|^a ln|s| over components of 1e-6 that
differ between the two processes by 1e-8 of themselves then differed by 2.2e-13 (libm's log)
and 2.3e-12 (`vectorized_log`, which rounds differently at O0 and O2 within its 1 ulp), a
measure of the input's conditioning rather than of code generation.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest


def _name(flag: str) -> str:
    """`--xla_some_flag=value` -> `xla_some_flag`."""
    return flag.lstrip("-").split("=")[0]


# The suite's compile-time settings (`.ci/run`), as `XLA_FLAGS` spells them. (The third is
# named by its flag, `xla_backend_extra_options`: flipping it off drops any backend option.)
SETTINGS = (
    "--xla_cpu_use_fusion_emitters=false",
    "--xla_backend_optimization_level=0",
    "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=500000",
)
SETTING_NAMES = {_name(setting) for setting in SETTINGS}

# `results()` runs in this process and in a child under the other configuration: the numbers
# are computed by the same code.
SCRIPT = """
import equinox as eqx
import jax
import jax.numpy as jnp

jax.config.update("jax_enable_x64", True)
from jaxatt import simulate
from jaxatt.metrics import settling_time, soft_settling_time
from jaxatt.simulation import Performance
from jaxatt.numerics import safe_norm, sig_pow
from jaxatt.scenarios import chen2022_tuning, chen2022_two_phase_power as chen


def results():
    loop = chen.build("M1")
    traj = eqx.filter_jit(simulate)(loop, chen.initial_state("D1"), 0.0, 4.0, dt=2e-3)
    s, u = traj.signals["s"], traj.signals["u"]
    batch = chen2022_tuning.initial_states(jax.random.key(3), 3)
    omega_1s = eqx.filter_jit(jax.vmap(
        lambda x: simulate(
            loop, x, 0.0, 1.0, dt=5e-3, performance=Performance(scalarize=True)
        ).states.plant.omega[-1]
    ))(batch)
    # Reverse mode through the pieces of a tuning loss: the soft settling time of the run,
    # and the two-phase power reaching law (|s|^alpha and |s|^beta) at fixed s from 1e-9 to 1
    # (the same input in both processes: at the run's s, whose 1e-6 components differ between
    # the two by 1e-8 of themselves, sum |s|^a ln|s| amplifies those differences to 2e-12).
    soft = jax.jit(jax.grad(lambda s: soft_settling_time(traj.ts, safe_norm(s), 1e-2, 0.2)))
    law = loop.controller.reaching_law
    probe = jnp.geomspace(1e-9, 1.0, 600).reshape(200, 3) * jnp.array([[1.0, -1.0, 1.0]])
    rate = jax.jit(jax.grad(lambda a, b: jnp.sum(sig_pow(probe, a) + sig_pow(probe, b)), (0, 1)))
    return {
        "settling": float(settling_time(traj.ts, jnp.max(jnp.abs(s), axis=1), 1e-2)),
        "omega": traj.states.plant.omega[-1].tolist(),
        "s": s[-1].tolist(),
        "u": u[-1].tolist(),
        "u_sum": float(jnp.sum(jnp.abs(u))),
        "batch_omega": omega_1s.tolist(),
        "grad_soft": float(jnp.sum(jnp.abs(soft(s)))),
        "grad_law": [float(g) for g in rate(law.alpha, law.beta)],
    }
"""


def _settings_in(flags: str) -> int:
    """How many of the suite's settings `flags` names."""
    return sum(_name(f) in SETTING_NAMES for f in flags.split())


def _other_configuration(flags: str) -> str:
    """XLA_FLAGS with the suite's settings flipped: XLA's defaults for all if any is set, else
    all set. Any other flag is kept."""
    if _settings_in(flags):
        return " ".join(f for f in flags.split() if _name(f) not in SETTING_NAMES)
    return " ".join(flags.split() + list(SETTINGS))


def _in_this_process() -> dict:
    namespace: dict = {}
    exec(SCRIPT, namespace)
    return namespace["results"]()


def _in_a_child(flags: str) -> dict:
    command = SCRIPT + "\nimport json\nprint(json.dumps(results()))"
    done = subprocess.run(
        [sys.executable, "-c", command],
        env=dict(os.environ, XLA_FLAGS=flags),
        capture_output=True,
        text=True,
        timeout=600,
    )
    for name in SETTING_NAMES:
        if done.returncode != 0 and f"Unknown flag in XLA_FLAGS: --{name}" in done.stderr:
            # A jaxlib without this setting: there is no second configuration to compare.
            pytest.skip(f"this jaxlib does not know --{name}")
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_suites_compiler_settings_give_the_numbers_of_xlas_defaults():
    here = os.environ.get("XLA_FLAGS", "")
    other_flags = _other_configuration(here)
    # one run with XLA's defaults, one with (at least one of) the suite's settings
    assert (_settings_in(here) == 0) != (_settings_in(other_flags) == 0)
    mine, other = _in_this_process(), _in_a_child(other_flags)
    for key, value in mine.items():
        scale = np.max(np.abs(value))
        np.testing.assert_allclose(other[key], value, rtol=0, atol=1e-12 * scale, err_msg=key)
    # Not vacuous: the loop settles inside the horizon and the gradients are non-zero.
    assert 0.5 < mine["settling"] < 4.0
    assert mine["grad_soft"] > 0 and all(abs(g) > 0 for g in mine["grad_law"])
