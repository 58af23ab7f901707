"""Command-line front end: `jaxatt demo | list | reproduce NAME | tune NAME`.

Enables float64 before anything else (reproductions run in double precision) and the persistent
compilation cache (a second run in a new process reuses the compiled programs; folder from
`--cache-dir`, else `$JAXATT_CACHE_DIR`, else `~/.cache/jaxatt/xla`; `JAXATT_CACHE_DIR=off`
keeps jaxatt from turning it on, `--no-cache` turns every persistent cache off, even one that
JAX's own `JAX_COMPILATION_CACHE_DIR` names), and, when asked (`--small-loop-kernels`),
XLA:CPU's one-kernel small loops, then dispatches to library functions. No numerics here.

Exit status (`EXIT_CODES`, also in `--help`): 0 done; 1 an unexpected error; 2 a bad command
line, an unknown name, `tune --resume` without a checkpoint or with one of another run, or
`--small-loop-kernels` where it cannot take effect (nothing run); 3 a `tune` run, or the
`demo`'s tuning stage, that did not complete (a non-finite step), so that no script or CI job
takes it for a success.
"""

import argparse
import json
import pathlib
import sys
import time

from ._versions import versions_line


EXIT_OK = 0
"""Every command: done (for `tune`, every optimizer step completed)."""
EXIT_ERROR = 1
"""An unexpected error (Python's status for an uncaught exception, with its traceback)."""
EXIT_USAGE = 2
"""A bad command line (argparse's status), an unknown scenario or tuning problem,
`tune --resume` with no checkpoint in the output folder or with a checkpoint of another run
(another problem, batch size or starting gains), or `--small-loop-kernels` where it cannot
take effect (a jaxlib older than 0.7.2); nothing was run."""
EXIT_STOPPED = 3
"""`tune`: the run did not complete (a step's loss or gradient was not finite); why is on
stderr. What the problem writes (its report, where it records the stop, and the checkpoint)
holds the last good step. `demo`: its tuning stage did not complete (no summary or report)."""

TUNE_OPTIMIZERS = ("default", "lbfgs")
"""`jaxatt tune --optimizer`'s choices: `jaxatt.scenarios.OPTIMIZERS` (kept here so that building
the parser imports no scenario; a test checks the two are equal)."""

EXIT_CODES = f"""exit status:
  {EXIT_OK}  done (tune: every optimizer step completed; tuned gains above a training
     penalty's bound on held-out samples are a warning on stderr)
  {EXIT_ERROR}  an unexpected error (traceback on stderr)
  {EXIT_USAGE}  bad command line, unknown NAME, tune --resume without a checkpoint in
     the output folder or with another run's checkpoint there, or
     --small-loop-kernels under a jaxlib older than 0.7.2 (nothing was run)
  {EXIT_STOPPED}  tune: the run did not complete (a non-finite loss or gradient; why is
     on stderr); the checkpoint, and the report where the problem writes one
     for a stopped run, hold the last good step. demo: its tuning stage did not
     complete (no summary or report written)
"""


def _enable_x64() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)


def _setup_cache(args: argparse.Namespace) -> None:
    from ._compilation_cache import (
        cache_disabled_by_env,
        disable_compilation_cache,
        enable_compilation_cache,
    )

    if getattr(args, "no_cache", False):
        # An explicit request: no cache at all, including one enabled through JAX's variables.
        disable_compilation_cache()
        return
    if getattr(args, "cache_dir", None) is None and cache_disabled_by_env():
        return
    enable_compilation_cache(getattr(args, "cache_dir", None))


def _cmd_list(args: argparse.Namespace) -> int:
    from .scenarios import REGISTRY

    for name, scenario in REGISTRY.items():
        print(f"{name:24s} {scenario.title}")
    return EXIT_OK


def _run_scenario(name: str, out: pathlib.Path, short: bool) -> int:
    from .scenarios import REGISTRY
    from .scenarios._io import json_safe

    if name not in REGISTRY:
        print(
            f"jaxatt: unknown scenario {name!r}; available: {', '.join(REGISTRY)}",
            file=sys.stderr,
        )
        return EXIT_USAGE
    start = time.perf_counter()
    print(f"[jaxatt] {name}: compiling and simulating (float64)...", flush=True)
    metrics = REGISTRY[name].reproduce(out, short=short, progress=True)
    elapsed = time.perf_counter() - start
    print(json.dumps(json_safe(metrics), indent=2, allow_nan=False))
    print(f"[jaxatt] done in {elapsed:.1f} s; figures and metrics.json written to {out.resolve()}")
    return EXIT_OK


def _cmd_reproduce(args: argparse.Namespace) -> int:
    out = pathlib.Path(args.out) if args.out else pathlib.Path("jaxatt-out") / args.name
    return _run_scenario(args.name, out, args.short)


