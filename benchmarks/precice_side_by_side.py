"""preCICE's own tutorial cases under cosim and under preCICE, side by side: the same unmodified participants, one
BLAS thread each, in alternated pairs.

Per run: the wall time of the whole run (from the first process's start to the last one's exit), the CPU time of
every process of it (``wait4``'s rusage, children included), and the coupling iterations. cosim's wall time is split
into its start-up (to the first window's start), its windows (``coupling_seconds``) and its close (the last window's
end to the exit); preCICE's the same way from its participants' own profiles (``precice-profiling/``: start-up to the
last ``initialize`` returning, windows to the last ``advance`` returning, close to the exit). The fixed cost is
start-up plus close; the per-iteration cost is the windows' time over the iterations (preCICE's whole wall time over
its iterations too, where it wrote no profile). Figures are medians [min-max] over the pairs, and cosim / preCICE
their ratio, pair by pair.

The preCICE half needs a Python whose ``precice`` is pyprecice on a real libprecice (``--precice-python``); without
one, only cosim runs. Neither preCICE nor pyprecice is part of this project: build them yourself.

Usage: python -m benchmarks.precice_side_by_side --tutorials TUTORIALS [--precice-python PY] [--case NAME ...]
[--repeat N] [--baseline TREE]; --small runs examples/precice_tube (10 windows) under cosim twice (the tests' mode).
``--baseline TREE`` runs another checkout's cosim (a worktree of an earlier commit) as a third engine of the same
alternated series, and gives cosim against it pair by pair.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import ROOT, machine
from benchmarks.tube_run import socket_ping_floor, zmq_ping_floor
from cosim.results import RunResults
from scripts.precice_tutorials import CASES, command_of, write_case

DEFAULT_CASES = ("elastic-tube-1d", "oscillator", "perpendicular-flap (fake)", "resonant-circuit")
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
TIMEOUT = 900.0


def _wait(process: subprocess.Popen, deadline: float) -> tuple[int, float]:
    """Wait for ``process`` (its exit code and the CPU seconds of it and its reaped descendants)."""
    while True:
        pid, status, usage = os.wait4(process.pid, os.WNOHANG)
        if pid:
            process.returncode = os.waitstatus_to_exitcode(status)
            return process.returncode, usage.ru_utime + usage.ru_stime
        if time.monotonic() > deadline:
            process.kill()
            raise TimeoutError(f"{process.args!r} ran longer than {TIMEOUT:g} s")
        time.sleep(0.002)


def run_cosim(case: Path, out: Path, *overrides: str, tree: Path | None = None) -> dict[str, Any]:
    """``cosim run CASE`` in a process of its own: wall, CPU, iterations, and the wall split; with ``tree``, that
    checkout's cosim (its folder first on the path), else this one's."""
    env = {**os.environ, **ONE_THREAD}
    if tree is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(tree), env.get("PYTHONPATH", "")]))
    errors = out.with_name(f"{out.name}.stderr")
    out.parent.mkdir(parents=True, exist_ok=True)
    started_at, started = time.time(), time.perf_counter()
    with errors.open("wb") as stderr:
        process = subprocess.Popen([sys.executable, "-m", "cosim", "run", str(case), "--out", str(out), "--quiet",
                                    *(f"--set={item}" for item in overrides)], env=env, stdout=subprocess.DEVNULL,
                                   stderr=stderr, cwd=tree)
        code, cpu = _wait(process, time.monotonic() + TIMEOUT)
    wall, ended_at = time.perf_counter() - started, time.time()
    if code != 0:
        raise RuntimeError(f"cosim run {case} exited {code}: {errors.read_text(errors='replace')[-400:]}")
    with RunResults(out) as run:
        attributes = run.attributes
        iterations = int(run.windows.iterations.sum())
    return {"wall": wall, "cpu": cpu, "iterations": iterations,
            "startup": attributes["first_window_started"] - started_at,
            "windows": attributes["coupling_seconds"], "close": ended_at - attributes["last_window_ended"]}


def profiled_events(path: Path) -> dict[str, tuple[float, float]]:
    """The first begin and the last end (unix seconds) of each event a participant's preCICE profile records
    (``precice-profiling/<participant>-<rank>-<size>.txt``, preCICE v3's ``fundamental`` profiling: a JSON header with
    the start in microseconds, then ``N<id>:<name>``, ``B<id>:<us>`` and ``E<id>:<us>`` lines)."""
    lines = path.read_text().splitlines()
    origin = int(json.loads(lines[0])["unix_us"])
    names: dict[str, str] = {}
    spans: dict[str, tuple[float, float]] = {}
    for line in lines[1:]:
        kind, _, rest = line.partition(":")
        if kind.startswith("N"):
            names[kind[1:]] = rest
        elif kind[:1] in "BE" and kind[1:] in names:
            event, at = names[kind[1:]], (origin + int(rest.split(":")[0])) * 1e-6
            first, last = spans.get(event, (at, at))
            spans[event] = (min(first, at), max(last, at))
    return spans


def run_precice(tutorials: Path, name: str, python: str) -> dict[str, Any]:
    """The tutorial's participants started at once as its run.sh starts them, with ``python``'s pyprecice. Its wall
    time is split as cosim's is, from each participant's preCICE profile: start-up to the last participant's
    ``initialize`` returning, the windows from there to the last ``advance`` returning, and the close after it."""
    folder, participants = CASES[name]
    shutil.rmtree(tutorials / folder / "precice-run", ignore_errors=True)
    for cwd, *_ in participants.values():
        shutil.rmtree(tutorials / folder / cwd / "precice-profiling", ignore_errors=True)
    env = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
    started_at, started = time.time(), time.perf_counter()
    processes = {}
    for participant, (cwd, command, extra, _) in participants.items():
        processes[participant] = subprocess.Popen(command_of(command, "python", {"python": python}), shell=True,
                                                  cwd=tutorials / folder / cwd, env={**env, **ONE_THREAD, **extra},
                                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline, cpu, codes = time.monotonic() + TIMEOUT, 0.0, {}
    for participant, process in processes.items():
        codes[participant], seconds = _wait(process, deadline)
        cpu += seconds
    wall, ended_at = time.perf_counter() - started, time.time()
    if any(codes.values()):
        raise RuntimeError(f"preCICE's {name} exited {codes}")
    profiles = [profiled_events(path) for cwd, *_ in participants.values()
                for path in sorted((tutorials / folder / cwd / "precice-profiling").glob("*.txt"))]
    split = {}
    if profiles and all("initialize" in p and "advance" in p for p in profiles):
        initialized = max(p["initialize"][1] for p in profiles)
        last_advance = max(p["advance"][1] for p in profiles)
        split = {"startup": initialized - started_at, "windows": last_advance - initialized,
                 "close": ended_at - last_advance}
    logs = [tutorials / folder / cwd / f"precice-{participant}-iterations.log"
            for participant, (cwd, *_) in participants.items()]
    rows = [line.split() for log in logs if log.is_file() for line in log.read_text().splitlines()[1:]]
    iterations = int(rows[-1][1]) if rows else 0       # TotalIterations of the last window
    return {"wall": wall, "cpu": cpu, "iterations": iterations, **split}


def spread(values: list[float]) -> str:
    return f"{np.median(values):.2f} [{min(values):.2f}-{max(values):.2f}]"


def _fixed(run: dict[str, Any]) -> float:
    return run["startup"] + run["close"]


def _per_iteration(run: dict[str, Any]) -> float:
    """Microseconds per coupling iteration: the windows' time (the whole wall time where there is no split)."""
    return 1e6 * run.get("windows", run["wall"]) / max(run["iterations"], 1)


