"""Benchmark of one call of the step-map ROM of a structure with inertia (Mok's wall) against its full-order
structure's call, in one run.

Prints per-call times (median and interquartile range of repeated timings, microseconds) of the ROM's window call
in its three arithmetics (the C code in-process, the NumPy path in the C code's order, BLAS), warm and after other
data went through the caches, the exported FMU's doStep through the fmu component (with its roll-back to the
window's start), and the Kratos structure's compute per call recorded by the FOM-FOM run the model came from.

Usage: python -m benchmarks.step_map_call --model MODEL.npz --results FOM_RESULTS.h5
       python -m benchmarks.step_map_call --small      (a model fitted to a chain of masses; no Kratos)
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import Timing, cold_call, machine, per_call
from benchmarks.newmark_chain import newmark_calls
from cosim.component import Component
from cosim.results import RunResults
from fmu_component.component import FmuComponent
from rom_component.dynamic.component import StepMapRomSolid
from rom_component.fmu.export import export_fmu
from rom_component.model_file import load_arrays


def small_model(folder: Path) -> tuple[Path, None]:
    """A step map fitted to the Newmark chain (12 masses), as the tests fit one."""
    from rom_component import model_file
    from rom_component.dynamic.model import StepMapRom
    from rom_component.dynamic.train import model_contents
    data = newmark_calls()
    fitted = StepMapRom(force_modes=8, disp_modes=6, history=3, ridge=1e-10).fit(data, 120)
    arrays, metadata = model_contents(fitted, data, 120, np.arange(data.U.shape[1]), {}, 0.1, "force", "displacement")
    return model_file.save(folder / "model.npz", arrays, metadata), None


def component_call(component, force: np.ndarray):
    """A window's repeated call as the component server makes it (the same window start: the history stays)."""
    return lambda: component.served_step(10.0, 0.1, {"force": force})


def main(argv: list[str] | None = None) -> dict[str, Timing]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", help="a step-map model file (cosim train with dynamics.memory = true)")
    parser.add_argument("--results", help="the FOM-FOM results it was trained on (the structure's compute per call)")
    parser.add_argument("--small", action="store_true", help="a small model of a chain of masses")
    args = parser.parse_args(argv)
    if not args.small and not args.model:
        parser.error("give --model (and --results), or --small")
    print(f"machine: {machine()}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        model, results = small_model(folder) if args.small else (Path(args.model), args.results)
        arrays, metadata = load_arrays(model)
        n_in = arrays["E"].shape[1]
        components: dict[str, Component] = {}
        for arithmetic in ("compiled", "reproducible", "fast"):
            rom = StepMapRomSolid()
            rom.instantiate({"model": str(model), "arithmetic": arithmetic})
            components[arithmetic] = rom
        fmu = FmuComponent()
        fmu.instantiate({"path": str(export_fmu(model, folder / "model.fmu"))})
        fmu.enter_initialization_mode(0.0, 100.0)
        fmu.exit_initialization_mode()
        components["fmu"] = fmu
        rng = np.random.default_rng(0)
        force = rng.standard_normal(rom.input_shape)
        repeat = 7 if args.small else 25
        timings: dict[str, Timing] = {}
        for name, component in components.items():
            call = component_call(component, force)
            call()
            timings[f"{name} warm"] = per_call(call, repeat=repeat)
            timings[f"{name} cold"] = cold_call(call, repeat=repeat, flush_mb=8 if args.small else 64)
        outputs = {name: dict(component.served_step(10.0, 0.1, {"force": force}))
                   for name, component in components.items()}
        reference = outputs["compiled"]["displacement"]
        for name in ("reproducible", "fmu"):
            assert outputs[name]["displacement"].tobytes() == reference.tobytes(), f"{name} differs from compiled"
        for component in components.values():
            component.terminate()
    print(f"step-map ROM of {n_in} force values: r_f = {arrays['E'].shape[0]}, r_u = {arrays['A'].shape[1]}, "
          f"history of {metadata['history']} windows; per call, us: median [q1, q3]")
    for name, timing in timings.items():
        print(f"  {name:<20} {timing}")
    if results:
        with RunResults(results) as run:
            fom = run.component(metadata.get("component", "structure")).compute_seconds
        timings["fom"] = Timing.of(fom)
        compiled = timings["compiled cold"]
        print(f"  {'structure FOM':<20} {timings['fom']}  (Kratos, the run's {len(fom)} calls)")
        print(f"  sigma, FOM median over the compiled ROM's cold median: {timings['fom'].median / compiled.median:.0f}")
    return timings


if __name__ == "__main__":
    main()
