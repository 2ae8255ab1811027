"""preCICE's tutorials as a conformance suite: each case whose participants are all Python, run unmodified by cosim.

Give a checkout of preCICE's tutorials repository (v3 era; it is never part of this project). For each case the
script writes a case file into ``--out`` (the participants' commands as the tutorials' ``run.sh`` give them, in
their folders), runs it twice, under ``cosim run CASE.toml`` and with the participants started by hand as
``run.sh`` starts them (the first starts the coupler), and prints a table: windows, converged windows, the
coupling iterations (in all, and in the first window), the exit codes, and the last line each participant printed.

Usage: python -m scripts.precice_tutorials TUTORIALS --out DIR [--case NAME ...] [--python STACK=PY ...]
[--mode cosim-run] [--timeout S] [--call-timeout S]. ``--python nutils7=/venv/bin/python`` runs the participants
that need nutils 7 with that interpreter (a venv with their own needs and ``pip install ./precice_compat/participant``;
a participant started by a console script, the Micro Manager's, takes the one beside it); stacks: python, nutils6
(the perpendicular flap's nutils fluid: nutils 6.3, treelog<2, numpy<2; with SciPy, else nutils 6 solves dense),
nutils7, nutils9 (the perpendicular flap's nutils solid), micromanager (nutils 7 and micro-manager-precice 0.5.0
installed --no-deps, with mpi4py: 0.4.0, which the tutorial's requirements.txt pins, reads neither its
micro-manager-config.json nor has the run.sh's command), fenics (Debian's python3-dolfin with fenicsprecice), fmi
(preCICE's FMI runner fmiprecice with fmpy); default python3. ``--timeout`` bounds a run (default 1800 s),
``--call-timeout`` the coupler's wait for a participant's call under ``cosim run`` (default 600 s; the serial Micro
Manager's first window takes longer). Results go to ``DIR/<case>-<mode>/`` and ``DIR/table.json`` as each run ends;
a rerun goes on with the runs it lacks.
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
FENICS = {"OMP_NUM_THREADS": "1"}
# case -> (its folder, {participant: (folder, command, environment, stack)}); a stack is the software a participant
# needs beyond pyprecice ("python": NumPy alone; "nutils7", "nutils9", "fenics", "fmi": fmiprecice and fmpy), whose
# Python --python names
CASES: dict[str, tuple[str, dict[str, tuple[str, str, dict[str, str], str]]]] = {
    "elastic-tube-1d": ("elastic-tube-1d", {
        "Fluid": ("fluid-python", "python3 ./FluidSolver.py ../precice-config.xml", {}, "python"),
        "Solid": ("solid-python", "python3 ./SolidSolver.py ../precice-config.xml", {}, "python")}),
    "perpendicular-flap (fake)": ("perpendicular-flap", {
        "Fluid": ("fluid-fake", "python3 fake.py", {}, "python"),
        "Solid": ("solid-fake", "python3 fake.py", {}, "python")}),
    "perpendicular-flap (fake fluid, nutils solid)": ("perpendicular-flap", {
        "Fluid": ("fluid-fake", "python3 fake.py", {}, "python"),
        "Solid": ("solid-nutils", "python3 solid.py", NUTILS, "nutils9")}),
    "perpendicular-flap (nutils fluid, fake solid)": ("perpendicular-flap", {
        "Fluid": ("fluid-nutils", "python3 fluid.py", NUTILS, "nutils6"),
        "Solid": ("solid-fake", "python3 fake.py", {}, "python")}),
    "perpendicular-flap (fake fluid, FEniCS solid)": ("perpendicular-flap", {
        "Fluid": ("fluid-fake", "python3 fake.py", {}, "python"),
        "Solid": ("solid-fenics", "python3 solid.py", FENICS, "fenics")}),
    "resonant-circuit": ("resonant-circuit", {
        "Coil": ("coil-python", "python3 coil.py", {}, "python"),
        "Capacitor": ("capacitor-python", "python3 capacitor.py", {}, "python")}),
    "oscillator": ("oscillator", {
        "Mass-Left": ("mass-left-python", "python3 ../solver-python/oscillator.py Mass-Left", {}, "python"),
        "Mass-Right": ("mass-right-python", "python3 ../solver-python/oscillator.py Mass-Right", {}, "python")}),
    "oscillator (FMI runner)": ("oscillator", {      # Oscillator.fmu built in solver-fmi as its README says
        "Mass-Left": ("mass-left-fmi", "python3 -m fmiprecice.runner fmi-settings.json precice-settings.json", {},
                      "fmi"),
        "Mass-Right": ("mass-right-fmi", "python3 -m fmiprecice.runner fmi-settings.json precice-settings.json", {},
                       "fmi")}),
    "oscillator-overlap": ("oscillator-overlap", {
        "Mass-Left": ("mass-left-python", "python3 ../solver-python/oscillator.py Mass-Left", {}, "python"),
        "Mass-Right": ("mass-right-python", "python3 ../solver-python/oscillator.py Mass-Right", {}, "python")}),
    "partitioned-heat-conduction (nutils)": ("partitioned-heat-conduction", {
        "Dirichlet": ("dirichlet-nutils", "python3 heat.py", NUTILS, "nutils7"),
        "Neumann": ("neumann-nutils", "python3 heat.py", NUTILS, "nutils7")}),
    "partitioned-heat-conduction (FEniCS)": ("partitioned-heat-conduction", {
        "Dirichlet": ("dirichlet-fenics", "python3 ../solver-fenics/heat.py Dirichlet", FENICS, "fenics"),
        "Neumann": ("neumann-fenics", "python3 ../solver-fenics/heat.py Neumann", FENICS, "fenics")}),
    "partitioned-heat-conduction-overlap (FEniCS)": ("partitioned-heat-conduction-overlap", {
        "Left": ("left-fenics", "python3 ../solver-fenics/heat.py Left", FENICS, "fenics"),
        "Right": ("right-fenics", "python3 ../solver-fenics/heat.py Right", FENICS, "fenics")}),
    "partitioned-heat-conduction-complex (FEniCS)": ("partitioned-heat-conduction-complex", {
        "Dirichlet": ("dirichlet-fenics", "python3 ../solver-fenics/heat.py -d -i complex", FENICS, "fenics"),
        "Neumann": ("neumann-fenics", "python3 ../solver-fenics/heat.py -n -i complex", FENICS, "fenics")}),
    "partitioned-heat-conduction-direct (nutils)": ("partitioned-heat-conduction-direct", {
        "Dirichlet": ("dirichlet-nutils", "python3 heat.py", NUTILS, "nutils7"),
        "Neumann": ("neumann-nutils", "python3 heat.py", NUTILS, "nutils7")}),
    "volume-coupled-diffusion (FEniCS)": ("volume-coupled-diffusion", {
        "Source": ("source-fenics", "python3 ../solver-fenics/volume-coupled-diffusion.py --source", FENICS,
                   "fenics"),
        "Drain": ("drain-fenics", "python3 ../solver-fenics/volume-coupled-diffusion.py --drain", FENICS, "fenics")}),
    "channel-transport (nutils)": ("channel-transport", {
        "Fluid": ("fluid-nutils", "python3 fluid.py", NUTILS, "nutils7"),
        "Transport": ("transport-nutils", "python3 transport.py", NUTILS, "nutils7")}),
    "two-scale-heat-conduction (nutils, serial Micro Manager)": ("two-scale-heat-conduction", {
        "macro-heat": ("macro-nutils", "python3 macro.py richoutput=no", NUTILS, "nutils7"),
        "Micro-Manager": ("micro-nutils", "micro-manager-precice micro-manager-config.json", NUTILS,
                          "micromanager")}),
    "channel-transport-reaction (FEniCS)": ("channel-transport-reaction", {
        "Flow": ("fluid-fenics", "python3 fluid.py", FENICS, "fenics"),
        "Chemical": ("chemical-fenics", "python3 chemical-reaction-advection-diffusion.py", FENICS, "fenics")}),
}
MODES = ("cosim-run", "by-hand")
TIMEOUT = 1800.0
CALL_TIMEOUT = 600.0       # what the case file gives the coupler to wait for a participant's call (a window's work)


def slug(name: str) -> str:
    return "".join(c if c.isalnum() or c == "-" else "-" for c in name).strip("-").replace("--", "-")


def command_of(command: str, stack: str, pythons: dict[str, str]) -> str:
    """The tutorial's command with the Python of the participant's stack (python3 as in run.sh if none given); a
    command that starts with a console script (the Micro Manager's) takes the one beside that Python."""
    python = pythons.get(stack)
    if not python:
        return command
    if command.startswith("python3 "):
        return command.replace("python3 ", f"{python} ", 1)
    return str(Path(python).parent / command)


def write_case(tutorials: Path, name: str, pythons: dict[str, str], where: Path) -> Path:
    """The case file of one tutorial, its paths absolute (the tutorials' checkout is left as it is)."""
    folder, participants = CASES[name]
    lines = [f"# preCICE's tutorial {name}, its participants unmodified", "[precice]",
             f'config = "{tutorials / folder / "precice-config.xml"}"']
    for participant, (cwd, command, environment, stack) in participants.items():
        lines += [f'[participants.{participant}]', f'command = "{command_of(command, stack, pythons)}"',
                  f'cwd = "{tutorials / folder / cwd}"', f"timeout = {CALL_TIMEOUT:g}"]
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


def run_cosim(tutorials: Path, name: str, pythons: dict[str, str], out: Path) -> dict:
    case = write_case(tutorials, name, pythons, out)
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


def run_by_hand(tutorials: Path, name: str, pythons: dict[str, str], out: Path) -> dict:
    """Each participant started in its folder as run.sh starts it; the first starts the coupler."""
    folder, participants = CASES[name]
    runs = tutorials / folder / "cosim-run"
    if runs.exists():
        shutil.rmtree(runs)           # an earlier run's coupler.json and runs: this run starts afresh
    shim = Path(__file__).resolve().parents[1] / "precice_compat" / "participant"
    environment = {**os.environ, "PYTHONPATH": str(shim), "COSIM": str(Path(sys.executable).with_name("cosim"))}
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    processes = {}
    for participant, (cwd, command, extra, stack) in participants.items():
        log = (out / f"{participant}.log").open("w")
        processes[participant] = subprocess.Popen(command_of(command, stack, pythons), shell=True, cwd=tutorials / folder / cwd,
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
    global TIMEOUT, CALL_TIMEOUT
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tutorials", type=Path, help="a checkout of preCICE's tutorials")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--case", action="append", choices=list(CASES), help="only these cases (default: all)")
    parser.add_argument("--mode", action="append", choices=MODES, help="only these ways to start (default: both)")
    parser.add_argument("--timeout", type=float, default=TIMEOUT, help="seconds a run may take (default %(default)g)")
    parser.add_argument("--call-timeout", type=float, default=CALL_TIMEOUT,
                        help="seconds cosim run waits for a participant's call (default %(default)g)")
    parser.add_argument("--python", action="append", default=[], metavar="STACK=PY",
                        help="the Python of the participants of a stack (python, nutils6, nutils7, nutils9, "
                             "micromanager, fenics, fmi): a venv "
                             "with what they need and this project's pyprecice (pip install "
                             "./precice_compat/participant); default python3")
    args = parser.parse_args(argv)
    TIMEOUT, CALL_TIMEOUT = args.timeout, args.call_timeout
    pythons = dict(item.split("=", 1) for item in args.python)
    store = args.out / "table.json"
    rows = json.loads(store.read_text()) if store.exists() else {}
    for name in args.case or list(CASES):
        for mode in args.mode or MODES:
            key = f"{name} / {mode}"
            if key in rows:
                continue
            where = args.out / f"{slug(name)}-{mode}"
            run = run_cosim if mode == "cosim-run" else run_by_hand
            rows[key] = run(args.tutorials.resolve(), name, pythons, where)
            store.write_text(json.dumps(rows, indent=1))
            print(table({key: rows[key]}).splitlines()[-1], flush=True)
    print(table(rows))


if __name__ == "__main__":
    main()
