r"""A Monte Carlo of Chen et al. (2022)'s controller M1 over several processes (hosts).

Start one copy per process (per host, or per GPU), all with the same arguments but their own
`--process-id`:

    python examples/multihost_monte_carlo.py --coordinator host0:1234 --num-processes 2 \
        --process-id 0
    python examples/multihost_monte_carlo.py --coordinator host0:1234 --num-processes 2 \
        --process-id 1

Under SLURM or Open MPI leave the three options out: `jax.distributed.initialize()` reads them
from the environment. With `--num-processes 1` the script runs in one process without
`jax.distributed`. On one multi-core CPU, start each process under `taskset -c K` (its own
core): the pinned processes ran the batch 1.42-1.90x faster than one process on all the
cores (`benchmarks/bench_devices.py`, docs/scaling.md); with `--batch-size 1024` and
`XLA_FLAGS=--xla_backend_extra_options=xla_cpu_use_multi_output_fusion` set for each of them,
the scalarized step ran another 1.29-1.33x faster (benchmarks/README.md, "Multi-output fusion
in L2-sized chunks"). Process 0 prints the summary table
and, with `--json PATH`, writes every sample's metrics and status.

`tests/montecarlo/test_distributed.py` runs this file in two processes on one machine (CPU,
small batch and horizon) and checks that it equals the one-process run; `docs/scaling.md` shows
it.
"""

import argparse
import json


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--coordinator", help="address:port of process 0 (default: from env)")
    parser.add_argument("--num-processes", type=int, help="number of processes")
    parser.add_argument("--process-id", type=int, help="this process's index, 0-based")
    parser.add_argument("--samples", type=int, default=1_000_000, help="batch size")
    parser.add_argument("--horizon", type=float, default=30.0, help="simulated time [s]")
    parser.add_argument("--dt", type=float, default=1e-3, help="RK4 step [s]")
    parser.add_argument("--save-every", type=int, default=1000, help="steps between saves")
    parser.add_argument(
        "--batch-size",
        type=int,
        help="samples each device runs at once (lax.map chunks; default: its whole share)",
    )
    parser.add_argument("--json", help="process 0 writes the per-sample results here")
    return parser.parse_args(argv)


def main(argv=None) -> None:
    args = parse_args(argv)

    import jax

    if args.num_processes != 1:
        # On every process, before any other JAX call.
        jax.distributed.initialize(
            coordinator_address=args.coordinator,
            num_processes=args.num_processes,
            process_id=args.process_id,
        )
    jax.config.update("jax_enable_x64", True)

    import jax.random as jr
    import numpy as np
    from jax.experimental import multihost_utils

    from jaxatt import montecarlo as mc
    from jaxatt.plants import QuaternionState
    from jaxatt.scenarios import chen2022_two_phase_power as chen

    # Every process builds the same batch (same keys); each supplies its own devices' shards.
    k_q, k_w = jr.split(jr.key(0))
    n = args.samples
    x0s = QuaternionState(mc.attitudes_within(k_q, n, 1.0), mc.rates_in_ball(k_w, n, 0.05))
    result = mc.monte_carlo(
        chen.build("M1"),
        x0s,
        0.0,
        args.horizon,
        dt=args.dt,
        save_every=args.save_every,
        batch_size=args.batch_size,
    )
    # Gathering a batch sharded over several processes is a collective: every process must
    # call it (`result.table()` and `result.summary()` gather too), only process 0 prints.
    table = result.table()
    metrics, status = multihost_utils.process_allgather((result.metrics, result.status), tiled=True)
    if jax.process_index() == 0:
        print(f"{jax.process_count()} process(es), {len(jax.devices())} device(s)")
        print(table)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(
                    {
                        "processes": jax.process_count(),
                        "devices": len(jax.devices()),
                        "batch_devices": len(result.status.sharding.device_set),
                        "metrics": {k: np.asarray(v).tolist() for k, v in metrics.items()},
                        "status": status.tolist(),
                    },
                    f,
                )


if __name__ == "__main__":
    main()