def _cmd_demo(args: argparse.Namespace) -> int:
    from .scenarios import demo
    from .tune import NonFiniteLossError

    out = pathlib.Path(args.out) if args.out else pathlib.Path("jaxatt-out") / "demo"
    start = time.perf_counter()
    print("[jaxatt] demo: Chen 2022 reproduction, Monte Carlo, autodiff tuning (float64)")
    try:
        summary = demo.run(out, short=args.short, progress=True)
    except NonFiniteLossError as error:
        # The tuning stage raised (a non-finite loss or gradient): what ran before it is on
        # disk, but there is no summary or report, and the demo must not read as a success.
        print(
            f"jaxatt: demo did not complete: its tuning stage stopped: {error}\n"
            f"jaxatt: no summary.json or report.md was written in {out.resolve()}; the "
            "reproduction and Monte Carlo figures written before it are there.",
            file=sys.stderr,
        )
        return EXIT_STOPPED
    tuned = summary["tuning"]
    print(
        "[jaxatt] held-out settling (mean of the settled samples): "
        f"{_settling(tuned['held_out_before'])} with the paper's gains, "
        f"{_settling(tuned['held_out_after'])} tuned"
    )
    _warn_over_bounds("demo", tuned["held_out_over_bounds"])
    print(
        f"[jaxatt] done in {time.perf_counter() - start:.1f} s; report: "
        f"{(out / 'report.md').resolve()}"
    )
    return EXIT_OK


def _settling(stats: dict) -> str:
    """`"2.794 s, 100.0 % settled"`; the settled fraction always, so that a lower mean over
    fewer settled samples cannot read as an improvement."""
    from ._text import percent

    mean = stats["mean_settling_time"]
    settled = f"{percent(stats['settled_fraction'])} settled"
    failed = f", {stats['failed']} failed" if stats.get("failed") else ""
    return ("no mean, " if mean is None else f"{mean:.3f} s, ") + settled + failed


def _cmd_tune(args: argparse.Namespace) -> int:
    from .scenarios import TUNING
    from .scenarios._io import json_safe
    from .tune import CheckpointMismatchError, NoCheckpointError, NonFiniteLossError

    if args.name not in TUNING:
        print(
            f"jaxatt: no tuning problem {args.name!r}; available: {', '.join(TUNING)}",
            file=sys.stderr,
        )
        return EXIT_USAGE
    out = pathlib.Path(args.out) if args.out else pathlib.Path("jaxatt-out") / f"tune-{args.name}"
    # Sizes left unset take the problem's own defaults (a 6-DOF pose costs far more per
    # sample than a rigid body, so one default cannot fit every problem).
    sizes = {
        k: v
        for k, v in (
            ("samples", args.samples),
            ("steps", args.steps),
            ("validation_samples", args.validation_samples),
        )
        if v is not None
    }
    try:
        report = TUNING[args.name].run(
            out, resume=args.resume, progress=True, optimizer=args.optimizer, **sizes
        )
    except NoCheckpointError as error:
        looked = ", ".join(path.name for path in error.paths)
        print(
            f"jaxatt: tune {args.name} --resume: no checkpoint to resume from in "
            f"{out.resolve()} (looked for {looked}); nothing was run. Leave out --resume to "
            "start a fresh run, or pass the --out folder of the run to continue.",
            file=sys.stderr,
        )
        return EXIT_USAGE
    except CheckpointMismatchError as error:
        # Checked before anything compiles; the checkpoint was left as it was.
        print(
            f"jaxatt: tune {args.name} --resume: {error}\n"
            f"jaxatt: nothing was run and {error.path.resolve()} was left as it was. Pass the "
            "--out folder of this problem's run (with the same --samples and --optimizer) to "
            "continue it, or leave out --resume to start a fresh run in another folder.",
            file=sys.stderr,
        )
        return EXIT_USAGE
    except NonFiniteLossError as error:
        # The problem raises (it writes no report); the checkpoint holds the last good step.
        print(
            f"jaxatt: tune {args.name} did not complete: {error}\n"
            f"jaxatt: no report was written; the checkpoint in {out.resolve()} holds the last "
            "good step.",
            file=sys.stderr,
        )
        return EXIT_STOPPED
    print(
        json.dumps(
            json_safe({k: report[k] for k in ("gains_before", "gains_after", "validation")}),
            indent=2,
            allow_nan=False,
        )
    )
    print(f"[jaxatt] report written to {(out / 'report.md').resolve()}")
    _warn_over_bounds(f"tune {args.name}", report.get("held_out_over_bounds"))
    if report.get("stopped"):
        # The problem stopped at a non-finite step and reported it: the report and the
        # checkpoint hold the last good step, and the run must not read as a success.
        print(
            f"jaxatt: tune {args.name} did not complete: {report['stopped']}\n"
            "jaxatt: the report and the checkpoint hold the last good step.",
            file=sys.stderr,
        )
        return EXIT_STOPPED
    return EXIT_OK


