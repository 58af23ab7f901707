"""Cold against warm start with the persistent compilation cache, each in a new process.

Three runs of one command, one after the other, each a fresh Python process:

1. `no cache`: `--no-cache` (what every run cost before the cache: compile everything);
2. `cold`: the cache on, in an empty folder (compile everything and write it);
3. `warm`: the same folder again (every program loaded from disk).

Commands: `jaxatt demo` (`python -m jaxatt.cli demo [--short]`), and the first `--cells` code
cells of a notebook run as one script (the notebook's own code, with
`jaxatt.enable_compilation_cache(folder)` or nothing inserted after its first line; `--cells`
may be given several times). Prints wall times, the warm speed-up, cache size and the load
average; writes `benchmarks/results/compile_cache.json`. Checks (exit 1): every run succeeds,
the demo's summary is identical in the three runs, warm faster than cold.

    python benchmarks/bench_compile_cache.py                       # full demo, notebook 01
    python benchmarks/bench_compile_cache.py --short --cells 2     # quick
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time


ROOT = pathlib.Path(__file__).resolve().parents[1]


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--short", action="store_true", help="jaxatt demo --short")
    p.add_argument("--no-demo", action="store_true", help="skip the demo")
    p.add_argument(
        "--notebook", default=str(ROOT / "notebooks" / "01_chen2022_two_phase_power.ipynb")
    )
    p.add_argument("--cells", type=int, action="append", help="code cells run (default: 2 and 4)")
    p.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "compile_cache.json"))
    args = p.parse_args(argv)
    args.cells = args.cells or [2, 4]
    return args


def timed(command: list[str], env: dict) -> dict:
    start = time.perf_counter()
    done = subprocess.run(command, env=env, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    return {
        "wall_s": wall,
        "returncode": done.returncode,
        "load_after": os.getloadavg()[0],
        "stderr_tail": done.stderr[-1500:] if done.returncode else "",
    }


def notebook_script(path: str, cells: int, cache: str | None) -> str:
    nb = json.loads(pathlib.Path(path).read_text())
    code = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"][:cells]
    enable = f"import jaxatt\njaxatt.enable_compilation_cache({cache!r})\n" if cache else "pass\n"
    # After the first cell (which enables x64 before any array exists).
    return "\n".join([code[0], enable, *code[1:]])


def folder_size(path: pathlib.Path) -> tuple[int, float]:
    files = [f for f in path.rglob("*") if f.is_file()]
    return len(files), sum(f.stat().st_size for f in files) / 2**20


def main(argv=None) -> int:
    args = parse_args(argv)
    env = dict(os.environ, MPLBACKEND="Agg", JAXATT_SHORT="1" if args.short else "0")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), env.get("PYTHONPATH")) if p)
    env.pop("JAXATT_CACHE_DIR", None)
    results, ok = {"load_at_start": os.getloadavg()[0], "short": args.short}, True
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        if not args.no_demo:
            cache = tmp / "demo_cache"
            runs = {}
            for name in ("no cache", "cold", "warm"):
                out = tmp / f"demo_{name.replace(' ', '_')}"
                flags = ["--no-cache"] if name == "no cache" else ["--cache-dir", str(cache)]
                command = [sys.executable, "-m", "jaxatt.cli", "demo", "--out", str(out), *flags]
                runs[name] = timed(command + (["--short"] if args.short else []), env)
                summary = out / "summary.json"
                runs[name]["summary"] = (
                    json.loads(summary.read_text()) if summary.exists() else None
                )
                print(f"demo, {name}: {runs[name]['wall_s']:.1f} s", flush=True)
            entries, mib = folder_size(cache)
            summaries = [r.pop("summary") for r in runs.values()]
            for run, summary in zip(runs.values(), summaries):
                run["demo_stage_s"] = None if summary is None else summary.get("timings_s")
            same = all(s is not None for s in summaries) and all(
                _strip_times(s) == _strip_times(summaries[0]) for s in summaries
            )
            results["demo"] = {
                "runs": runs,
                "warm_speedup": runs["cold"]["wall_s"] / runs["warm"]["wall_s"],
                "cold_over_no_cache": runs["cold"]["wall_s"] / runs["no cache"]["wall_s"],
                "cache_entries": entries,
                "cache_mib": mib,
                "same_summary": same,
            }
            ok &= same and all(r["returncode"] == 0 for r in runs.values())
            ok &= runs["warm"]["wall_s"] < runs["cold"]["wall_s"]
        for cells in args.cells:
            if cells <= 0:  # --cells 0: no notebook
                continue
            cache = tmp / f"nb_cache_{cells}"
            runs = {}
            for name in ("no cache", "cold", "warm"):
                script = tmp / f"nb_{cells}.py"
                script.write_text(
                    notebook_script(
                        args.notebook, cells, None if name == "no cache" else str(cache)
                    )
                )
                runs[name] = timed([sys.executable, str(script)], env)
                print(f"notebook, {cells} cells, {name}: {runs[name]['wall_s']:.1f} s", flush=True)
                ok &= runs[name]["returncode"] == 0
            results[f"notebook_{cells}_cells"] = {
                "notebook": pathlib.Path(args.notebook).name,
                "runs": runs,
                "warm_speedup": runs["cold"]["wall_s"] / runs["warm"]["wall_s"],
                "cache_entries": folder_size(cache)[0],
            }
    results["load_at_end"] = os.getloadavg()[0]
    results["ok"] = bool(ok)
    print(json.dumps(results, indent=2))
    pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(args.out).write_text(json.dumps(results, indent=2))
    print("check:", "PASSED" if ok else "FAILED")
    return 0 if ok else 1


def _strip_times(summary: dict) -> dict:
    """The summary without its wall-clock timings (they differ from run to run)."""
    return {k: v for k, v in summary.items() if k != "timings_s"}


if __name__ == "__main__":
    raise SystemExit(main())
