"""preCICE's tutorials as a conformance suite: each case whose participants are all Python, run unmodified by cosim.

Give a checkout of preCICE's tutorials repository (v3 era; it is never part of this project). For each case the
script writes a case file into ``--out`` (the participants' commands as the tutorials' ``run.sh`` give them, in
their folders), runs it twice, under ``cosim run CASE.toml`` and with the participants started by hand as
``run.sh`` starts them (the first starts the coupler), and prints a table: windows, converged windows, the
coupling iterations (in all, and in the first window), the exit codes, and the last line each participant printed.

Usage: python -m scripts.precice_tutorials TUTORIALS --out DIR [--case NAME ...] [--python PY] [--mode cosim-run]
``--python`` runs the participants with another interpreter (a venv with the participants' own needs, nutils 7
say, and ``pip install ./precice_compat/participant``); by default the coupler's. Results go to
``DIR/<case>-<mode>/`` and ``DIR/table.json`` as each run ends; a rerun goes on with the runs it lacks.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from cosim.results import RunResults

NUTILS = {"NUTILS_RICHOUTPUT": "no"}
# case -> (its folder, {participant: (folder, command, environment)})
CASES: dict[str, tuple[str, dict[str, tuple[str, str, dict[str, str]]]]] = {
    "elastic-tube-1d": ("elastic-tube-1d", {
        "Fluid": ("fluid-python", "python3 ./FluidSolver.py ../precice-config.xml", {}),
        "Solid": ("solid-python", "python3 ./SolidSolver.py ../precice-config.xml", {})}),
    "perpendicular-flap (fake)": ("perpendicular-flap", {
        "Fluid": ("fluid-fake", "python3 fake.py", {}),
        "Solid": ("solid-fake", "python3 fake.py", {})}),
    "perpendicular-flap (fake fluid, nutils solid)": ("perpendicular-flap", {
        "Fluid": ("fluid-fake", "python3 fake.py", {}),
        "Solid": ("solid-nutils", "python3 solid.py", NUTILS)}),
    "resonant-circuit": ("resonant-circuit", {
        "Coil": ("coil-python", "python3 coil.py", {}),
        "Capacitor": ("capacitor-python", "python3 capacitor.py", {})}),
    "oscillator": ("oscillator", {
        "Mass-Left": ("mass-left-python", "python3 ../solver-python/oscillator.py Mass-Left", {}),
        "Mass-Right": ("mass-right-python", "python3 ../solver-python/oscillator.py Mass-Right", {})}),
    "oscillator-overlap": ("oscillator-overlap", {
        "Mass-Left": ("mass-left-python", "python3 ../solver-python/oscillator.py Mass-Left", {}),
        "Mass-Right": ("mass-right-python", "python3 ../solver-python/oscillator.py Mass-Right", {})}),
    "partitioned-heat-conduction (nutils)": ("partitioned-heat-conduction", {
        "Dirichlet": ("dirichlet-nutils", "python3 heat.py", NUTILS),
        "Neumann": ("neumann-nutils", "python3 heat.py", NUTILS)}),
    "partitioned-heat-conduction-direct (nutils)": ("partitioned-heat-conduction-direct", {
        "Dirichlet": ("dirichlet-nutils", "python3 heat.py", NUTILS),
        "Neumann": ("neumann-nutils", "python3 heat.py", NUTILS)}),
    "channel-transport (nutils)": ("channel-transport", {
        "Fluid": ("fluid-nutils", "python3 fluid.py", {}),
        "Transport": ("transport-nutils", "python3 transport.py", {})}),
}
MODES = ("cosim-run", "by-hand")
TIMEOUT = 1800.0


def slug(name: str) -> str:
    return "".join(c if c.isalnum() or c == "-" else "-" for c in name).strip("-").replace("--", "-")


def command_of(command: str, python: str | None) -> str:
    return command.replace("python3 ", f"{python} ", 1) if python else command


def write_case(tutorials: Path, name: str, python: str | None, where: Path) -> Path:
    """The case file of one tutorial, its paths absolute (the tutorials' checkout is left as it is)."""
    folder, participants = CASES[name]
    lines = [f"# preCICE's tutorial {name}, its participants unmodified", "[precice]",
             f'config = "{tutorials / folder / "precice-config.xml"}"']
    for participant, (cwd, command, environment) in participants.items():
        lines += [f'[participants.{participant}]', f'command = "{command_of(command, python)}"',
                  f'cwd = "{tutorials / folder / cwd}"', "timeout = 600"]
        if environment:
            lines.append("environment = { " + ", ".join(f'{k} = "{v}"' for k, v in environment.items()) + " }")
    where.mkdir(parents=True, exist_ok=True)
    case = where / "case.toml"
    case.write_text("\n".join(lines) + "\n")
    return case


def last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip() and "%|" not in line]
    return lines[-1][:160] if lines else ""


