"""Shared parts of the benchmarks: the machine, timing statistics, a fresh output directory."""

from __future__ import annotations

import os
import platform
import time
import timeit
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
CORE_PER_SOLVER = ("components.fluid.cores=[0]", "components.solid.cores=[1]")   # double flap: fluid 0, solid 1


def machine() -> str:
    """CPU model, cores, Python and OS of this machine, and its load when the benchmark starts (runs that
    share the cores slow every timing)."""
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg()[0]
    return (f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()} "
            f"{platform.release()}, load average {load:.1f} at start")


@dataclass
class Timing:
    """Median and interquartile range of repeated measurements, in microseconds."""

    median: float
    q1: float
    q3: float
    samples: int

    @classmethod
    def of(cls, seconds: np.ndarray) -> Timing:
        us = np.asarray(seconds, dtype=float) * 1e6
        q1, median, q3 = np.percentile(us, [25, 50, 75])
        return cls(float(median), float(q1), float(q3), len(us))

    def __str__(self) -> str:
        return f"{self.median:9.1f} [{self.q1:.1f}, {self.q3:.1f}]"


def per_call(function: Callable[[], object], repeat: int = 15, number: int | None = None) -> Timing:
    """Per-call time of ``function``: ``repeat`` timings of ``number`` calls each (autoranged to ~0.05 s)."""
    timer = timeit.Timer(function)
    if number is None:
        number = max(1, int(timer.autorange()[0] / 4))
    return Timing.of(np.array(timer.repeat(repeat=repeat, number=number)) / number)


def single_calls(function: Callable[[], object], before: Callable[[], object], repeat: int = 15) -> Timing:
    """``repeat`` timings of one call of ``function``, each after ``before`` (untimed)."""
    times = []
    for _ in range(repeat):
        before()
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return Timing.of(np.array(times))


def cold_call(function: Callable[[], object], repeat: int = 15, flush_mb: int = 64) -> Timing:
    """Time of one call of ``function`` after ``flush_mb`` MB of other data went through the caches (as a
    component's call does after the other solver's turn): ``repeat`` single-call timings."""
    other = np.ones(flush_mb * 2**20 // 8)

    def flush() -> None:
        other[...] += 1.0                  # evict the caller's data from every cache level

    return single_calls(function, flush, repeat)


def idle_call(function: Callable[[], object], repeat: int = 15, idle_seconds: float = 0.01) -> Timing:
    """Time of one call of ``function`` after ``idle_seconds`` of the caller spinning on the clock (busy, no
    data touched): what the machine itself does to the caches between two calls, without another process's
    data (in a coupled run the ROM waits 0.2-0.3 s for the fluid between calls)."""
    def spin() -> None:
        until = time.perf_counter() + idle_seconds
        while time.perf_counter() < until:
            pass

    return single_calls(function, spin, repeat)


def fresh_directory(kind: str) -> Path:
    """A new directory under runs/bench/ (or ``$COSIM_BENCH_DIR``: the tests' own) for this benchmark run (runs
    never overwrite each other)."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    base = Path(os.environ.get("COSIM_BENCH_DIR") or ROOT / "runs" / "bench")
    path = base / f"{kind}-{stamp}-{os.getpid()}"
    path.mkdir(parents=True)
    return path


def rewrite_readme(marker: str, lines: list[str], command: str) -> None:
    """Replace the block between ``<!-- marker:begin`` and ``<!-- marker:end -->`` with ``lines``, in the
    README or the docs page that holds it."""
    begin, end = f"<!-- {marker}:begin", f"<!-- {marker}:end -->"
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    holding = [p for p in pages if begin in (text := p.read_text()) and end in text]
    if not holding:
        raise SystemExit(f"neither README.md nor docs/ has a '{begin}' ... '{end}' block")
    page = holding[0]
    head, rest = page.read_text().split(begin, 1)
    _, tail = rest.split(end, 1)
    block = f"{begin} ({command} writes this part) -->\n```\n" + "\n".join(lines) + "\n```\n"
    page.write_text(head + block + end + tail)
