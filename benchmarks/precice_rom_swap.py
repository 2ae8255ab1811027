"""A preCICE case's solid participant, compiled or not, swapped for the ROM trained on its recorded calls.

The case's participants run unmodified under ``cosim run``: first full order (FOM-FOM), every call of the solid
recorded; ``cosim train`` fits the ROM on the calls up to ``--train-until``; then one line of the case file
(``backend = "rom"``) swaps the solid for it, the other participants unchanged. FOM-FOM and ROM-FOM runs then
alternate, ``--repeat`` of each. The table gives, medians [min-max] over the repeats:

- the iterations of each run, and the ROM's error against the FOM run: the solid's output field (relative L2 over
  every window and vertex) and the watch point's first component (relative L2 and max error over max value), on the
  training span and after it;
- sigma: the solid's CPU time per call against the ROM's (each process's own CPU time, per call, in results.h5);
- T_s and T_f, the solid's and the other participants' CPU time in a FOM-FOM run, the bound 1 + T_s / T_f on the
  speed-up, and the speed-up measured: FOM-FOM wall time over ROM-FOM wall time (``wall_seconds``).

A compiled solid (preCICE's CalculiX adapter) is built against cosim's libprecice (``cosim libprecice install``,
then the adapter's own build with ``PKG_CONFIG_PATH`` from ``cosim libprecice env``); neither the adapter nor
CalculiX is part of this project.

Usage: python -m benchmarks.precice_rom_swap --case DIR --participant NAME=FOLDER:COMMAND ... --out DIR
[--rom Solid] [--rom-config TOML] [--max-time T] [--train-until T] [--repeat N] [--figure PNG];
``--small``: examples/precice_tube, its Python participants, the tube's static ROM, 12 windows (the tests' mode).
Results go to ``DIR/`` (the case's copy, ``runs/``, ``model.npz``, ``summary.json``, the figure); a rerun goes on
with the runs it lacks.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import ROOT, machine
from cosim.results import RunResults
from precice_compat.config import read_config

STEP_MAP = "rom_component.dynamic.component:StepMapRomSolid"
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def toml_string(text: str) -> str:
    return json.dumps(text)           # a JSON string is a TOML basic string


def prepare(case: Path, participants: dict[str, tuple[str, str]], rom: str, max_time: float | None,
            out: Path) -> Path:
    """A copy of the case's configuration and participant folders in ``out/case`` (solvers write where they run)
    and its case file; returns the case file."""
    where = out / "case"
    if not where.exists():
        where.mkdir(parents=True)
        config = (case / "precice-config.xml").read_text()
        if max_time is not None:
            config, count = re.subn(r'(<max-time\s+value=")[^"]*(")', rf"\g<1>{max_time:g}\g<2>", config)
            if count != 1:
                raise SystemExit(f"{case / 'precice-config.xml'}: no single <max-time value=...> to set")
        (where / "precice-config.xml").write_text(config)
        for folder, _ in participants.values():
            shutil.copytree(case / folder, where / folder, symlinks=True,
                            ignore=shutil.ignore_patterns("precice-run", "precice-profiling", "*.log", ".venv"))
    lines = ["# the case's participants unmodified; the solid's ROM one line away (backend)", "[precice]",
             'config = "precice-config.xml"']
    for name, (folder, command) in participants.items():
        lines += [f"[participants.{name}]", f"command = {toml_string(command)}", f"cwd = {toml_string(folder)}",
                  "timeout = 1800", "environment = { " + ", ".join(f'{k} = "{v}"' for k, v in ONE_THREAD.items())
                  + " }"]
        if name == rom:
            lines += [f"[participants.{name}.rom]", f"model = {toml_string(str(out / 'model.npz'))}"]
            memory = json.loads((out / "rom.json").read_text())["memory"] if (out / "rom.json").exists() else False
            if memory:
                lines.append(f"entry = {toml_string(STEP_MAP)}")
    (where / "case.toml").write_text("\n".join(lines) + "\n")
    return where / "case.toml"


def run(case_file: Path, out: Path, *overrides: str) -> None:
    """One ``cosim run`` in its own process (a finished run is kept: a rerun goes on with those it lacks)."""
    if (out / "status.json").exists() and json.loads((out / "status.json").read_text()).get("state") == "finished":
        return
    if out.exists():
        shutil.rmtree(out)
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(case_file), "--out", str(out), "--quiet",
                           *(f"--set={item}" for item in overrides)], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"cosim run {case_file} --out {out}: exit {done.returncode}: "
                         f"{(done.stderr.strip().splitlines() or [''])[-1]}")


def train(fom: Path, out: Path, rom_config: Path, rom: str, inputs: str, outputs: str, until: float) -> None:
    from rom_component.static.train import load_config
    settings = [f"snapshots.component={rom}", f"snapshots.input={inputs}", f"snapshots.output={outputs}",
                f"snapshots.t_max={until:g}"]
    memory = bool(load_config(rom_config, settings).get("dynamics", {}).get("memory", False))
    if not (out / "model.npz").exists():
        done = subprocess.run([sys.executable, "-m", "cosim", "train", str(fom / "results.h5"), "--config",
                               str(rom_config), "--out", str(out / "model.npz"), *(f"--set={s}" for s in settings)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"cosim train: exit {done.returncode}: {(done.stderr.strip().splitlines() or [''])[-1]}")
        (out / "train.log").write_text(done.stdout)
    (out / "rom.json").write_text(json.dumps({"memory": memory, "train_until": until}))


def watch_point(run_dir: Path) -> dict[str, np.ndarray] | None:
    """The first watch point's log of a run, by column (None if the case has none)."""
    logs = sorted(run_dir.glob("precice-*-watchpoint-*.log"))
    if not logs:
        return None
    header = logs[0].read_text().splitlines()[0].split()
    table = np.loadtxt(logs[0], skiprows=1, ndmin=2)
    return {name: table[:, k] for k, name in enumerate(header)}


