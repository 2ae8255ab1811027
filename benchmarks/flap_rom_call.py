"""Benchmark of one solid call of the double flap: the Kratos solid FOM against the ROM (Python and FMU).

Prints per-call times (median and interquartile range of repeated timings, microseconds) measured in this run:
- the Kratos solid FOM (hyperelastic, Newton) with the authors' linear solver (sparse_qr) and with sparse_lu,
  one window re-solved per call from a recorded interface force;
- the ROM's offline path (estimator.predict on one row) as a baseline;
- the ROM's online interface path (530 forces in, 530 interface displacements out: encoder, sparse
  quadratic polynomial, quadratic manifold restricted to the interface) in fast and reproducible arithmetic,
  and compiled (the FMU's C code in-process, bit-identical to reproducible; and, as a baseline, built without
  its vector sums), and the ROM component's step, and its served_step (one C call on bound buffers);
- the exported FMU through the fmu component (raw fmi2 calls) and, as a baseline, through fmpy;
- unless --small, the ROM component's step inside a coupled run (Kratos fluid, the scene's settings, the
  first COUPLED windows from t = 0) from the run's own timings: its caches are cold after each fluid solve;
  with keep_warm, and with a core per solver (with and without keep_warm);
and the solid speed-up sigma = FOM / ROM for each. The ROM has r_f = 45, r_u = 9, as in the paper.

Usage:
  python -m benchmarks.flap_rom_call --results A.h5 [B.h5 ...] [--t-max 3.0] [--coupled 25]
                                                  train on recorded double-flap runs
  python -m benchmarks.flap_rom_call --small      synthetic snapshots of the flap's sizes, 3 FOM calls (tests)
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.base import clone

from benchmarks.common import (
    CORE_PER_SOLVER,
    Timing,
    cold_call,
    fresh_directory,
    idle_call,
    machine,
    per_call,
    rewrite_readme,
)
from cosim.component import MESH_PREFIX
from fmu_component.component import FmuComponent
from fmu_component.fmi2_instance import Fmi2Instance
from rom_component import model_file
from rom_component.fmu.export import export_fmu
from rom_component.recorded import interface_index, read_interface, read_training_set
from rom_component.static.compiled import CompiledRom
from rom_component.static.component import RomSolid
from rom_component.static.estimator import SolidRom, resolve_parts
from rom_component.static.load import load_rom
from rom_component.static.online import OnlineRom
from rom_component.static.train import load_config

ROOT = Path(__file__).resolve().parent.parent

PAPER = {"rom_call_us": 2800.0, "fom_call_us": 724_000.0}
MESHES = ROOT / "scenes" / "double_flap"
# the paper's ROM 1 and 4: 45 force modes, the sparse polynomial, the quadratic manifold of 9 modes
PARAMS: dict[str, Any] = {"encoder": {"type": "pod", "modes": 45, "scaling": "global"},
                          "regressor": {"type": "poly"}, "decoder": {"type": "quadratic", "modes": 9}}


KEEP_WARM = 0.001      # seconds between the idle repeats of the ROM's last call (components.solid.rom.keep_warm)


def synthetic_snapshots(m: int = 400, seed: int = 0):
    """Snapshots of the flap's sizes (530 forces, 3610 field values, 530 of them on the interface) from a
    smooth nonlinear map of a few latent loads: enough to fit a ROM of the paper's shape."""
    rng = np.random.default_rng(seed)
    latent = rng.standard_normal((m, 6))
    F = latent @ rng.standard_normal((6, 530)) + 0.05 * (latent ** 2) @ rng.standard_normal((6, 530))
    F += 1e-2 * rng.standard_normal(F.shape)      # full rank: every one of the 45 modes carries data
    U = latent @ rng.standard_normal((6, 3610)) * 1e-3 + (latent[:, :3] ** 2) @ rng.standard_normal((3, 3610)) * 1e-4
    interface = np.sort(rng.choice(1805, 265, replace=False))
    K = (interface[:, None] * 2 + np.arange(2)).ravel()
    nodes = rng.uniform(0.0, 0.3, (265, 2))
    variables = [{"name": name, "mesh": "interface", "components": 2} for name in ("force", "displacement")]
    return F, U, K, {"interface": nodes}, variables


