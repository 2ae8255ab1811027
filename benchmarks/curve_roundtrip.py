"""Benchmark of CURVE's cost per call: a component served with and without CURVE, the same calls to each.

Two ``cosim serve`` processes of the tube's solid on loopback, one plain and one with ``--curve`` (keys from
``cosim keys``); the coupler's proxy calls each in turn, so that both share the machine's state. Rows: a ping
without data, the tube solid's coupling step (101 pressures in, 101 sections out), and a ping carrying 1 MB.
Prints medians with the interquartile range in brackets, in microseconds, plain TCP being the baseline.

Usage: python -m benchmarks.curve_roundtrip [--small] [--readme]   (--small: few repeats, for the tests; --readme:
rewrite the table in docs/remote.md)
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections.abc import Sequence

import numpy as np

from benchmarks.common import ROOT, Timing, fresh_directory, machine, rewrite_readme
from cosim.curve import make_keys
from cosim.proxy import ComponentProxy

ENTRY = "solid_component.tube:TubeSolid"


def serve(curve: str | None) -> tuple[subprocess.Popen, str]:
    """A served tube solid (with CURVE if ``curve``), and its endpoint."""
    options = ["--curve", curve] if curve else []
    process = subprocess.Popen([sys.executable, "-m", "cosim", "serve", ENTRY, "--bind", "tcp://127.0.0.1:*",
                                *options], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    assert process.stdout is not None
    return process, json.loads(process.stdout.readline())["endpoint"]


def timings(proxy: ComponentProxy, repeat: int) -> dict[str, np.ndarray]:
    """Seconds of ``repeat`` round trips of each kind of call."""
    pressure = np.linspace(0.0, 10.0, 101)
    megabyte = {"x": np.zeros(2**17)}
    calls = {"ping, no data": lambda: proxy.call("ping"),
             "tube solid step, 101 values each way": lambda: proxy.step(0.0, 0.01, {"pressure": pressure}),
             "ping carrying 1 MB": lambda: proxy.call("ping", arrays=megabyte)}
    out = {}
    for label, call in calls.items():
        call()                                   # warm: the connection and the component's first step
        seconds = []
        for _ in range(repeat):
            started = time.perf_counter()
            call()
            seconds.append(time.perf_counter() - started)
        out[label] = np.array(seconds)
    return out


def main(argv: Sequence[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="few repeats (for the tests)")
    parser.add_argument("--readme", action="store_true", help="rewrite the curve-roundtrip block of docs/remote.md")
    args = parser.parse_args(argv)
    out = fresh_directory("curve_roundtrip")
    keys = out / "keys"
    make_keys(keys)
    repeat = 30 if args.small else 2000
    host = machine()
    print(f"machine: {host}")
    results: dict[str, dict[str, Timing]] = {}
    servers = {name: serve(curve) for name, curve in (("plain TCP", None), ("CURVE", str(keys)))}
    proxies = {name: ComponentProxy(f"solid ({name})", endpoint, timeout=30.0, curve=str(keys) if name == "CURVE" else "")
               for name, (_, endpoint) in servers.items()}
    try:
        for proxy in proxies.values():
            proxy.instantiate({})
            proxy.enter_initialization_mode(0.0, 1.0)
            proxy.exit_initialization_mode()
        seconds: dict[str, dict[str, list[np.ndarray]]] = {name: {} for name in proxies}
        for _ in range(5):                       # interleaved rounds: both see the same machine state
            for name, proxy in proxies.items():
                for label, values in timings(proxy, repeat // 5).items():
                    seconds[name].setdefault(label, []).append(values)
        results = {name: {label: Timing.of(np.concatenate(parts)) for label, parts in by_label.items()}
                   for name, by_label in seconds.items()}
    finally:
        for proxy in proxies.values():
            try:
                proxy.shutdown()
            finally:
                proxy.close()
        for process, _ in servers.values():
            process.wait(timeout=10)
    lines = [f"Round trip per call over loopback, us: median [IQR] ({repeat} calls each, in 5 interleaved rounds)",
             f"  {'call':<40}{'plain TCP (baseline)':>26}{'CURVE':>26}{'CURVE - plain':>15}"]
    for label, plain in results["plain TCP"].items():
        curve = results["CURVE"][label]
        lines.append(f"  {label:<40}{str(plain):>26}{str(curve):>26}{curve.median - plain.median:>15.1f}")
    print("\n" + "\n".join(lines))
    if args.readme and not args.small:
        rewrite_readme("curve-roundtrip", [f"machine: {host}", *lines], "python -m benchmarks.curve_roundtrip --readme")
    return results


if __name__ == "__main__":
    main()
