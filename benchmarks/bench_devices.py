"""Chen 2022 M1 Monte Carlo over several CPU devices and processes: what sharding buys on a CPU.

`monte_carlo` shards the batch over every device in `jax.devices()`. On a CPU there are
three ways to get more than one: XLA's forced host devices in one process
(`XLA_FLAGS=--xla_force_host_platform_device_count=N`), several processes joined by
`jax.distributed.initialize` (the multi-host recipe, `examples/multihost_monte_carlo.py`), or
neither (one device; XLA:CPU splits each kernel over the cores itself). This script times the
default call, `monte_carlo(chen.build("M1"), x0s, 0, T, dt=1e-3)` (metrics streamed,
scalarized from 1000 samples per device), the same batch each way, every mode in fresh
processes:

- `one`: one process, one device (XLA:CPU's own threads over all cores);
- `forced`: one process, `--devices` forced host devices, sharded (the default `shard=True`);
- `forced-unsharded`: the same process set-up with `shard=False` (everything on device 0);
- `processes`: `--devices` processes, one device each, joined by `jax.distributed` on a local
  coordinator, each pinned to one core (`os.sched_setaffinity` before JAX starts, so XLA
  sees one core and splits nothing).

Each row: the first call (trace, compile, run), then the minimum over `--repeat` calls of the
warm call (all processes start each timed call together: a barrier first). Every mode's
per-sample metrics and statuses must equal the `one` run's to 1e-12 relative (exit 1
otherwise).

Usage (from the repository root):

    python benchmarks/bench_devices.py                       # 10 000 samples, 2 s, 2 devices
    python benchmarks/bench_devices.py --batch 4000 --horizon 1 --modes one processes
"""

import argparse
import json
import os
import socket
import subprocess
import sys
import time


MODES = ("one", "forced", "forced-unsharded", "processes")
DT = 1e-3


def worker(args) -> None:
    if args.pin is not None:
        os.sched_setaffinity(0, {args.pin})  # before JAX starts its threads
    import jax

    if args.processes > 1:
        jax.distributed.initialize(
            coordinator_address=args.coordinator,
            num_processes=args.processes,
            process_id=args.process_id,
        )
    jax.config.update("jax_enable_x64", True)
    import jax.random as jr
    import numpy as np
    from jax.experimental import multihost_utils

    from jaxatt.montecarlo import monte_carlo
    from jaxatt.scenarios import chen2022_tuning, chen2022_two_phase_power as chen

    loop = chen.build("M1")
    x0s = chen2022_tuning.initial_states(jr.key(0), args.batch)

    def call():
        result = monte_carlo(loop, x0s, 0.0, args.horizon, dt=DT, shard=args.shard)
        jax.block_until_ready((result.metrics, result.status))
        return result

    def timed():
        if args.processes > 1:
            multihost_utils.sync_global_devices("start")
        start = time.perf_counter()
        result = call()
        if args.processes > 1:
            multihost_utils.sync_global_devices("end")
        return time.perf_counter() - start, result

    first, result = timed()
    runs = [timed()[0] for _ in range(args.repeat)]
    metrics, status = multihost_utils.process_allgather((result.metrics, result.status), tiled=True)
    if jax.process_index() == 0:
        out = {
            "devices": len(jax.devices()),
            "processes": jax.process_count(),
            "batch_devices": len(result.status.sharding.device_set),
            "first_s": first,
            "run_s": min(runs),
            "metrics": {k: np.asarray(v).tolist() for k, v in metrics.items()},
            "status": np.asarray(status).tolist(),
        }
        print("RESULT" + json.dumps(out))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def run_mode(mode: str, args) -> dict:
    base = [sys.executable, __file__, "--worker", "--batch", str(args.batch)]
    base += ["--horizon", str(args.horizon), "--repeat", str(args.repeat)]
    env = dict(os.environ)
    if mode.startswith("forced"):
        flags = f"--xla_force_host_platform_device_count={args.devices}"
        env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " " + flags).strip()
    if mode == "forced-unsharded":
        base.append("--no-shard")
    if mode != "processes":
        done = subprocess.run(base, env=env, capture_output=True, text=True, check=False)
        outputs = [done]
    else:
        port = _free_port()
        procs = [
            subprocess.Popen(
                base
                + ["--processes", str(args.devices), "--process-id", str(i)]
                + ["--coordinator", f"localhost:{port}", "--pin", str(i % os.cpu_count())],
                env=env,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            for i in range(args.devices)
        ]
        outputs = []
        for p in procs:
            stdout, stderr = p.communicate()
            outputs.append(subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr))
    for done in outputs:
        if done.returncode != 0:
            raise SystemExit(f"{mode}: worker failed\n{done.stderr[-3000:]}")
    line = next(
        line for done in outputs for line in done.stdout.splitlines() if line.startswith("RESULT")
    )
    return json.loads(line[len("RESULT") :])