def summary(results_file: Path) -> dict:
    if not results_file.exists():
        return {}
    with RunResults(results_file) as results:
        windows = results.windows
        return {"windows": len(windows), "converged": int(np.sum(windows.converged)),
                "iterations": int(np.sum(windows.iterations)),
                "first_window": int(windows.iterations[0]) if len(windows) else 0}


def run_cosim(tutorials: Path, name: str, python: str | None, out: Path) -> dict:
    case = write_case(tutorials, name, python, out)
    if (out / "run").exists():
        shutil.rmtree(out / "run")         # a run the table does not hold: cut off before it was written
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(case), "--out", str(out / "run"), "--quiet"],
                          capture_output=True, text=True, timeout=TIMEOUT)
    row = {"exit": {"cosim": done.returncode}, "wall": time.perf_counter() - started,
           "error": last_line(done.stderr) if done.returncode else "", **summary(out / "run" / "results.h5")}
    logs = out / "run" / "logs"
    row["printed"] = {p: last_line((logs / f"{p}.log").read_text(errors="replace"))
                      for p in CASES[name][1] if (logs / f"{p}.log").exists()}
    return row


def run_by_hand(tutorials: Path, name: str, python: str | None, out: Path) -> dict:
    """Each participant started in its folder as run.sh starts it; the first starts the coupler."""
    folder, participants = CASES[name]
    runs = tutorials / folder / "cosim-run"
    if runs.exists():
        shutil.rmtree(runs)           # an earlier run's coupler.json and runs: this run starts afresh
    shim = Path(__file__).resolve().parents[1] / "precice_compat" / "participant"
    environment = {**os.environ, "PYTHONPATH": str(shim), "COSIM": f"{sys.executable} -m cosim"}
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    processes = {}
    for participant, (cwd, command, extra) in participants.items():
        log = (out / f"{participant}.log").open("w")
        processes[participant] = subprocess.Popen(command_of(command, python), shell=True, cwd=tutorials / folder / cwd,
                                                  env={**environment, **extra}, stdout=log, stderr=subprocess.STDOUT,
                                                  start_new_session=True)
    deadline = time.monotonic() + TIMEOUT
    codes = {}
    try:
        for participant, process in processes.items():
            codes[participant] = process.wait(timeout=max(1.0, deadline - time.monotonic()))
    finally:
        for process in processes.values():
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
    row = {"exit": codes, "wall": time.perf_counter() - started,
           "printed": {p: last_line((out / f"{p}.log").read_text(errors="replace")) for p in participants}}
    found = sorted(runs.glob("runs/*/results.h5")) if runs.exists() else []
    if found:
        row.update(summary(found[-1]))
        shutil.copytree(found[-1].parent, out / "run", dirs_exist_ok=True)
    return row


def table(rows: dict[str, dict]) -> str:
    lines = ["| case | mode | windows (converged) | iterations | first window | exits | wall s | note |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for key, row in rows.items():
        name, mode = key.rsplit(" / ", 1)
        exits = ", ".join(f"{k} {v}" for k, v in row.get("exit", {}).items())
        note = row.get("error") or "; ".join(f"{k}: {v}" for k, v in row.get("printed", {}).items())
        lines.append(f"| {name} | {mode} | {row.get('windows', '-')} ({row.get('converged', '-')}) | "
                     f"{row.get('iterations', '-')} | {row.get('first_window', '-')} | {exits} | "
                     f"{row.get('wall', 0):.1f} | {note.replace('|', '/')} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tutorials", type=Path, help="a checkout of preCICE's tutorials")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--case", action="append", choices=list(CASES), help="only these cases (default: all)")
    parser.add_argument("--mode", action="append", choices=MODES, help="only these ways to start (default: both)")
    parser.add_argument("--python", help="the participants' Python (default: the coupler's)")
    args = parser.parse_args(argv)
    store = args.out / "table.json"
    rows = json.loads(store.read_text()) if store.exists() else {}
    for name in args.case or list(CASES):
        for mode in args.mode or MODES:
            key = f"{name} / {mode}"
            if key in rows:
                continue
            where = args.out / f"{slug(name)}-{mode}"
            run = run_cosim if mode == "cosim-run" else run_by_hand
            rows[key] = run(args.tutorials.resolve(), name, args.python, where)
            store.write_text(json.dumps(rows, indent=1))
            print(table({key: rows[key]}).splitlines()[-1], flush=True)
    print(table(rows))


if __name__ == "__main__":
    main()