def errors(fom: Path, rom: Path, output: str, until: float) -> dict[str, float]:
    """The ROM-FOM run's error against the FOM-FOM run's, on the training span and after it."""
    with RunResults(fom) as a, RunResults(rom) as b:
        times = a.windows.time
        u, v = a.fields()[output], b.fields()[output]
    found: dict[str, float] = {}
    spans = {"train": times <= until + 1e-9, "after": times > until + 1e-9}
    for span, rows in spans.items():
        if rows.any():
            found[f"field_{span}"] = float(np.linalg.norm(v[rows] - u[rows]) / np.linalg.norm(u[rows]))
    p, q = watch_point(fom), watch_point(rom)
    if p is not None and q is not None:
        column = next(name for name in p if not name.startswith(("Time", "Coordinate")) and name.startswith(output))
        for span, rows in spans.items():
            if rows.any():
                d = q[column][rows] - p[column][rows]
                found[f"point_{span}"] = float(np.linalg.norm(d) / np.linalg.norm(p[column][rows]))
                found[f"point_max_{span}"] = float(np.abs(d).max() / np.abs(p[column][rows]).max())
        found["point_last_fom"], found["point_last_rom"] = float(p[column][-1]), float(q[column][-1])
    return found


def costs(run_dir: Path, rom: str) -> dict[str, float]:
    """Iterations, wall time, and each process's CPU time of a run: the solid's (or its ROM's) and the others'."""
    with RunResults(run_dir) as results:
        records = [results.component(name) for name in results.component_names()]
        solid = [r for r in records if r.attributes.get("participant", r.name) == rom]
        others = [r for r in records if r.attributes.get("participant", r.name) != rom]
        per_call = np.concatenate([r.cpu_seconds for r in solid])
        return {"iterations": int(results.windows.iterations.sum()), "windows": len(results.windows),
                "wall": float(results.file.attrs["wall_seconds"]),
                "solid_cpu": float(per_call.sum()), "solid_cpu_per_call": float(np.median(per_call)),
                "others_cpu": float(sum(r.cpu_seconds.sum() for r in others))}


def spread(values: list[float], digits: str = ".3g") -> str:
    return f"{np.median(values):{digits}} [{min(values):{digits}}-{max(values):{digits}}]"


