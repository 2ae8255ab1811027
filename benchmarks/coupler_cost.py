"""Where a coupling iteration's time goes: the components' compute, the wire, the coupler itself, against the
floor of compute plus two raw ZeroMQ ping-pongs, measured in one run; and the run's start-up and end.

For the tube FOM-FOM, ROM-FOM and FMU-FOM runs and two trivial components (benchmarks/trivial_components.py),
each a ``cosim run`` in its own process, and the trivial components with waveforms (4 steps a window each, every
substep exchanged, cubic B-splines) against the same components exchanging the window's end alone on 4 times the
nodes (the same number of values per window, the cost of waveforms on its own; both under Aitken, two iterations
a window in both), the table gives per coupling iteration (over the run's calls):
- compute: the CPU time of each component's step call, in its own process (``cpu_seconds``);
- wire: round trip minus the component's own wall time, summed over an iteration's calls, and the median call's
  over one raw ping-pong (``wire/ping``);
- coupler: the windows' wall time less every round trip, per iteration (acceleration, measures, recording, the
  results file);
- the floor: (compute + 2 ping-pongs) per iteration times the iterations, and the wall time over it, with the
  ping-pong measured right before the run (``ping us``: the machine's pace drifts with other tenants' load);
- start-up: from the launch of ``cosim run`` to its first window, less the components' own start-up (spawn to the
  end of their initialisation, ``components_startup_seconds``); end: from the last window to the process's exit,
  ``run.png`` written.

``--repeat N`` runs every case N times, interleaved, and prints the median with the range of each figure.
``--baseline TREE`` runs the same cases with the code of another checkout (a worktree of an earlier commit),
interleaved with this one, for a before/after in one run (its start-up and end split need this tree's results
attributes; the baseline gives the totals).

Usage: python -m benchmarks.coupler_cost [--small] [--repeat N] [--baseline TREE]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import fresh_directory, machine
from benchmarks.trivial_components import SCENE as TRIVIAL_SCENE
from benchmarks.tube_run import zmq_ping_floor
from cosim.results import RunResults

ROOT = Path(__file__).resolve().parent.parent
TUBE = ROOT / "scenes" / "tube_fom.toml"
COLUMNS = [("iterations", "iters", "{:.0f}"), ("ping_us", "ping us", "{:.0f}"), ("compute_us", "compute us", "{:.0f}"), ("wire_us", "wire us", "{:.0f}"),
           ("wire_per_ping", "wire/ping", "{:.2f}"), ("coupler_us", "coupler us", "{:.0f}"),
           ("startup_s", "start-up s", "{:.2f}"), ("end_s", "end s", "{:.2f}"), ("process_wall", "wall s", "{:.2f}"),
           ("floor_s", "floor s", "{:.2f}"), ("over_floor", "wall/floor", "{:.2f}"),
           ("window_over_floor", "win. wall/floor", "{:.2f}"), ("iterations_per_second", "iter/s", "{:.0f}")]


def cosim_run(scene: Path, out: Path, overrides: list[str], tree: Path = ROOT) -> tuple[float, float]:
    """``cosim run`` in its own process, as a user runs it, with the code of ``tree``; the Unix times of its
    launch and exit."""
    launched = time.time()
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(scene), "--out", str(out), "--quiet",
                           *[a for item in overrides for a in ("--set", item)]], cwd=tree, capture_output=True,
                          text=True, timeout=3600)
    if done.returncode != 0:
        raise RuntimeError(f"cosim run {scene} failed: {done.stderr.strip()[-500:]}")
    return launched, time.time()


def split(out: Path, launched: float, exited: float, ping: float) -> dict[str, Any]:
    """The per-iteration split of the run in ``out`` (``ping``: the raw ping-pong's median, s), its start-up and
    end."""
    with RunResults(out) as results:
        windows = results.windows
        attributes = results.attributes
        iterations = int(windows.iterations.sum())
        cpu = roundtrips = 0.0
        wires = []
        for name in results.component_names():
            record = results.component(name)
            if not len(record.cpu_seconds):
                continue
            cpu += float(record.cpu_seconds.sum())
            roundtrips += float(record.roundtrip_seconds.sum())
            wires.append(record.roundtrip_seconds - record.compute_seconds)
        window_wall = float(windows.wall_seconds.sum())
    wire = np.concatenate(wires)
    process_wall = exited - launched
    floor = cpu + 2 * ping * iterations
    row = {"windows": len(windows), "iterations": iterations, "process_wall": process_wall,
           "compute_us": cpu / iterations * 1e6, "wire_us": float(wire.sum()) / iterations * 1e6,
           "wire_per_ping": float(np.median(wire)) / ping,
           "coupler_us": (window_wall - roundtrips) / iterations * 1e6,
           "floor_s": floor, "over_floor": process_wall / floor, "window_over_floor": window_wall / floor,
           "iterations_per_second": iterations / process_wall, "startup_s": float("nan"), "end_s": float("nan")}
    if "first_window_started" in attributes:
        row["startup_s"] = attributes["first_window_started"] - launched - attributes["components_startup_seconds"]
        row["end_s"] = exited - attributes["last_window_ended"]
    return row


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Each figure's median over repeated runs, with its range (``<key>_range``)."""
    merged: dict[str, Any] = {}
    for key in rows[0]:
        values = np.array([row[key] for row in rows], dtype=float)
        merged[key] = float(np.median(values))
        merged[f"{key}_range"] = (float(values.min()), float(values.max()))
    return merged


def cases(out: Path, small: bool) -> dict[str, tuple[Path, list[str]]]:
    """The four runs, with a ROM trained on a short FOM run and its FMU."""
    end, train_end = (4.0, 2.0) if small else (120.0, 18.0)
    model, fmu = out / "model.npz", out / "rom.fmu"
    subprocess.run([sys.executable, "-m", "cosim", "run", str(TUBE), "--out", str(out / "train"), "--quiet",
                    "--set", f"time.end={train_end:g}"], cwd=ROOT, check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "cosim", "train", str(out / "train" / "results.h5"), "--config",
                    str(ROOT / "rom_configs" / "tube_rom.toml"), "--set", f"snapshots.t_max={train_end:g}", "--out",
                    str(model)], cwd=ROOT, check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "cosim", "export-fmu", str(model), "--out", str(fmu)], cwd=ROOT,
                   check=True, capture_output=True)
    trivial = out / "trivial.toml"
    trivial.write_text(TRIVIAL_SCENE.format(end=1.0 if small else 10.0))
    nodes = 101
    waveforms = out / "trivial_waveforms.toml"
    text = TRIVIAL_SCENE.format(end=1.0 if small else 10.0).replace(
        'to = "solid"\n', 'to = "solid"\nwaveform_degree = 3\nsubsteps = true\n').replace(
        'to = "fluid"\n', 'to = "fluid"\nwaveform_degree = 3\nsubsteps = true\n')
    for name in ("fluid", "solid"):
        text = text.replace(f"[components.{name}]\n", f"[components.{name}]\nsubsteps = 4\n"
                                                      f"parameters = {{ nodes = {nodes} }}\n")
    waveforms.write_text(text)
    return {
        "tube FOM-FOM": (TUBE, [f"time.end={end:g}"]),
        "tube ROM-FOM": (TUBE, [f"time.end={end:g}", "components.solid.backend=rom",
                                f"components.solid.rom.model={model}", "components.solid.rom.switch_time=0"]),
        "tube FMU-FOM": (TUBE, [f"time.end={end:g}", "components.solid.backend=fmu",
                                f"components.solid.fmu.path={fmu}", "components.solid.fmu.switch_time=0"]),
        "two trivial components": (trivial, []),
        "trivial, 4 substeps": (waveforms, [AITKEN]),
        "trivial, end, 4x nodes": (trivial, [AITKEN, f"components.fluid.parameters.nodes={4 * nodes}",
                                             f"components.solid.parameters.nodes={4 * nodes}"]),
    }