def recorded_snapshots(results: list[str], t_max: float):
    config = load_config(ROOT / "rom_configs" / "double_flap_rom.toml", [f"snapshots.t_max={t_max}"])
    F, U, _, _ = read_training_set(results, config["snapshots"])
    variables, meshes = read_interface(results[0], config["snapshots"])
    return F, U, interface_index(results[0], config["snapshots"]), meshes, variables


def kratos_call_times(force: np.ndarray, calls: int) -> dict[str, np.ndarray]:
    """Compute seconds of ``calls`` solves of one window by the Kratos solid, for each linear solver."""
    from kratos_solvers.solid import KratosSolid
    times = {}
    for solver in ("sparse_qr", "sparse_lu"):
        solid = KratosSolid()
        try:
            solid.instantiate({"time": {"start": 0.0, "end": 1.0, "dt": 0.008}, "mesh": str(MESHES / "solid.mdpa"),
                               "linear_solver": solver})
            solid.step(0.0, 0.008, {"force": force})        # the first solve assembles and factorises
            seconds = []
            for _ in range(calls):
                started = time.perf_counter()
                solid.step(0.0, 0.008, {"force": force})
                seconds.append(time.perf_counter() - started)
            times[solver] = np.array(seconds)
        finally:
            solid.close()
    return times