def figure(fom: Path, rom: Path, output: str, until: float, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    p, q = watch_point(fom), watch_point(rom)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    if p is not None and q is not None:
        column = next(n for n in p if n.startswith(output))
        top.plot(p["Time"], p[column], label="full order (its recorded calls train the ROM)")
        top.plot(q["Time"], q[column], "--", label="ROM, swapped in by one line")
        bottom.semilogy(p["Time"], np.abs(q[column] - p[column]) / np.abs(p[column]).max())
        top.set_ylabel(f"watch point: {column}")
    else:
        with RunResults(fom) as a, RunResults(rom) as b:
            t, u, v = a.windows.time, a.fields()[output], b.fields()[output]
        top.plot(t, u.reshape(len(u), -1)[:, 0], label="full order")
        top.plot(t, v.reshape(len(v), -1)[:, 0], "--", label="ROM")
        bottom.semilogy(t, np.linalg.norm((v - u).reshape(len(u), -1), axis=1)
                        / np.linalg.norm(u.reshape(len(u), -1), axis=1).max())
        top.set_ylabel(f"{output}, first value")
    for axis in (top, bottom):
        axis.axvspan(0, until, color="0.9", zorder=0)
    top.legend(loc="best", fontsize=8)
    bottom.set_ylabel("|ROM - FOM| / max |FOM|")
    bottom.set_xlabel("time (s); shaded: the calls the ROM was trained on")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", type=Path, help="the preCICE case: a folder with precice-config.xml")
    parser.add_argument("--participant", action="append", default=[], metavar="NAME=FOLDER:COMMAND",
                        help="a participant's folder in the case and its command (as its run.sh gives it)")
    parser.add_argument("--rom", default="Solid", help="the participant the ROM replaces")
    parser.add_argument("--rom-config", type=Path, default=ROOT / "rom_configs" / "precice_flap_rom.toml")
    parser.add_argument("--max-time", type=float, help="the run's <max-time> (default: the configuration's)")
    parser.add_argument("--train-until", type=float, help="the ROM trains on the calls up to this time "
                        "(default: half the run)")
    parser.add_argument("--repeat", type=int, default=3, help="FOM-FOM and ROM-FOM runs each, alternated")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "precice_rom_swap")
    parser.add_argument("--figure", type=Path, help="where the figure goes (default: OUT/rom-swap.png)")
    parser.add_argument("--small", action="store_true", help="examples/precice_tube, 12 windows, one run each")
    args = parser.parse_args(argv)
    if args.small:
        args.case = ROOT / "examples" / "precice_tube"
        args.participant = ["Fluid=fluid-python:python3 FluidSolver.py ../precice-config.xml 1.2",
                            "Solid=solid-python:python3 SolidSolver.py ../precice-config.xml"]
        args.rom_config, args.max_time, args.train_until = ROOT / "rom_configs" / "tube_rom.toml", 1.2, 1.2
        args.repeat = 1
    if args.case is None or not args.participant:
        parser.error("give --case and each --participant (or --small)")
    participants = {}
    for item in args.participant:
        name, _, rest = item.partition("=")
        folder, _, command = rest.partition(":")
        if not (name and folder and command):
            parser.error(f"--participant {item!r}: expected NAME=FOLDER:COMMAND")
        participants[name] = (folder, command)
    if args.rom not in participants:
        parser.error(f"--rom {args.rom!r} is none of the participants ({', '.join(participants)})")
    config = read_config(args.case / "precice-config.xml")
    solid = config.participants[args.rom]
    (inputs, *_), (outputs, *_) = solid.reads, solid.writes
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    case_file = prepare(args.case.resolve(), participants, args.rom, args.max_time, out)
    run(case_file, out / "runs" / "fom-1")
    with RunResults(out / "runs" / "fom-1") as results:
        end = float(results.windows.time[-1])
    until = args.train_until if args.train_until is not None else end / 2
    train(out / "runs" / "fom-1", out, args.rom_config, args.rom, inputs, outputs, until)
    case_file = prepare(args.case.resolve(), participants, args.rom, args.max_time, out)   # the ROM's entry
    for k in range(1, args.repeat + 1):
        run(case_file, out / "runs" / f"rom-{k}", f"participants.{args.rom}.backend=rom")
        if k > 1:
            run(case_file, out / "runs" / f"fom-{k}")
    foms = [costs(out / "runs" / f"fom-{k}", args.rom) for k in range(1, args.repeat + 1)]
    roms = [costs(out / "runs" / f"rom-{k}", args.rom) for k in range(1, args.repeat + 1)]
    error = errors(out / "runs" / "fom-1", out / "runs" / "rom-1", outputs, until)
    sigma = [f["solid_cpu_per_call"] / r["solid_cpu_per_call"] for f, r in zip(foms, roms)]
    bound = [1 + f["solid_cpu"] / f["others_cpu"] for f in foms]
    speedup = [f["wall"] / r["wall"] for f, r in zip(foms, roms)]
    summary = {"machine": machine(), "case": str(args.case), "participants": participants, "rom": args.rom,
               "train_until": until, "end": end, "errors": error, "fom": foms, "rom_runs": roms, "sigma": sigma,
               "bound": bound, "speedup": speedup}
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    figure(out / "runs" / "fom-1", out / "runs" / "rom-1", outputs, until, args.figure or out / "rom-swap.png")
    print(f"# {args.rom} of {args.case.name} swapped for its ROM ({machine()}); {args.repeat} runs each, alternated; "
          f"medians [min-max]; trained on t <= {until:g} of {end:g}")
    print("| | FOM-FOM | ROM-FOM |\n| --- | --- | --- |")
    print(f"| coupling iterations | {spread([f['iterations'] for f in foms], 'g')} | "
          f"{spread([r['iterations'] for r in roms], 'g')} |")
    print(f"| wall time, s | {spread([f['wall'] for f in foms])} | {spread([r['wall'] for r in roms])} |")
    print(f"| {args.rom}'s CPU time per call, ms | {spread([1e3 * f['solid_cpu_per_call'] for f in foms])} | "
          f"{spread([1e3 * r['solid_cpu_per_call'] for r in roms])} |")
    print(f"| the others' CPU time, s | {spread([f['others_cpu'] for f in foms])} | "
          f"{spread([r['others_cpu'] for r in roms])} |")
    print(f"\nsigma (CPU per call, FOM / ROM) {spread(sigma)}; bound 1 + T_s/T_f {spread(bound)}; "
          f"speed-up measured (wall) {spread(speedup)}")
    print("ROM-FOM error: " + ", ".join(f"{k} {v:.3e}" for k, v in error.items()))
    return summary


if __name__ == "__main__":
    main()