def table(results: dict[str, dict[str, list[dict[str, Any]]]]) -> str:
    lines = ["| case | iterations (cosim / preCICE) | preCICE wall s | cosim wall s | cosim / preCICE | fixed s (cosim / "
             "preCICE) | cosim start-up s | cosim close s | CPU s (cosim / preCICE) | us per iteration (cosim / "
             "preCICE) | per iteration, cosim / preCICE |", "| --- " * 11 + "|"]
    for name, runs in results.items():
        ours, theirs = runs["cosim"], runs.get("precice", [])
        pairs = list(zip(ours, theirs))
        precice_wall = spread([r["wall"] for r in theirs]) if theirs else "-"
        ratio = spread([a["wall"] / b["wall"] for a, b in pairs]) if pairs else "-"
        split = bool(theirs) and all("windows" in r for r in theirs)
        fixed = spread([_fixed(r) for r in ours]) + (f" / {spread([_fixed(r) for r in theirs])}" if split else "")
        per_iteration = f"{np.median([_per_iteration(r) for r in ours]):.0f}"
        if theirs:
            per_iteration += f" / {np.median([_per_iteration(r) for r in theirs]):.0f}" + ("" if split else " (whole)")
        iteration_ratio = spread([_per_iteration(a) / _per_iteration(b) for a, b in pairs]) if pairs else "-"
        cpu = f"{np.median([r['cpu'] for r in ours]):.2f}" + (
            f" / {np.median([r['cpu'] for r in theirs]):.2f}" if theirs else "")
        iterations = f"{ours[0]['iterations']}" + (f" / {theirs[0]['iterations']}" if theirs else "")
        lines.append(f"| {name} | {iterations} | {precice_wall} | {spread([r['wall'] for r in ours])} | {ratio} | "
                     f"{fixed} | {spread([r['startup'] for r in ours])} | {spread([r['close'] for r in ours])} | "
                     f"{cpu} | {per_iteration} | {iteration_ratio} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tutorials", type=Path, help="a checkout of preCICE's tutorials")
    parser.add_argument("--precice-python", help="a Python whose precice is pyprecice on a real libprecice")
    parser.add_argument("--case", action="append", choices=list(CASES), help=f"default: {', '.join(DEFAULT_CASES)}")
    parser.add_argument("--repeat", type=int, default=5, help="alternated pairs per case (default 5)")
    parser.add_argument("--json", type=Path, help="also write every run's figures here")
    parser.add_argument("--baseline", type=Path, help="another checkout of cosim (a worktree of an earlier commit) run "
                                                      "in the same alternated series: cosim against it, pair by pair")
    parser.add_argument("--small", action="store_true", help="examples/precice_tube, 10 windows, cosim only, twice")
    args = parser.parse_args(argv)
    print(f"machine: {machine()}")
    count = 500 if args.small else 3000
    print(f"transport floor, one round trip of 808 bytes between two processes: ZeroMQ {zmq_ping_floor(count)} us, a "
          f"plain TCP socket {socket_ping_floor(count)} us (median [quartiles])", flush=True)
    scratch = Path(tempfile.mkdtemp(prefix="cosim-side-by-side-"))
    results: dict[str, dict[str, list[dict[str, Any]]]] = {}
    try:
        if args.small:
            case = ROOT / "examples" / "precice_tube" / "case.toml"
            results["elastic tube (examples/precice_tube, 10 windows)"] = {
                "cosim": [run_cosim(case, scratch / f"run{i}", "time.end=1") for i in range(2)]}
        else:
            if args.tutorials is None:
                parser.error("--tutorials is needed (or --small)")
            for name in args.case or DEFAULT_CASES:
                case = write_case(args.tutorials.resolve(), name, {}, scratch / name.replace(" ", "_"))
                runs: dict[str, list[dict[str, Any]]] = {"cosim": [], "precice": [], "baseline": []}
                engines = ["precice", "cosim"] + (["baseline"] if args.baseline else [])
                for repeat in range(args.repeat):        # alternated: each engine in turn first
                    for engine in engines[repeat % len(engines):] + engines[:repeat % len(engines)]:
                        if engine in ("cosim", "baseline"):
                            out = scratch / f"{engine}{len(runs[engine])}-{case.parent.name}"
                            runs[engine].append(run_cosim(case, out, tree=args.baseline.resolve()
                                                          if engine == "baseline" else None))
                        elif args.precice_python:
                            runs["precice"].append(run_precice(args.tutorials.resolve(), name, args.precice_python))
                results[name] = runs
                print(f"{name}: done", flush=True)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print(table(results))
    if args.baseline:
        print(f"\nthe baseline, {args.baseline}, in the same series:")
        print(table({name: {"cosim": runs["baseline"], "precice": runs["precice"]} for name, runs in results.items()}))
        print("\n| case | wall, cosim / baseline | fixed, cosim / baseline | per iteration, cosim / baseline |\n"
              "| --- | --- | --- | --- |")
        for name, runs in results.items():
            pairs = list(zip(runs["cosim"], runs["baseline"]))
            print(f"| {name} | {spread([a['wall'] / b['wall'] for a, b in pairs])} | "
                  f"{spread([_fixed(a) / _fixed(b) for a, b in pairs])} | "
                  f"{spread([_per_iteration(a) / _per_iteration(b) for a, b in pairs])} |")
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return results


if __name__ == "__main__":
    main()
