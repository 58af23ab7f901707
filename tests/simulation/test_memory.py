"""A run whose saved trajectories cannot fit in memory is refused before compiling, naming the
arguments that set its size (jaxatt.simulation._memory). Before the check, `simulate` over
10^6 s at dt = 1e-3 compiled for 3.7 s and then failed with XLA's "RESOURCE_EXHAUSTED: Out of
memory allocating 32000000032 bytes", naming no argument; a size the host could overcommit
would have grown until the kernel killed the process."""

import jax
import jax.random as jr
import pytest

import jaxatt
from jaxatt import montecarlo as mc
from jaxatt.simulation import Simulation, _memory

from ..helpers import compile_count, mrp_pd_loop


@pytest.fixture(scope="module")
def case():
    loop = mrp_pd_loop()
    x0s = mc.mrp_states(jr.key(0), 4, max_rate=0.1, max_angle=1.0)
    return loop, x0s, jax.tree.map(lambda a: a[0], x0s)


def test_simulate_refuses_a_trajectory_larger_than_memory_before_compiling(case):
    loop, _, x0 = case
    before = compile_count()
    with pytest.raises(ValueError, match=r"simulate: the saved trajectories need .* GiB") as info:
        jaxatt.simulate(loop, x0, 0.0, 1e6, dt=1e-3)  # 10^9 saves
    assert "raise `save_every` (now 1)" in str(info.value)
    assert "of memory of this CPU" in str(info.value)
    assert compile_count() == before


def test_the_check_runs_inside_an_outer_jit_vmap_or_grad(case, monkeypatch):
    # Regression (stop 48's note): inside an outer jit, vmap or grad the check was skipped, and
    # the run compiled and failed in XLA's allocator (or grew until killed). It reads shapes
    # only, so it runs there too. A small limit here (room for 3003 saves; 4001 asked), so
    # that without the check the runs are small and the test fails cleanly.
    loop, x0s, x0 = case
    one = _memory.record_bytes(loop, x0, 0.0)
    monkeypatch.setattr(_memory, "memory_limit", lambda: 3 * 1001 * one + 1)
    before = compile_count()
    with pytest.raises(ValueError, match=r"1 sample\(s\) x 4001 saves"):
        jax.jit(lambda x: jaxatt.simulate(loop, x, 0.0, 4.0, dt=1e-3).ts[-1])(x0)
    with pytest.raises(ValueError, match=r"1 sample\(s\) x 4001 saves"):
        jax.vmap(lambda x: jaxatt.simulate(loop, x, 0.0, 4.0, dt=1e-3).ts[-1])(x0s)
    # monte_carlo inside jit: the batch's size is its leading axis, known when tracing.
    with pytest.raises(ValueError, match=r"4 sample\(s\) x 1001 saves"):
        jax.jit(
            lambda xs: mc.monte_carlo(loop, xs, 0.0, 1.0, dt=1e-3, keep_trajectories=True).status
        )(x0s)
    assert compile_count() == before
    # grad runs the code around simulate eagerly (small programs), never the loop
    loops = compile_count("integrate")
    with pytest.raises(ValueError, match=r"1 sample\(s\) x 4001 saves"):
        jax.grad(lambda x: jaxatt.simulate(loop, x, 0.0, 4.0, dt=1e-3).ts[-1])(x0)
    assert compile_count("integrate") == loops


def test_monte_carlo_counts_every_kept_sample_and_says_how_to_stream(case, monkeypatch):
    loop, x0s, x0 = case
    sim = Simulation(0.0, 1.0, 1e-3)
    one = _memory.record_bytes(loop, x0, 0.0)
    # Room for three samples' 1001 saves, not for four.
    monkeypatch.setattr(_memory, "memory_limit", lambda: 3 * 1001 * one + 1)
    _memory.check_saved_memory("test", loop, x0, sim, samples=3)
    before = compile_count()
    with pytest.raises(ValueError, match=r"4 sample\(s\) x 1001 saves") as info:
        mc.monte_carlo(loop, x0s, 0.0, 1.0, dt=1e-3, keep_trajectories=True)
    assert "leave `keep_trajectories` off" in str(info.value)
    # Metrics that cannot stream (a function) save the samples in flight, all four at once
    # here: `batch_size` bounds them.
    with pytest.raises(ValueError, match=r"4 sample\(s\) x 1001 saves") as info:
        mc.monte_carlo(loop, x0s, 0.0, 1.0, dt=1e-3, metrics=lambda traj: {"t": traj.ts[-1]})
    assert "lower `batch_size`" in str(info.value)
    assert compile_count() == before


def test_the_record_is_the_loop_state_the_signals_and_the_time(case):
    # MRP PD on the rigid body, counted by hand: the time (1), the state sigma and omega (3 + 3;
    # no controller or reference state), the signals u, u_cmd, attitude_error,
    # attitude_error_vector, rate_error, disturbance (6 x 3) and attitude_error_angle (1).
    loop, _, x0 = case
    assert _memory.record_bytes(loop, x0, 0.0) == 8 * (1 + 6 + 18 + 1)