def relative_difference(a, b) -> float:
    import numpy as np

    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    scale = np.maximum(np.abs(b), 1.0)
    with np.errstate(invalid="ignore"):
        diff = np.where(same, 0.0, np.abs(a - b) / scale)
    return float(np.nanmax(np.where(np.isnan(diff), np.inf, diff)))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--batch", type=int, default=10_000, help="samples")
    p.add_argument("--horizon", type=float, default=2.0, help="simulated time [s]")
    p.add_argument("--devices", type=int, default=2, help="devices or processes")
    p.add_argument("--repeat", type=int, default=3, help="timed warm calls")
    p.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES))
    p.add_argument("--out", help="write the table as JSON here")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--no-shard", dest="shard", action="store_false", help=argparse.SUPPRESS)
    p.add_argument("--processes", type=int, default=1, help=argparse.SUPPRESS)
    p.add_argument("--process-id", type=int, default=0, help=argparse.SUPPRESS)
    p.add_argument("--coordinator", help=argparse.SUPPRESS)
    p.add_argument("--pin", type=int, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        worker(args)
        return 0
    steps = round(args.horizon / DT)
    print(
        f"Chen 2022 M1 default monte_carlo call, {args.batch} samples, {args.horizon} s of RK4 "
        f"at dt {DT} s, float64, {os.cpu_count()} cores, {args.devices} devices or processes"
    )
    print(
        " mode             | processes | devices | batch devices | first call s | run s "
        "| st-st/s  | x one | max rel diff"
    )
    rows, ok, reference = {}, True, None
    for mode in args.modes:
        r = run_mode(mode, args)
        rate = args.batch * steps / r["run_s"]
        if reference is None and mode == "one":
            reference = r
        diff = None
        if reference is not None:
            diff = max(
                [
                    relative_difference(r["metrics"][k], reference["metrics"][k])
                    for k in reference["metrics"]
                ]
                + [relative_difference(r["status"], reference["status"])]
            )
            ok &= diff <= 1e-12
        one = rows.get("one", {}).get("state_steps_per_s")
        rows[mode] = {
            "processes": r["processes"],
            "devices": r["devices"],
            "batch_devices": r["batch_devices"],
            "first_s": r["first_s"],
            "run_s": r["run_s"],
            "state_steps_per_s": rate,
            "max_relative_difference": diff,
        }
        print(
            f" {mode:16s} | {r['processes']:9d} | {r['devices']:7d} | {r['batch_devices']:13d} "
            f"| {r['first_s']:12.2f} | {r['run_s']:5.2f} | {rate:.2e} "
            f"| {rate / one if one else 1.0:5.2f} | {'-' if diff is None else f'{diff:.1e}'}"
        )
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"args": vars(args), "rows": rows, "ok": ok}, f, indent=1)
    if not ok:
        print("FAILED: a mode's metrics differ from the one-device run by more than 1e-12")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
