"""Where a coupling iteration's time goes: the components' compute, the wire, the coupler itself, against the
floor of compute plus two raw ZeroMQ ping-pongs, measured in one run.

For the tube FOM-FOM, ROM-FOM and FMU-FOM runs and two trivial components (benchmarks/trivial_components.py),
each a ``cosim run`` in its own process, the table gives per coupling iteration (medians over the run's calls):
- compute: the CPU time of each component's step call, in its own process (``cpu_seconds``);
- wire: round trip minus the component's own wall time, per call, summed over the iteration's calls;
- coupler: the windows' wall time less every round trip, per iteration (acceleration, measures, recording, the
  results file);
- outside the windows: the process's wall time less the windows' (start-up, the components' start, the plots);
- the floor: (compute + 2 ping-pongs) per iteration times the iterations, and the wall time over it.

Usage: python -m benchmarks.coupler_cost [--small]   (--small: short runs, for the tests)
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from benchmarks.common import fresh_directory, machine
from benchmarks.trivial_components import SCENE as TRIVIAL_SCENE
from benchmarks.tube_run import zmq_ping_floor
from cosim.results import RunResults

ROOT = Path(__file__).resolve().parent.parent
TUBE = ROOT / "scenes" / "tube_fom.toml"


def cosim_run(scene: Path, out: Path, overrides: list[str]) -> float:
    """``cosim run`` in its own process, as a user runs it; its wall time from launch to exit."""
    started = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "cosim", "run", str(scene), "--out", str(out), "--quiet",
                           *[a for item in overrides for a in ("--set", item)]], cwd=ROOT, capture_output=True,
                          text=True, timeout=3600)
    if done.returncode != 0:
        raise RuntimeError(f"cosim run {scene} failed: {done.stderr.strip()[-500:]}")
    return time.perf_counter() - started


def split(out: Path, process_wall: float, ping: float) -> dict[str, Any]:
    """The per-iteration split of the run in ``out`` (``ping``: the raw ping-pong's median, s)."""
    with RunResults(out) as results:
        windows = results.windows
        iterations = int(windows.iterations.sum())
        cpu = wire = roundtrips = 0.0
        for name in results.component_names():
            record = results.component(name)
            if not len(record.cpu_seconds):
                continue
            cpu += float(record.cpu_seconds.sum())
            wire += float((record.roundtrip_seconds - record.compute_seconds).sum())
            roundtrips += float(record.roundtrip_seconds.sum())
        window_wall = float(windows.wall_seconds.sum())
    floor = cpu + 2 * ping * iterations
    return {"windows": len(windows), "iterations": iterations, "process_wall": process_wall,
            "compute_us": cpu / iterations * 1e6, "wire_us": wire / iterations * 1e6,
            "coupler_us": (window_wall - roundtrips) / iterations * 1e6,
            "outside_s": process_wall - window_wall, "floor_s": floor, "over_floor": process_wall / floor,
            "window_over_floor": window_wall / floor}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="short runs (for the tests)")
    args = parser.parse_args(argv)
    out = fresh_directory("coupler_cost")
    end, train_end = (4.0, 2.0) if args.small else (120.0, 18.0)
    print(f"machine: {machine()}")
    ping = zmq_ping_floor(300 if args.small else 3000)
    print(f"raw ZeroMQ ping-pong, 808 bytes, us: {ping}")
    model, fmu = out / "model.npz", out / "rom.fmu"
    subprocess.run([sys.executable, "-m", "cosim", "run", str(TUBE), "--out", str(out / "train"), "--quiet",
                    "--set", f"time.end={train_end:g}"], cwd=ROOT, check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "cosim", "train", str(out / "train" / "results.h5"), "--config",
                    str(ROOT / "scenes" / "tube_rom.toml"), "--set", f"snapshots.t_max={train_end:g}", "--out",
                    str(model)], cwd=ROOT, check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "cosim", "export-fmu", str(model), "--out", str(fmu)], cwd=ROOT,
                   check=True, capture_output=True)
    trivial = out / "trivial.toml"
    trivial.write_text(TRIVIAL_SCENE.format(end=1.0 if args.small else 10.0))
    cases = {
        "tube FOM-FOM": (TUBE, [f"time.end={end:g}"]),
        "tube ROM-FOM": (TUBE, [f"time.end={end:g}", "components.solid.backend=rom",
                                f"components.solid.rom.model={model}", "components.solid.rom.switch_time=0"]),
        "tube FMU-FOM": (TUBE, [f"time.end={end:g}", "components.solid.backend=fmu",
                                f"components.solid.fmu.path={fmu}", "components.solid.fmu.switch_time=0"]),
        "two trivial components": (trivial, []),
    }
    rows = {}
    print(f"\n{'per coupling iteration':<24}{'windows':>8}{'iters':>7}{'compute us':>11}{'wire us':>9}"
          f"{'coupler us':>11}{'outside s':>10}{'wall s':>8}{'floor s':>8}{'wall/floor':>11}{'iter/s':>8}")
    for label, (scene, overrides) in cases.items():
        directory = out / label.replace(" ", "_")
        wall = cosim_run(scene, directory, overrides)
        row = rows[label] = split(directory, wall, ping.median * 1e-6)
        print(f"{label:<24}{row['windows']:>8}{row['iterations']:>7}{row['compute_us']:>11.0f}{row['wire_us']:>9.0f}"
              f"{row['coupler_us']:>11.0f}{row['outside_s']:>10.2f}{wall:>8.2f}{row['floor_s']:>8.2f}"
              f"{row['over_floor']:>11.2f}{row['iterations'] / wall:>8.0f}")
    print(f"\nwire: round trip - the component's own wall time, both calls of an iteration; the ping-pong bound: "
          f"{2 * ping.median:.0f} us per iteration. floor: (compute + 2 ping-pongs) x iterations. outside: the "
          "process's wall time less its windows' (start-up, components' start, plots)")
    return {"machine": machine(), "ping": ping, "rows": rows,
            "ping_bound_iterations_per_second": 1e6 / (2 * ping.median)}


if __name__ == "__main__":
    main()
