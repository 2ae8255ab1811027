"""Benchmark of the tube FOM-FOM run: wall time, per-call compute, coupler overhead, accelerations.

Prints one table per measurement, with the machine and baselines measured in the same run:
- the transport floor: a raw ZeroMQ DEALER/ROUTER ping-pong between two processes;
- the paper's preCICE IQN-ILS figure (3.38 coupling iterations per window for mu1).

Usage: python benchmarks/tube_run.py [--out runs/bench] [--quick]
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from coupler.run import run_scene  # noqa: E402
from cosim.scene import load_scene  # noqa: E402

SCENE = ROOT / "scenes" / "tube_fom.toml"
PAPER_PRECICE_ITERATIONS = 3.38

PING_SERVER = """
import sys, zmq
s = zmq.Context().socket(zmq.ROUTER); s.bind("tcp://127.0.0.1:*")
print(s.getsockopt_string(zmq.LAST_ENDPOINT), flush=True)
while True:
    m = s.recv_multipart(); s.send_multipart(m)
    if m[-1] == b"quit": break
"""


def machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()} {platform.release()}"


def zmq_ping_floor(n: int = 3000, payload: int = 808) -> float:
    """Median microseconds of a raw ZeroMQ round trip (808 bytes = 101 float64) between two processes."""
    import zmq
    server = subprocess.Popen([sys.executable, "-c", PING_SERVER], stdout=subprocess.PIPE, text=True)
    try:
        endpoint = server.stdout.readline().strip()
        socket = zmq.Context.instance().socket(zmq.DEALER)
        socket.connect(endpoint)
        message = [b"h", b"x" * payload]
        times = np.empty(n)
        for i in range(n):
            start = time.perf_counter()
            socket.send_multipart(message)
            socket.recv_multipart()
            times[i] = time.perf_counter() - start
        socket.send_multipart([b"h", b"quit"])
        socket.recv_multipart()
        socket.close()
        return float(np.median(times) * 1e6)
    finally:
        try:
            server.wait(timeout=5)
        except subprocess.TimeoutExpired:
            server.kill()


def run(out: Path, overrides: list[str]) -> dict:
    scene = load_scene(SCENE, overrides)
    summary = run_scene(scene, out, progress=False)
    with h5py.File(out / "results.h5") as f:
        stats = {"wall": summary.wall_seconds, "windows": summary.windows, "iterations": summary.iterations,
                 "max_iterations": int(f["windows/iterations"][:].max()),
                 "converged": bool(f["windows/converged"][:].all()),
                 "window_seconds": float(f["windows/wall_seconds"][:].sum())}
        for name in ("fluid", "solid"):
            compute = f[f"components/{name}/compute_seconds"][:]
            roundtrip = f[f"components/{name}/roundtrip_seconds"][:]
            stats[name] = {"compute_median": np.median(compute), "compute_mean": compute.mean(),
                           "roundtrip_median": np.median(roundtrip), "roundtrip_mean": roundtrip.mean(),
                           "overhead_median": np.median(roundtrip - compute), "calls": len(compute),
                           "roundtrip_total": roundtrip.sum()}
    return stats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "runs" / "bench"))
    parser.add_argument("--quick", action="store_true", help="only the scene's own settings")
    args = parser.parse_args()
    out = Path(args.out)
    print(f"machine: {machine()}")
    floor = zmq_ping_floor()
    main_run = run(out / "iqn-ils", [])
    us = 1e6
    print(f"\nTube FOM-FOM, mu1, 0-120 s ({main_run['windows']} windows), scene settings (IQN-ILS)")
    print(f"  wall time of the run (start-up to results closed): {main_run['wall']:8.2f} s   (target <= 15 s)")
    print(f"  all windows converged: {main_run['converged']}")
    print(f"  {'per call, microseconds':<28}{'fluid':>10}{'solid':>10}")
    for key, label in (("compute_median", "compute (median)"), ("compute_mean", "compute (mean)"),
                       ("roundtrip_median", "round trip (median)"), ("overhead_median", "round trip - compute")):
        print(f"  {label:<28}{main_run['fluid'][key] * us:>10.1f}{main_run['solid'][key] * us:>10.1f}")
    print(f"  {'raw ZeroMQ ping-pong (floor)':<28}{floor:>10.1f}{floor:>10.1f}   <- baseline, same machine, same run")
    iterations = main_run["iterations"]
    transport = (main_run["fluid"]["overhead_median"] + main_run["solid"]["overhead_median"]) * us
    coupler_own = (main_run["window_seconds"] - main_run["fluid"]["roundtrip_total"]
                   - main_run["solid"]["roundtrip_total"]) / iterations * us
    print(f"  coupler overhead per iteration: {transport:.0f} us on the wire (round trip - compute, both calls) "
          f"+ {coupler_own:.0f} us in the coupler (acceleration, measures, recording, results file)")
    if args.quick:
        return
    variants = [("IQN-ILS (scene: 8 reused windows, QR2 1e-3)", [], main_run),
                ("IQN-ILS + linear extrapolation", ["coupling.extrapolation_order=1"], None),
                ("IQN-ILS, no reused windows", ["coupling.acceleration.reused_time_windows=0"], None),
                ("Aitken, initial relaxation 0.01", ["coupling.acceleration.type=aitken"], None),
                ("Aitken, initial relaxation 0.5", ["coupling.acceleration.type=aitken",
                                                    "coupling.acceleration.initial_relaxation=0.5"], None)]
    print("\nCoupling iterations per window, mu1, 1200 windows")
    print(f"  {'acceleration':<46}{'mean':>7}{'max':>6}{'wall s':>8}{'vs preCICE 3.38':>17}")
    for i, (label, overrides, result) in enumerate(variants):
        result = result or run(out / f"variant{i}", overrides)
        mean = result["iterations"] / result["windows"]
        change = (mean / PAPER_PRECICE_ITERATIONS - 1) * 100
        print(f"  {label:<46}{mean:>7.3f}{result['max_iterations']:>6d}{result['wall']:>8.2f}{change:>+16.1f}%")


if __name__ == "__main__":
    main()
