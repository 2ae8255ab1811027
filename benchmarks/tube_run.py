"""Benchmark of the tube FOM-FOM run: wall time, per-call compute, coupler overhead, accelerations.

Prints one table per measurement (medians with the interquartile range in brackets), with the
machine and the baselines measured in the same run:
- the transport floor: a raw ZeroMQ DEALER/ROUTER ping-pong between two processes;
- coupling iterations against the paper's preCICE IQN-ILS run, like for like: the paper's own
  inlet tables replayed (4054 iterations in 1200 windows for mu1, 3.21 per window for mu2).

Usage: python -m benchmarks.tube_run [--small]   (--small: 6 s of simulated time, for the tests)
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import Timing, fresh_directory, machine
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.run import run_scene

ROOT = Path(__file__).resolve().parent.parent

SCENE = ROOT / "scenes" / "tube_fom.toml"
PAPER_PRECICE = {"mu1": 4054 / 1200, "mu2": 3.21}   # coupling iterations per window, the paper's preCICE runs
TABLES = {"mu1": (ROOT / "scenes/inlet/tube-inlet-mu1.csv", []),
          "mu2": (ROOT / "scenes/inlet/tube-inlet-mu2.csv", ["inlet.f=0.9", "inlet.h=4"])}

PING_SERVER = """
import sys, zmq
s = zmq.Context().socket(zmq.ROUTER); s.bind("tcp://127.0.0.1:*")
print(s.getsockopt_string(zmq.LAST_ENDPOINT), flush=True)
while True:
    m = s.recv_multipart(); s.send_multipart(m)
    if m[-1] == b"quit": break
"""


@contextmanager
def _echo_server(script: str) -> Iterator[str]:
    """An echo server ``script`` in a process of its own: the address it prints; it is waited for (killed if it hangs)
    when the block ends."""
    server = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert server.stdout is not None       # a pipe
        yield server.stdout.readline().strip()
    finally:
        try:
            server.wait(timeout=5)
        except subprocess.TimeoutExpired:
            server.kill()


def zmq_ping_floor(n: int = 3000, payload: int = 808) -> Timing:
    """A raw ZeroMQ round trip (808 bytes = 101 float64) between two processes."""
    import zmq
    with _echo_server(PING_SERVER) as endpoint:
        socket: zmq.Socket = zmq.Context.instance().socket(zmq.DEALER)
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
        return Timing.of(times)


SOCKET_SERVER = """
import socket
server = socket.create_server(("127.0.0.1", 0)); print(server.getsockname()[1], flush=True)
peer, _ = server.accept(); peer.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
while True:
    m = peer.recv(65536)
    if not m or m.endswith(b"quit"): break
    peer.sendall(m)
