"""Benchmark of one solid call of the tube: FOM, ROM (Python and FMU), and baselines.

Prints per-call times (median and interquartile range of repeated timings, microseconds) measured in this run:
- the solid FOM as implemented (exact root on each branch, vectorised over nodes);
- a paper-style solid FOM (one scalar root solve per node, scipy brentq): the kind of
  solver behind the paper's sigma ~ 96, as a baseline;
- the ROM's offline path (estimator.predict on one row: encoder, RBFInterpolator, decoder);
- the ROM's online path (OnlineRom, the arrays of the saved model) in both arithmetics and the
  ROM component's step (input checks included);
- the exported FMU through the fmu component (raw fmi2SetReal/DoStep/GetReal with
  preallocated ctypes arrays) and, as a baseline, through fmpy's setReal/doStep/getReal;
plus the training and cross-validation times, and the coupler round trips of ROM-FOM runs
with the rom and the fmu backends.

Usage: python -m benchmarks.rom_call [--results FOM_RESULTS.h5] [--small]   (--small: a 0-6 s training run)
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from benchmarks.common import Timing, fresh_directory, machine, per_call
from cosim.component import MESH_PREFIX
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.run import run_scene
from fmu_component.component import FmuComponent
from fmu_component.fmi2_instance import Fmi2Instance
from rom_component import model_file
from rom_component.fmu.export import export_fmu
from rom_component.recorded import read_interface, read_snapshots
from rom_component.static.component import RomSolid
from rom_component.static.estimator import SolidRom
from rom_component.static.load import load_rom
from rom_component.static.online import OnlineRom
from rom_component.static.selection import holdout_table
from rom_component.static.train import load_config
from solid_component.tube import TubeSolid

ROOT = Path(__file__).resolve().parent.parent

PAPER_ROM_CALL_US = 2800.0


def paper_style_solid(solid: TubeSolid):
    """One bracketed scalar root solve of p r = sigma((r - r0) / r0) per node."""
    from scipy.optimize import brentq
    r0 = solid.r0

    def section(p: np.ndarray) -> np.ndarray:
        radii = [brentq(lambda r, pi=pi: pi * r - solid.stress(np.array((r - r0) / r0)), 0.5 * r0, 1.5 * r0,
                        xtol=1e-14) for pi in p]
        return math.pi * np.square(radii)
    return section


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", help="a tube FOM-FOM results.h5 (default: run 0-18 s now)")
    parser.add_argument("--small", action="store_true", help="a 0-6 s training run, a small grid (for the tests)")
    args = parser.parse_args(argv)
    out = fresh_directory("rom_call")
    train_end, end, repeat = (6.0, 8.0, 5) if args.small else (18.0, 30.0, 15)
    print(f"machine: {machine()}")
    results = Path(args.results) if args.results else None
    if results is None:
        run_scene(load_scene(ROOT / "scenes/tube_fom.toml", [f"time.end={train_end:g}"]), out / "fom_train",
                  progress=False)
        results = out / "fom_train" / "results.h5"
    config = load_config(ROOT / "rom_configs/tube_rom.toml", [f"snapshots.t_max={train_end:g}"])
    F, U, _, _ = read_snapshots(results, config["snapshots"])
    started = time.perf_counter()
    estimator = SolidRom.from_settings(config["model"]).fit(F, U)
    fit_seconds = time.perf_counter() - started
    selection = config["selection"]
    force_modes, disp_modes = ([1, 3], [1, 5, 9]) if args.small else (selection["force_modes"], selection["disp_modes"])
    started = time.perf_counter()
    holdout_table(SolidRom.from_settings(config["model"]), F, U, force_modes, disp_modes, selection["test_fraction"], selection["seed"])
    cv_seconds = time.perf_counter() - started
    variables, meshes = read_interface(results, config["snapshots"])   # the meshes the solid declared
    model_path = model_file.save(out / "model.npz",
                                  {**estimator.online_arrays(), **{MESH_PREFIX + k: v for k, v in meshes.items()}},
                                  {"regressor": estimator.regressor_.type_name, "params": estimator.settings(),
                                   "variables": variables,
                                   "input_variable": "pressure", "output_variable": "section"})
    online = load_rom(model_path)
    fast = OnlineRom(*model_file.load_arrays(model_path), arithmetic="fast")
    fmu_path = export_fmu(model_path, out / "solid_rom.fmu")
    fmu = FmuComponent()
    fmu.instantiate({"path": str(fmu_path)})
    fmu.enter_initialization_mode(0.0, 1.0)
    fmu.exit_initialization_mode()
    assert isinstance(fmu.fmu, Fmi2Instance)      # an FMI 2.0 FMU: scalar value references
    slave, refs_in, refs_out = fmu.fmu.slave, fmu.fmu.value_references("pressure"), fmu.fmu.value_references("section")

    def fmpy_convenience() -> list:
        slave.setReal(refs_in, list(f))
        slave.doStep(0.0, 0.1)
        return slave.getReal(refs_out)
    component = RomSolid()
    component.instantiate({"model": str(model_path)})
    solid = TubeSolid()
    solid.instantiate({})
    paper_solid = paper_style_solid(solid)
    f = np.ascontiguousarray(F[len(F) // 2])
    np.testing.assert_allclose(paper_solid(f), math.pi * solid.radius(f) ** 2, rtol=1e-12)

    rows = [
        ("solid FOM, paper-style scalar root solve per node (baseline)", per_call(lambda: paper_solid(f), repeat, 5)),
        ("solid FOM, exact per-branch root, vectorised (ours)", per_call(lambda: math.pi * solid.radius(f) ** 2, repeat)),
        ("ROM offline path: estimator.predict(one row) (baseline)", per_call(lambda: estimator.predict(f[None]), repeat)),
        ("ROM online path, fast arithmetic (BLAS)", per_call(lambda: fast(f), repeat)),
        ("ROM online path, reproducible arithmetic (= the FMU, bit for bit)", per_call(lambda: online(f), repeat)),
        ("ROM component step (reproducible, input checks included)",
         per_call(lambda: component.step(0.0, 0.1, {"pressure": f}), repeat)),
        ("FMU ROM through the fmu component (raw fmi2 calls)",
         per_call(lambda: fmu.step(0.0, 0.1, {"pressure": f}), repeat)),
        ("FMU ROM through fmpy setReal/doStep/getReal (baseline)", per_call(fmpy_convenience, repeat)),
    ]
    np.testing.assert_array_equal(fmu.step(0.0, 0.1, {"pressure": f})["section"], online(f))
    m = len(online.arrays["centres"]) if online.regressor == "rbf" else len(online.qi)
    r_f, r_u, n = online.E.shape[0], online.A.shape[1], online.n_inputs
    flops = 2 * r_f * n + 3 * m * r_f + 30 * m + 2 * r_u * (m + r_f + 1) + 2 * n * r_u
    print(f"\nTube solid ROM: {len(F)} snapshots, r_f = {r_f}, r_u = {r_u}, {config['model']['regressor']['type']} "
          f"({m} centres), {config['model']['decoder']['type']} decoder; online path about {flops} flops")
    print(f"  training (fit): {fit_seconds * 1e3:.1f} ms; hold-out cross-validation over "
          f"{len(force_modes) * len(disp_modes)} (r_f, r_u) pairs: {cv_seconds:.2f} s")
    print(f"  {'per call, in-process, us: median [IQR]':<66}{'':>24}{'vs fast ROM':>13}")
    fast_us = rows[3][1].median
    for label, timing in rows:
        print(f"  {label:<66}{str(timing):>24}{timing.median / fast_us:>12.1f}x")
    print(f"  {'paper: ROM call of the double flap (for scale, its machine)':<66}{PAPER_ROM_CALL_US:>9.1f}")
    fmu.terminate()

    print(f"\nThrough the coupler (ROM-FOM mu1, 0-{end:g} s, the reduced backend from {train_end:g} s), "
          "us per call: median [IQR]")
    print(f"  {'backend':<12}{'compute':>24}{'round trip':>24}   run")
    coupled = {}
    for backend, key, value in (("rom", "model", model_path), ("fmu", "path", fmu_path)):
        run_dir = out / f"{backend}_mu1"
        scene = load_scene(ROOT / "scenes/tube_fom.toml", [f"time.end={end:g}", f"components.solid.backend={backend}",
                                                           f"components.solid.{backend}.{key}={value}",
                                                           f"components.solid.{backend}.switch_time={train_end:g}"])
        run_scene(scene, run_dir, progress=False)
        with RunResults(run_dir) as run_results:
            for name in ("solid", f"solid_{backend}", "fluid"):
                record = run_results.component(name)
                c, r = Timing.of(record.compute_seconds), Timing.of(record.roundtrip_seconds)
                coupled[(backend, name)] = (c, r)
                print(f"  {name:<12}{str(c):>24}{str(r):>24}   {backend} backend")
    return {"machine": machine(), "calls": dict(rows), "fit_seconds": fit_seconds, "cv_seconds": cv_seconds,
            "flops": flops, "coupled": coupled}


if __name__ == "__main__":
    main()
