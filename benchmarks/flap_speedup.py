"""Benchmark of the double flap's total speed-up: FOM-FOM and ROM-FOM, each alone or side by side.

The campaign's walls come from runs that shared the cores with other runs, so their ratio says little. This
runs ``scenes/double_flap.toml`` at one Reynolds number over [0, END] s twice on this machine: the FOM-FOM
reference (the baseline) and the same scene with the trained ROM in the solid's place from SWITCH s. By
default one after the other, each alone; the machine's speed drifts by a few per cent between two runs half
an hour apart, and that moves the ratio. With ``--side-by-side`` both run at the same time, each on a core
of its own (all its processes pinned there; a run's solvers take turns, so one core serves it), and see the
same machine; ``--swap-cores`` puts the reference on the second core instead.
It prints the load average before each run, walls, coupling iterations, the solid's sigma, and the report's
total speed-up against its bound (T_f + T_s) / (T_f + T_s,FOM part + T_s,ROM part / sigma), over the whole
run and over the served windows. The bound assumes the reference's coupling iterations; the last column
prices in the run's own (the fluid's compute scaled by ROM-FOM over FOM-FOM iterations), which separates
the cost of extra iterations from the coupler's and the machine's.

Usage:
  python -m benchmarks.flap_speedup --model runs/campaign/models/rom4.npz --reynolds 192.30769230769232 \\
      --switch-time 0.8 [--end 6.0] [--rom-first | --side-by-side [--swap-cores]] [--pin] [--set KEY=VALUE ...]
      [--readme [--block NAME]]          --set: scene overrides of the ROM-FOM run (e.g. the ROM's transient calls)
                                         --pin: one after the other, each solver on a core of its own
  python -m benchmarks.flap_speedup --small     8 windows, a ROM trained on the first 4 (for the tests)
  python -m benchmarks.flap_speedup --report runs/bench/flap_speedup-... [...]  the tables of earlier runs again
      (of several pairs also their geometric means, per model)
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from benchmarks.common import CORE_PER_SOLVER, fresh_directory, machine, rewrite_readme
from cosim.scene import load_scene
from coupler.run import run_scene
from rom_component.report.compare import Run, call_windows, compare
from rom_component.static.train import load_config, train

ROOT = Path(__file__).resolve().parent.parent

SCENE = ROOT / "scenes" / "double_flap.toml"
ROM_CONFIG = ROOT / "rom_configs" / "double_flap_rom.toml"
DT = 0.008
ROM_SETTINGS = ("arithmetic", "on_out_of_range", "transient_calls", "transient_margin", "keep_warm")   # shown in the table
SMALL = {"windows": 8, "train_windows": 4, "reynolds": 250.0}
SMALL_MODEL = ["selection.choose='fixed'", "selection.table=false", "model.encoder.modes=4", "model.decoder.modes=3",
               "model.regressor.quadratic_modes=0"]


def run_once(out: Path, reynolds: float, end: float, rom: tuple[str, float] | None = None,
             rom_settings: Sequence[str] = (), common: Sequence[str] = ()) -> dict:
    """One run of the scene into ``out``: the FOM-FOM reference, or with ``rom = (model, switch_time)`` and the
    scene overrides ``rom_settings``; ``common``: overrides of either run."""
    overrides = [f"flow.reynolds={reynolds!r}", f"time.end={end!r}", *common]
    if rom:
        overrides += ["components.solid.backend=rom", f"components.solid.rom.model={rom[0]}",
                      f"components.solid.rom.switch_time={rom[1]!r}", *rom_settings]
    load = os.getloadavg()[0]
    started = time.perf_counter()
    run_scene(load_scene(SCENE, overrides), out, progress=False)
    return {"load_average_before": load, "seconds": time.perf_counter() - started}


def side_by_side(out: Path, reynolds: float, end: float, rom: tuple[str, float], swap: bool,
                 rom_settings: Sequence[str] = ()) -> dict:
    """The reference and the ROM-FOM run at the same time, each in a process of this script pinned to a core of
    its own (0 and 1, or swapped); the first to fail stops the other."""
    if len(os.sched_getaffinity(0)) < 2:
        raise SystemExit("--side-by-side needs two cores")
    cores = {"reference": 1, "rom": 0} if swap else {"reference": 0, "rom": 1}
    common = [sys.executable, "-m", "benchmarks.flap_speedup", "--reynolds", repr(reynolds), "--end", repr(end),
              "--model", str(Path(rom[0]).resolve()), "--switch-time", repr(rom[1]), "--out", str(Path(out).resolve()),
              *(f"--set={s}" for s in rom_settings)]
    children = {kind: subprocess.Popen([*common, "--one", kind, "--core", str(core)], cwd=ROOT)
                for kind, core in cores.items()}
    try:
        while True:
            codes = {kind: child.poll() for kind, child in children.items()}
            failed = [kind for kind, code in codes.items() if code not in (None, 0)]
            if failed:
                raise SystemExit(f"the {failed[0]} run failed (exit code {codes[failed[0]]}); see {out / failed[0]}")
            if all(code == 0 for code in codes.values()):
                break
            time.sleep(1.0)
    finally:
        for child in children.values():
            if child.poll() is None:
                child.terminate()
                child.wait()
    return {kind: json.loads((out / f"{kind}.timing.json").read_text()) for kind in cores}


def run_one(out: Path, kind: str, core: int, reynolds: float, end: float, rom: tuple[str, float],
            rom_settings: Sequence[str] = ()) -> None:
    """One run of a side-by-side pair, pinned to ``core`` (with every process it starts); its timing to a file."""
    os.sched_setaffinity(0, {core})
    timing = {**run_once(out / kind, reynolds, end, rom if kind == "rom" else None, rom_settings), "core": core}
    (out / f"{kind}.timing.json").write_text(json.dumps(timing))


def small_model(reference: Path, out: Path) -> tuple[Path, float]:
    """A ROM trained on the reference's first windows (the short protocol in miniature)."""
    switch = SMALL["train_windows"] * DT
    config = load_config(ROM_CONFIG, [f"snapshots.t_max={switch!r}", *SMALL_MODEL])
    train(reference / "results.h5", out, config, echo=lambda *_: None)
    return out, switch


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", help="trained ROM (.npz) for the solid's place")
    parser.add_argument("--reynolds", type=float, help="Reynolds number of both runs")
    parser.add_argument("--switch-time", type=float, help="the ROM takes the solid's place from this time (s)")
    parser.add_argument("--end", type=float, default=6.0, help="end time of both runs (s)")
    placement = parser.add_mutually_exclusive_group()
    placement.add_argument("--rom-first", action="store_true", help="run the ROM-FOM run before the reference")
    placement.add_argument("--side-by-side", action="store_true",
                       help="run both at the same time, each pinned to a core of its own")
    parser.add_argument("--calls", type=Path, help="calls.json of benchmarks/flap_rom_call.py: the table adds sigma "
                                                   "against its solid call with the authors' sparse_qr")
    parser.add_argument("--pin", action="store_true",
                        help="one after the other, in both runs the fluid on core 0 and the solid (FOM or ROM) on core 1")
    parser.add_argument("--swap-cores", action="store_true", help="side by side: the reference on core 1, the ROM on 0")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a scene override of the ROM-FOM run, e.g. components.solid.rom.transient_calls=2 (repeatable)")
    parser.add_argument("--one", choices=("reference", "rom"), help=argparse.SUPPRESS)   # a side-by-side child
    parser.add_argument("--core", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    parser.add_argument("--small", action="store_true", help="8 windows and a ROM trained on the first 4 (tests)")
    parser.add_argument("--readme", action="store_true", help="rewrite the README's flap-speedup block")
    parser.add_argument("--block", default="flap-speedup", help="with --readme: the README block to rewrite")
    parser.add_argument("--report", nargs="+", metavar="DIR",
                        help="print (and with --readme write) the tables of earlier runs' directories; of several pairs "
                             "also their geometric means")
    args = parser.parse_args(argv)
    if args.pin and args.side_by_side:
        parser.error("--pin runs one after the other; it does not go with --side-by-side")
    if not (args.small or args.report) and (args.model is None or args.reynolds is None or args.switch_time is None):
        parser.error("give --model, --reynolds and --switch-time, or --small, or --report")
    if args.report:      # the machine's load then: the table's column "load before" (the machine line's is of now)
        missing = [d for d in args.report if not (Path(d) / "speedup.json").is_file()]
        if missing:
            parser.error(f"--report: {', '.join(missing)} holds no speedup.json (not a finished flap_speedup run)")
        results = [tabulate(Path(directory), machine().split(", load average")[0],
                            json.loads((Path(directory) / "speedup.json").read_text())["timings"], authors_call(args.calls))
                   for directory in args.report]
        lines = results[0]["lines"] + [line for result in results[1:] for line in ["", *result["lines"][1:]]]  # one machine line
        if len(results) > 1:
            lines += pairs_summary(results)
        return publish(lines, args.block if args.readme else None,
                       results[0] if len(results) == 1 else {"pairs": results})
    if args.one:
        run_one(Path(args.out), args.one, args.core, args.reynolds, args.end, (args.model, args.switch_time), args.set)
        return {}
    machine_line = machine()
    out = fresh_directory("flap_speedup")
    common = CORE_PER_SOLVER if args.pin else ()     # --pin: a core per solver, in both runs
    if args.small:
        reynolds, end = SMALL["reynolds"], SMALL["windows"] * DT
        trained_on = out / ("training" if args.side_by_side else "reference")
        timings = {"reference": run_once(trained_on, reynolds, end, common=common)}
        model, switch = small_model(trained_on, out / "model.npz")
        if args.side_by_side:
            timings = side_by_side(out, reynolds, end, (str(model), switch), args.swap_cores, args.set)
        else:
            timings["rom"] = run_once(out / "rom", reynolds, end, (str(model), switch), args.set, common)
    else:
        reynolds, end, model, switch = args.reynolds, args.end, Path(args.model).resolve(), args.switch_time
        if args.side_by_side:
            timings = side_by_side(out, reynolds, end, (str(model), switch), args.swap_cores, args.set)
        else:
            order = ["rom", "reference"] if args.rom_first else ["reference", "rom"]
            timings = {}
            for kind in order:
                timings[kind] = run_once(out / kind, reynolds, end, (str(model), switch) if kind == "rom" else None,
                                         args.set, common)
    result = tabulate(out, machine_line, timings, authors_call(args.calls))
    return publish(result["lines"], args.block if args.readme else None, result)


def publish(lines: list[str], block: str | None, result: dict) -> dict:
    """Print ``lines``; with ``block`` (a README block's name) put them there too."""
    print("\n".join(lines))
    if block:
        named = "" if block == "flap-speedup" else f" --block {block}"
        command = f"python -m benchmarks.flap_speedup --model ... --readme{named}, or --report DIR... --readme{named}"
        rewrite_readme(block, lines, command)
    return result


def pairs_summary(results: list[dict]) -> list[str]:
    """Geometric means over the pairs of each model and Reynolds number (side by side with the cores swapped, a core's own speed
    cancels out of the mean: it divides one pair's speed-up and multiplies the other's)."""
    def mean(values: list[float]) -> float:
        return math.exp(sum(math.log(v) for v in values) / len(values))

    lines = [""]
    for model, reynolds in dict.fromkeys((r["model"], r["reynolds"]) for r in results):
        pairs = [r for r in results if (r["model"], r["reynolds"]) == (model, reynolds)]
        speedup = [r["row"]["total_speedup"] for r in pairs]
        bound = [r["row"]["total_speedup_bound"] for r in pairs]
        ratio = [s / b for s, b in zip(speedup, bound)]
        own = [s / r["bound_at_run_iterations"] for s, r in zip(speedup, pairs)]
        shown = os.path.relpath(model, ROOT) if Path(model).is_relative_to(ROOT) else model
        lines.append(f"{shown} at Re = {reynolds:g}, {len(pairs)} pair{'s' if len(pairs) > 1 else ''} (geometric means): speed-up {mean(speedup):.3f}, bound {mean(bound):.3f}, "
                     f"ratio {mean(ratio):.1%} (pairs: {', '.join(f'{x:.1%}' for x in ratio)}); against the bound at the "
                     f"runs' own iterations {mean(own):.1%}")
    return lines


def authors_call(calls: Path | None) -> float | None:
    """Seconds of one solid FOM call with the authors' sparse_qr, from a flap_rom_call.py calls.json (or None)."""
    if calls is None:
        return None
    medians = json.loads(calls.read_text())["median_seconds"]
    found = [seconds for label, seconds in medians.items() if "sparse_qr" in label]
    if not found:
        raise SystemExit(f"--calls: {calls} holds no sparse_qr call")
    return float(found[0])


def tabulate(out: Path, machine_line: str, timings: dict, qr_seconds: float | None = None) -> dict:
    """The table of the two runs in ``out`` (``lines`` of the result); writes speedup.json. ``qr_seconds``: a
    solid FOM call with the authors' solver, for sigma against it."""
    lines = [f"machine: {machine_line}"]
    runs = {"reference": Run.read(out / "reference"), "rom": Run.read(out / "rom")}
    rom_table = runs["rom"].scene["components"][runs["rom"].participant]["rom"]
    reynolds, end = float(runs["rom"].scene["flow"]["reynolds"]), float(runs["rom"].scene["time"]["end"])
    switch, model = float(rom_table["switch_time"]), rom_table["model"]
    row = compare(runs["rom"], runs["reference"])
    solid = row["solid"]
    ratio = row["iterations"] / row["reference_iterations"]
    fluid, solid_total = row["reference_fluid_compute_s"], row["reference_solid_compute_s"]
    served = row["predicted_range"]
    # the bound with the run's own iterations: every fluid call costs what the reference's did on average
    served_solid, sigma = served["solid_compute_s"], solid["speedup_compute"]
    bound_iterations = (fluid + solid_total) / (fluid * ratio + solid_total - served_solid + served_solid / sigma)
    served_ratio = row["predicted_iterations_ratio"]
    served_bound_iterations = (served["fluid_compute_s"] + served["solid_compute_s"]) / (
        served["fluid_compute_s"] * served_ratio + served_solid / sigma)
    cores = {kind: t["core"] for kind, t in timings.items() if "core" in t}
    placed = {name: spec.get("cores") for name, spec in runs["reference"].scene["components"].items()}
    pinned = "; in both runs " + ", ".join(f"the {name} on core{'s' if len(c) > 1 else ''} {', '.join(map(str, c))}"
                                          for name, c in placed.items() if c) if any(placed.values()) else ""
    order = (f"side by side, reference on core {cores['reference']}, ROM-FOM on core {cores['rom']}" if cores
             else f"order: {' then '.join(timings)}{pinned}")
    lines += [f"double flap, Re = {reynolds:g}, [0, {end:g}] s, ROM from {switch:g} s ({row['predicted_windows']} of "
              f"{len(runs['rom'].time)} windows); model {model}; {order}",
              "ROM settings: " + ", ".join(f"{key} = {rom_table[key]}" for key in ROM_SETTINGS if key in rom_table),
              f"{'run':<12}{'load before':>12}{'wall s':>9}{'iterations':>11}{'fluid compute s':>16}"
              f"{'solid compute s':>16}   fluid ms per call: before the switch (the same work in both runs), after"]
    served_windows = runs["rom"].predicted()
    for kind, run in runs.items():
        solid_name = run.rom_backend or "solid"
        others = sum(c["compute_seconds"].sum() for n, c in run.components.items() if n not in ("solid", run.rom_backend))
        solids = sum(run.components[n]["compute_seconds"].sum() for n in {"solid", solid_name} if n in run.components)
        per_call = run.components["fluid"]["compute_seconds"] * 1e3
        after = served_windows[call_windows(run)]
        lines.append(f"{'FOM-FOM' if kind == 'reference' else 'ROM-FOM':<12}{timings[kind]['load_average_before']:>12.2f}"
                     f"{run.wall:>9.1f}{int(run.iterations.sum()):>11}{others:>16.1f}{solids:>16.1f}"
                     f"   {per_call[~after].mean():.1f}, {per_call[after].mean():.1f}")
    lines += [f"solid sigma (CPU time per call, FOM over ROM, medians): {solid['speedup_compute']:.0f} "
              f"(ROM {solid['rom_compute_median_s'] * 1e6:.0f} us median in the run, FOM {solid['fom_compute_median_s'] * 1e3:.1f} ms)"
              + ("" if qr_seconds is None else f"; against the authors' sparse_qr ({qr_seconds * 1e3:.1f} ms a call, "
                 f"flap_rom_call.py; the ROM's mean call, {solid['rom_cpu_per_call_s'] * 1e6:.0f} us): "
                 f"{qr_seconds / solid['rom_cpu_per_call_s']:.0f}"),
              f"{'':<22}{'speed-up':>10}{'bound':>8}{'ratio':>8}{'iterations':>12}{'bound at these iterations':>27}{'ratio':>8}",
              f"{'whole run':<22}{row['total_speedup']:>10.3f}{row['total_speedup_bound']:>8.3f}"
              f"{row['total_speedup'] / row['total_speedup_bound']:>8.1%}{ratio - 1:>+12.2%}{bound_iterations:>27.3f}"
              f"{row['total_speedup'] / bound_iterations:>8.1%}",
              f"{'served windows alone':<22}{served['speedup']:>10.3f}{served['bound']:>8.3f}"
              f"{served['speedup'] / served['bound']:>8.1%}{served_ratio - 1:>+12.2%}{served_bound_iterations:>27.3f}"
              f"{served['speedup'] / served_bound_iterations:>8.1%}",
              f"e(t) on the full field over the served windows: mean {row['displacement_error']['mean']:.2%}, "
              f"max {row['displacement_error']['max']:.2%}; {row['rom_fallback_windows']} windows fell back to the solid FOM"]
    warm = runs["rom"].components[str(runs["rom"].rom_backend)]["final"]
    if "keep_warm_seconds" in warm:      # the ROM's idle repeats share the ROM-FOM run's core: part of its wall
        seconds = float(warm["keep_warm_seconds"][0])
        lines.append(f"keep_warm repeats: {int(warm['keep_warm_calls'][0])} calls, {seconds:.1f} s of compute "
                     f"({seconds / runs['rom'].wall:.1%} of the ROM-FOM run's wall)")
    result = {"machine": machine_line, "timings": timings, "reynolds": reynolds, "end": end, "switch_time": switch,
              "model": model, "row": {k: v for k, v in row.items() if not k.startswith("_")},
              "bound_at_run_iterations": bound_iterations, "served_bound_at_run_iterations": served_bound_iterations,
              "out": str(out)}
    (out / "speedup.json").write_text(json.dumps(result, indent=1, default=float))
    return {**result, "lines": lines}


if __name__ == "__main__":
    main()