WAVEFORM_CASES = ("trivial, 4 substeps", "trivial, end, 4x nodes")
# both waveform cases under Aitken: two iterations a window each, so that the acceleration costs the same per
# iteration (IQN-ILS takes 3.85 iterations a window with waveforms against 2, and its update grows with the columns)
AITKEN = 'coupling.acceleration={type="aitken", data=["section"], initial_relaxation=0.5}'


def cost(row: dict[str, Any]) -> float:
    """The coupler's own time and the wire's, per iteration."""
    return row["coupler_us"] + row["wire_us"]


def print_table(title: str, rows: dict[str, dict[str, Any]], spread: bool) -> None:
    print(f"\n{title}")
    print(f"{'per coupling iteration':<24}" + "".join(f"{label:>14}" for _, label, _ in COLUMNS))
    for case, row in rows.items():
        cells = []
        for key, _, form in COLUMNS:
            cell = form.format(row[key])
            if spread and f"{key}_range" in row and key != "iterations":
                low, high = row[f"{key}_range"]
                cell = f"{cell} [{form.format(low)}-{form.format(high)}]"
            cells.append(f"{cell:>14}" if not spread else f" {cell}")
        print(f"{case:<24}" + "".join(cells))


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="short runs (for the tests)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of every case, interleaved (default 1)")
    parser.add_argument("--baseline", type=Path, help="a checkout of other code, run interleaved with this one")
    args = parser.parse_args(argv)
    out = fresh_directory("coupler_cost")
    print(f"machine: {machine()}")
    ping = zmq_ping_floor(300 if args.small else 3000)
    print(f"raw ZeroMQ ping-pong, 808 bytes, us: {ping}")
    runs = cases(out, args.small)
    trees = {"this checkout": ROOT, **({"baseline": args.baseline.resolve()} if args.baseline else {})}
    measured: dict[str, dict[str, list[dict[str, Any]]]] = {tree: {case: [] for case in runs} for tree in trees}
    pings = []
    for repeat in range(args.repeat):
        for case, (scene, overrides) in runs.items():
            for tree, path in trees.items():
                if tree == "baseline" and case in WAVEFORM_CASES:
                    continue            # code from before waveforms has no such scene
                directory = out / f"{tree.replace(' ', '_')}-{case.replace(' ', '_')}-{repeat}"
                # the machine's pace drifts (other tenants' load): each run is held against a ping-pong just before
                near = zmq_ping_floor(200 if args.small else 1000).median * 1e-6
                pings.append(near)
                launched, exited = cosim_run(scene, directory, overrides, path)
                row = split(directory, launched, exited, near)
                row["ping_us"] = near * 1e6
                measured[tree][case].append(row)
    tables = {tree: {case: summary(rows) for case, rows in by_case.items() if rows}
              for tree, by_case in measured.items()}
    for tree, rows in tables.items():
        title = f"{tree} ({trees[tree]})" + (f", medians of {args.repeat} runs [range]" if args.repeat > 1 else "")
        print_table(title, rows, args.repeat > 1)
    print(f"\nwire: round trip - the component's own wall time, both calls of an iteration; "
          f"wire/ping: the median call's over one raw ping-pong; the ping-pong bound: {2 * ping.median:.0f} us per iteration. "
          "floor: (compute + 2 ping-pongs) x iterations. start-up: launch to the first window less the components' "
          "own start-up; end: the last window to the exit, run.png written")
    mine = tables["this checkout"]
    print(f"\nwaveforms: the coupler's cost per iteration with 4 substeps exchanged over that of the window's end "
          f"on 4 times the nodes: {mine['trivial, 4 substeps']['coupler_us'] / mine['trivial, end, 4x nodes']['coupler_us']:.2f}"
          f" (coupler + wire: {cost(mine['trivial, 4 substeps']) / cost(mine['trivial, end, 4x nodes']):.2f})")
    if args.baseline:
        print("\nthis checkout over the baseline, wall time: " + ", ".join(
            f"{case} {tables['this checkout'][case]['process_wall'] / tables['baseline'][case]['process_wall']:.2f}"
            for case in runs if case in tables["baseline"]))
    return {"machine": machine(), "ping": ping, "rows": tables["this checkout"], "tables": tables,
            "ping_bound_iterations_per_second": 1e6 / (2 * ping.median)}


if __name__ == "__main__":
    main()
