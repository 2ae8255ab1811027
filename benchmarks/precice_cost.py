"""What the preCICE participant path costs against a native component: the tube's FOM-FOM run as the native scene
(two components behind `cosim serve`) and as the same solvers in two preCICE participants (examples/precice_tube,
the v3 API), interleaved, each a `cosim run` in its own process, held against a raw ZeroMQ ping-pong taken right
before it.

Per coupling iteration (benchmarks.coupler_cost's split): the components' compute (a participant reports the time
between the coupler's answer and its next window-ending advance, its own work and its calls of the API), the wire
(round trip less compute), the coupler's own time, and the run's wall time; the two runs give the same bits (the
tests check it, the native IQN-ILS set as a preCICE configuration's), so they take the same iterations.

Usage: python -m benchmarks.precice_cost [--small] [--repeat N]
"""

from __future__ import annotations

import argparse
from typing import Any

from benchmarks.common import ROOT, fresh_directory, machine
from benchmarks.coupler_cost import cosim_run, split, summary
from benchmarks.tube_run import zmq_ping_floor

# the native scene's IQN-ILS as the example's preCICE configuration has it (no window reused, no drop of reused
# columns, emptied windows not counted)
AS_PRECICE = ["coupling.acceleration.reused_time_windows=0", "coupling.acceleration.stale_step_ratio=0",
              "coupling.acceleration.count_emptied_windows=false"]
CASES: dict[str, tuple[Any, list[str]]] = {"native components": (ROOT / "scenes" / "tube_fom.toml", AS_PRECICE),
                                           "preCICE participants (v3)": (ROOT / "examples" / "precice_tube" /
                                                                         "case.toml", [])}
COLUMNS = [("iterations", "iters", "{:.0f}"), ("ping_us", "ping us", "{:.0f}"), ("compute_us", "compute us", "{:.0f}"),
           ("wire_us", "wire us", "{:.0f}"), ("coupler_us", "coupler us", "{:.0f}"),
           ("process_wall", "wall s", "{:.2f}"), ("over_floor", "wall/floor", "{:.2f}")]


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="2 s of the tube (for the tests)")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each case, interleaved (default 3)")
    args = parser.parse_args(argv)
    end = 2.0 if args.small else 120.0
    repeat = 1 if args.small else args.repeat
    out = fresh_directory("precice_cost")
    print(f"machine: {machine()}")
    rows: dict[str, list[dict[str, Any]]] = {case: [] for case in CASES}
    for run in range(repeat):
        for case, (scene, overrides) in CASES.items():
            settings = [f"time.end={end:g}", *overrides]
            if "participants" in case:
                settings.append(f"participants.Fluid.command=python3 FluidSolver.py ../precice-config.xml {end:g}")
            ping = zmq_ping_floor(200 if args.small else 1000).median * 1e-6
            directory = out / f"{case.split()[0]}-{run}"
            launched, exited = cosim_run(scene, directory, settings)
            row = split(directory, launched, exited, ping)
            row["ping_us"] = ping * 1e6
            rows[case].append(row)
    table = {case: summary(found) for case, found in rows.items()}
    print(f"\ntube FOM-FOM, 0-{end:g} s, medians of {repeat} runs per case [range]")
    print(f"{'per coupling iteration':<28}" + "".join(f"{label:>22}" for _, label, _ in COLUMNS))
    for case, row in table.items():
        cells = []
        for key, _, form in COLUMNS:
            low, high = row[f"{key}_range"]
            cells.append(f"{form.format(row[key])} [{form.format(low)}-{form.format(high)}]" if repeat > 1
                         else form.format(row[key]))
        print(f"{case:<28}" + "".join(f"{cell:>22}" for cell in cells))
    native, participants = table["native components"], table["preCICE participants (v3)"]
    extra = (participants["process_wall"] - native["process_wall"]) / native["iterations"] * 1e6
    print(f"\nthe participant path over the native one: wall {participants['process_wall'] / native['process_wall']:.2f}"
          f", {extra:+.0f} us per iteration; coupler {participants['coupler_us'] - native['coupler_us']:+.0f} us, "
          f"wire {participants['wire_us'] - native['wire_us']:+.0f} us per iteration")
    return {"machine": machine(), "table": table, "extra_us_per_iteration": extra}


if __name__ == "__main__":
    main()