def coupled_step_times(model: Path, out: Path, windows: int, keep_warm: float = 0.0,
                       overrides: Sequence[str] = ()) -> tuple[np.ndarray, float]:
    """Compute seconds of the ROM component's calls in a coupled double-flap run of ``windows`` windows (scene
    ``overrides`` added), and the share of one core its keep-warm repeats took over the run's wall."""
    from cosim.results import RunResults
    from cosim.scene import load_scene
    from coupler.run import run_scene
    scene = load_scene(ROOT / "scenes" / "double_flap.toml",
                       ["components.solid.backend=rom", f"components.solid.rom.model={model}",
                        f"components.solid.rom.keep_warm={keep_warm!r}", f"time.end={windows * 0.008!r}",
                        *overrides])
    run_scene(scene, out, progress=False)
    with RunResults(out / "results.h5") as run:
        roms = [run.component(name) for name in run.component_names()
                if run.component(name).attributes.get("kind") == "rom"]
        warm = float(roms[0].final.get("keep_warm_seconds", [0.0])[0])
        return np.asarray(roms[0].compute_seconds), warm / float(run.attributes["wall_seconds"])


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", nargs="+", help="double-flap FOM-FOM results.h5 files to train on")
    parser.add_argument("--t-max", type=float, default=3.0, help="train on windows ending at or before (s)")
    parser.add_argument("--small", action="store_true", help="synthetic snapshots, few repeats (for the tests)")
    parser.add_argument("--coupled", type=int, default=25, help="windows of the coupled run (0: none)")
    parser.add_argument("--readme", action="store_true", help="rewrite the README's flap-rom-call block")
    args = parser.parse_args(argv)
    if not args.small and not args.results:
        parser.error("give --results (recorded double-flap runs) or --small")
    out = fresh_directory("flap_rom_call")
    repeat, fom_calls = (5, 3) if args.small else (15, 15)
    F, U, K, meshes, variables = synthetic_snapshots() if args.small else recorded_snapshots(args.results, args.t_max)
    started = time.perf_counter()
    estimator = SolidRom.from_settings(resolve_parts(PARAMS)).fit(F, U)
    fit_seconds = time.perf_counter() - started
    model_path = model_file.save(out / "model.npz",
                                  {**estimator.online_arrays(K), **{MESH_PREFIX + k: v for k, v in meshes.items()}},
                                  {"regressor": "poly", "params": estimator.settings(), "variables": variables,
                                   "input_variable": "force", "output_variable": "displacement"})
    online = load_rom(model_path)
    fast = OnlineRom(*model_file.load_arrays(model_path), arithmetic="fast")
    fmu_path = export_fmu(model_path, out / "solid_rom.fmu", 2)
    fmu = FmuComponent()
    fmu.instantiate({"path": str(fmu_path)})
    fmu.enter_initialization_mode(0.0, 1.0)
    fmu.exit_initialization_mode()
    assert isinstance(fmu.fmu, Fmi2Instance)      # an FMI 2.0 FMU: scalar value references
    slave = fmu.fmu.slave
    refs_in, refs_out = fmu.fmu.value_references("force"), fmu.fmu.value_references("displacement")
    compiled = load_rom(model_path, "compiled")
    scalar = CompiledRom(*model_file.load_arrays(model_path), defines=("SOLID_ROM_SCALAR",))
    component = RomSolid()
    component.instantiate({"model": str(model_path)})
    compiled_component = RomSolid()
    compiled_component.instantiate({"model": str(model_path), "arithmetic": "compiled"})
    f = np.ascontiguousarray(F[len(F) // 2])
    force = f.reshape(265, 2)

    def compiled_step() -> dict:
        return compiled_component.step(0.0, 0.008, {"force": force})

    def served_step() -> dict:
        return compiled_component.served_step(0.0, 0.008, {"force": force})

    def fmpy_convenience() -> list:
        slave.setReal(refs_in, list(f))
        slave.doStep(0.0, 0.008)
        return slave.getReal(refs_out)

    np.testing.assert_array_equal(np.ravel(fmu.step(0.0, 0.008, {"force": force})["displacement"]), online(f))
    assert compiled(f).tobytes() == online(f).tobytes() == scalar(f).tobytes()
    np.testing.assert_allclose(online(f), estimator.predict(f[None])[0, K], rtol=1e-10, atol=1e-14)
    rows = [
        ("ROM offline path: estimator.predict(one row), full field (baseline)",
         per_call(lambda: estimator.predict(f[None]), repeat)),
        ("ROM online interface path, fast arithmetic (BLAS)", per_call(lambda: fast(f), repeat)),
        ("ROM online interface path, reproducible arithmetic (= the FMU)", per_call(lambda: online(f), repeat)),
        ("ROM online interface path, compiled (the FMU's C code in-process)", per_call(lambda: compiled(f), repeat)),
        ("  the same built without vector sums (-DSOLID_ROM_SCALAR, baseline)", per_call(lambda: scalar(f), repeat)),
        ("ROM component step (reproducible, input checks, trust)",
         per_call(lambda: component.step(0.0, 0.008, {"force": force}), repeat)),
        ("ROM component step (compiled, input checks, trust)",
         per_call(compiled_step, repeat)),
        ("  the same with cold caches (64 MB of other data touched before each call)",
         cold_call(compiled_step, repeat)),
        ("  the same after 10 ms of the caller spinning (no other data touched)",
         idle_call(compiled_step, repeat)),
        ("ROM component served_step (compiled, one C call, as cosim serve calls it)",
         per_call(served_step, repeat)),
        ("  the same with cold caches (64 MB of other data touched before each call)",
         cold_call(served_step, repeat)),
        ("FMU ROM: fmi2DoStep alone (the ROM inside the FMU)", per_call(lambda: fmu.do_step(0.0, 0.008), repeat)),
        ("  the same after 10 ms of the caller spinning (the C code's own cold cost)",
         idle_call(lambda: fmu.do_step(0.0, 0.008), repeat)),
        ("FMU ROM through the fmu component (raw fmi2 set, doStep, get)",
         per_call(lambda: fmu.step(0.0, 0.008, {"force": force}), repeat)),
        ("FMU ROM through fmpy setReal/doStep/getReal (baseline)", per_call(fmpy_convenience, repeat)),
    ]
    fmu.terminate()
    # the double flap's configuration (rom_configs/double_flap_rom.toml): products of the q leading reduced forces only
    q = int(load_config(ROOT / "rom_configs" / "double_flap_rom.toml")["model"]["regressor"]["quadratic_modes"])
    leading = clone(estimator).set_params(regressor__quadratic_modes=q).fit(F, U)
    leading_arrays = {**leading.online_arrays(K), **{MESH_PREFIX + k: v for k, v in meshes.items()}}
    leading_fast = OnlineRom(leading_arrays, {"regressor": "poly"}, arithmetic="fast")
    leading_online = OnlineRom(leading_arrays, {"regressor": "poly"})
    rows += [(f"  the same, products of the {q} leading modes only: fast arithmetic",
              per_call(lambda: leading_fast(f), repeat)),
             (f"  the same, products of the {q} leading modes only: reproducible",
              per_call(lambda: leading_online(f), repeat))]
    if args.coupled and not args.small:
        leading_path = model_file.save(out / "model_leading.npz", leading_arrays,
                                        {"regressor": "poly", "params": leading.settings(),
                                         "variables": variables, "input_variable": "force",
                                         "output_variable": "displacement"})
        seconds, _ = coupled_step_times(leading_path, out / "coupled", args.coupled)
        rows.append((f"ROM component step (compiled, {q} leading products) in a coupled run, {len(seconds)} calls",
                     Timing.of(seconds)))
        seconds, share = coupled_step_times(leading_path, out / "coupled_keep_warm", args.coupled, KEEP_WARM)
        rows.append((f"  the same, the last call repeated every {KEEP_WARM * 1e3:g} ms between calls "
                     f"({share:.1%} of a core)", Timing.of(seconds)))
        if {0, 1} <= os.sched_getaffinity(0):      # a core per solver: the fluid on 0, the ROM on 1
            seconds, _ = coupled_step_times(leading_path, out / "coupled_pinned", args.coupled, 0.0,
                                            CORE_PER_SOLVER)
            rows.append(("  the same, a core per solver (fluid on core 0, ROM on core 1)", Timing.of(seconds)))
            seconds, share = coupled_step_times(leading_path, out / "coupled_pinned_keep_warm", args.coupled,
                                                KEEP_WARM, CORE_PER_SOLVER)
            rows.append((f"  the same, a core per solver, repeated every {KEEP_WARM * 1e3:g} ms ({share:.1%} of "
                         f"the ROM's core)", Timing.of(seconds)))
    kratos = kratos_call_times(force, fom_calls)
    fom_rows = [(f"solid FOM, Kratos, {solver}{' (the authors)' if solver == 'sparse_qr' else ''}",
                 Timing.of(seconds)) for solver, seconds in kratos.items()]
    n, r_f, r_u = online.n_inputs, online.E.shape[0], online.A.shape[1]
    terms = int((online.H != 0).sum())
    flops = 2 * r_f * n + len(online.qi) + 2 * terms + 2 * n * r_u + 2 * n * r_u * (r_u + 1) // 2
    qr, lu = kratos["sparse_qr"], kratos["sparse_lu"]
    lines = [f"machine: {machine()}",
             f"double-flap solid ROM: {len(F)} {'synthetic' if args.small else 'recorded'} snapshots, r_f = {r_f}, "
             f"r_u = {r_u}, sparse quadratic polynomial ({terms} of {online.H.size} coefficients non-zero), quadratic "
             f"manifold; {n} forces in, {online.n_outputs} interface displacements out; about {flops} flops per call",
             f"training (fit): {fit_seconds:.2f} s",
             f"{'per call, us: median [IQR] of ' + str(repeat) + ' timings':<70}{'':>26}{'sigma vs sparse_qr':>20}"
             f"{'vs sparse_lu':>14}"]
    for label, timing in fom_rows + rows:
        lines.append(f"{label:<70}{str(timing):>26}{np.median(qr) * 1e6 / timing.median:>20.0f}"
                     f"{np.median(lu) * 1e6 / timing.median:>14.0f}")
    lines.append(f"{'paper: ROM call 2.8 ms, solid FOM 0.724 s (its machine)':<70}"
                 f"{PAPER['rom_call_us']:>26.1f}{PAPER['fom_call_us'] / PAPER['rom_call_us']:>20.0f}")
    print("\n".join(lines))
    medians = {label: timing.median * 1e-6 for label, timing in rows + fom_rows}
    (out / "calls.json").write_text(json.dumps({"median_seconds": medians, "machine": machine()}, indent=1))
    if args.readme:
        rewrite_readme("flap-rom-call", lines, "python -m benchmarks.flap_rom_call --results ... --readme")
    return {"machine": machine(), "calls": dict(rows + fom_rows), "fit_seconds": fit_seconds, "flops": flops,
            "out": str(out)}


if __name__ == "__main__":
    main()