def _warn_over_bounds(command: str, over: list[str] | None) -> None:
    """Say on stderr that the tuned gains exceed, on held-out samples, a bound their training
    penalties hold (a tuning report's `held_out_over_bounds`); the run itself completed."""
    if over:
        print(
            f"jaxatt: warning: {command}: the tuned gains exceed a penalty's bound on held-out "
            f"samples: {'; '.join(over)}. The penalties hold their bounds on the training "
            "batch only (report.md).",
            file=sys.stderr,
        )


def _positive_int(text: str) -> int:
    """A batch size or step count: refused by argparse (usage, exit 2) before anything is built,
    not deep inside the problem after its output folder was made."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="jaxatt",
        description=(
            "Differentiable spacecraft attitude control in JAX. Throughput benchmarks live in "
            "the repository's benchmarks/ (python benchmarks/bench_quick.py)."
        ),
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--version",
        action="version",
        version=versions_line(),
        help="jaxatt's version and those of JAX, jaxlib, Equinox, diffrax, optax, NumPy, Python",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    # Options every compiling command takes (after the command name).
    compiling = argparse.ArgumentParser(add_help=False)
    compiling.add_argument(
        "--cache-dir",
        help=(
            "persistent compilation cache folder (default: $JAXATT_CACHE_DIR, else "
            "~/.cache/jaxatt/xla)"
        ),
    )
    compiling.add_argument(
        "--no-cache",
        action="store_true",
        help=(
            "neither read nor write any persistent compilation cache, even one set by "
            "JAX_COMPILATION_CACHE_DIR (JAXATT_CACHE_DIR=off only keeps jaxatt's own off)"
        ),
    )
    compiling.add_argument(
        "--small-loop-kernels",
        action="store_true",
        help=(
            "XLA:CPU compiles each small time loop as one kernel "
            "(jaxatt.enable_small_loop_kernels): single trajectories and small batches run "
            "faster, large models compile longer; results equal to rounding, but a tuning "
            "path can end at other gains"
        ),
    )
    demo = sub.add_parser(
        "demo",
        parents=[compiling],
        help="reproduce Chen 2022, run a Monte Carlo, tune with autodiff; write a report",
    )
    demo.add_argument("--out", help="output folder (default ./jaxatt-out/demo)")
    demo.add_argument("--short", action="store_true", help="coarser step, smaller batch")
    demo.set_defaults(func=_cmd_demo)
    lister = sub.add_parser("list", help="list the available scenarios")
    lister.set_defaults(func=_cmd_list)
    rep = sub.add_parser(
        "reproduce", parents=[compiling], help="reproduce a scenario's figures and metrics"
    )
    rep.add_argument("name", help="scenario name (see `jaxatt list`)")
    rep.add_argument("--out", help="output folder (default ./jaxatt-out/NAME)")
    rep.add_argument("--short", action="store_true", help="short mode (CI)")
    rep.set_defaults(func=_cmd_reproduce)
    tun = sub.add_parser(
        "tune",
        parents=[compiling],
        help="tune a scenario's gains with autodiff; write a report",
        description=(
            "Tune a problem's gains with autodiff, validate them on a held-out batch and write "
            "a report and a checkpoint to the output folder."
        ),
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    tun.add_argument(
        "name", help="tuning problem (chen2022, zhang2021, zhang2021-finite-time, shi2024)"
    )
    tun.add_argument(
        "--samples", type=_positive_int, help="training batch size (default: the problem's)"
    )
    tun.add_argument("--steps", type=_positive_int, help="optimizer steps (default: the problem's)")
    tun.add_argument(
        "--validation-samples",
        type=_positive_int,
        help="held-out batch size, fresh key (default: the problem's)",
    )
    tun.add_argument(
        "--optimizer",
        choices=TUNE_OPTIMIZERS,
        default="default",
        help=(
            "the problem's own optimizer (default; its recorded runs') or optax.lbfgs() with its "
            "zoom line search; a checkpoint of one is not resumed by the other"
        ),
    )
    tun.add_argument("--out", help="output folder (default ./jaxatt-out/tune-NAME)")
    tun.add_argument(
        "--resume",
        action="store_true",
        help=(
            "continue the run whose checkpoint is in the output folder; without one, an error "
            "(exit 2) before anything runs, never a fresh start"
        ),
    )
    tun.set_defaults(func=_cmd_tune)
    return parser


def _setup_small_loops(args: argparse.Namespace) -> bool:
    """`--small-loop-kernels`: before anything is computed (XLA reads the option once).
    False, with why on stderr, where the option cannot take effect (a jaxlib older than 0.7.2,
    or a backend that started first)."""
    if getattr(args, "small_loop_kernels", False):
        from ._small_loops import enable_small_loop_kernels

        try:
            threshold = enable_small_loop_kernels()
        except RuntimeError as error:
            print(f"jaxatt: --small-loop-kernels: {error}", file=sys.stderr)
            return False
        print(
            "[jaxatt] XLA:CPU compiles loops of under "
            f"{threshold} bytes per iteration as one kernel",
            flush=True,
        )
    return True


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if not _setup_small_loops(args):
        return EXIT_USAGE
    _enable_x64()
    _setup_cache(args)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