"""


def socket_ping_floor(n: int = 3000, payload: int = 808) -> Timing:
    """A round trip of the same bytes over a plain TCP socket (no ZeroMQ: no I/O thread on either side), between
    two processes: the transport floor a peer-to-peer link of plain sockets has on this machine."""
    import socket
    with _echo_server(SOCKET_SERVER) as port, socket.create_connection(("127.0.0.1", int(port))) as peer:
        peer.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        message, times = b"x" * payload, np.empty(n)
        for i in range(n):
            start = time.perf_counter()
            peer.sendall(message)
            received = 0
            while received < payload:
                received += len(peer.recv(65536))
            times[i] = time.perf_counter() - start
        peer.sendall(b"quit")
        return Timing.of(times)


def run(out: Path, overrides: list[str]) -> dict:
    """Run the scene with ``overrides``; its iterations and per-call times."""
    summary = run_scene(load_scene(SCENE, overrides), out, progress=False)
    with RunResults(out) as results:
        windows = results.windows
        stats: dict[str, Any] = {"wall": summary.wall_seconds, "windows": summary.windows, "iterations": summary.iterations,
                 "max_iterations": int(windows.iterations.max()), "converged": bool(windows.converged.all()),
                 "window_seconds": float(windows.wall_seconds.sum())}
        for name in ("fluid", "solid"):
            record = results.component(name)
            compute, roundtrip = record.compute_seconds, record.roundtrip_seconds
            stats[name] = {"compute": Timing.of(compute), "roundtrip": Timing.of(roundtrip),
                           "overhead": Timing.of(roundtrip - compute), "roundtrip_total": roundtrip.sum()}
    return stats


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="6 s of simulated time, fewer variants (for the tests)")
    args = parser.parse_args(argv)
    out = fresh_directory("tube_run")
    end = 6.0 if args.small else 120.0
    span = [f"time.end={end:g}"]
    print(f"machine: {machine()}")
    floor = zmq_ping_floor(300 if args.small else 3000)
    main_run = run(out / "iqn-ils", span)
    print(f"\nTube FOM-FOM, mu1, 0-{end:g} s ({main_run['windows']} windows), scene settings (IQN-ILS)")
    print(f"  wall time of the run (start-up to results closed): {main_run['wall']:8.2f} s")
    print(f"  all windows converged: {main_run['converged']}")
    print(f"  {'per call, us: median [IQR]':<30}{'fluid':>24}{'solid':>24}")
    for key, label in (("compute", "compute"), ("roundtrip", "round trip"), ("overhead", "round trip - compute")):
        print(f"  {label:<30}{str(main_run['fluid'][key]):>24}{str(main_run['solid'][key]):>24}")
    print(f"  {'raw ZeroMQ ping-pong (floor)':<30}{str(floor):>24}   <- baseline, same machine, same run")
    iterations = main_run["iterations"]
    transport = main_run["fluid"]["overhead"].median + main_run["solid"]["overhead"].median
    coupler_own = (main_run["window_seconds"] - main_run["fluid"]["roundtrip_total"]
                   - main_run["solid"]["roundtrip_total"]) / iterations * 1e6
    print(f"  coupler overhead per iteration: {transport:.0f} us on the wire (round trip - compute, both calls) "
          f"+ {coupler_own:.0f} us in the coupler (acceleration, measures, recording, results file)")
    results = {"machine": machine(), "end": end, "main": main_run, "floor": floor, "coupler_us": coupler_own,
               "variants": {}, "tables": {}}
    variants = [("IQN-ILS (scene: 8 reused windows, QR2 1e-3)", [], main_run),
                ("IQN-ILS + linear extrapolation", ["coupling.extrapolation_order=1"], None),
                ("IQN-ILS, reused_time_windows = 0", ["coupling.acceleration.reused_time_windows=0"], None),
                ("Aitken, initial relaxation 0.01",
                 ['coupling.acceleration={type="aitken", data=["section"], initial_relaxation=0.01}'], None)]
    if args.small:
        variants = variants[:1] + variants[2:3]
    print(f"\nCoupling iterations per window, mu1 (our Duffing inlet), {main_run['windows']} windows")
    print(f"  {'acceleration':<46}{'mean':>7}{'max':>6}{'wall s':>8}")
    for i, (label, overrides, result) in enumerate(variants):
        result = result or run(out / f"variant{i}", span + overrides)
        results["variants"][label] = result
        print(f"  {label:<46}{result['iterations'] / result['windows']:>7.3f}{result['max_iterations']:>6d}"
              f"{result['wall']:>8.2f}")
    print("\nLike for like with the paper's preCICE run: the paper's inlet tables replayed, IQN-ILS, scene settings")
    print(f"  {'case':<10}{'ours':>10}{'preCICE':>10}{'difference':>12}")
    for case, (table, overrides) in TABLES.items():
        if args.small and case == "mu2":
            continue
        result = run(out / f"table_{case}", span + overrides + [f"inlet.table={table}"])
        results["tables"][case] = result
        mean = result["iterations"] / result["windows"]
        print(f"  {case:<10}{mean:>10.3f}{PAPER_PRECICE[case]:>10.3f}{(mean / PAPER_PRECICE[case] - 1) * 100:>+11.1f}%"
              + ("   (over 0-6 s only: not comparable)" if args.small else f"   ({result['iterations']} iterations)"))
    return results


if __name__ == "__main__":
    main()
