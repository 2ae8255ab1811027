"""The peer: the double flap through Kratos CoSimulationApplication's own coupler.

Same meshes, same fluid and solid settings (the project parameters come from the same
builders as our components), the authors' coupling: Gauss-Seidel strong, structure then
fluid, IQN-ILS on the fluid's load (alpha 0.5, time-step horizon 3, iteration horizon 50),
relative_norm_previous_residual 5e-3 on load and displacement, nearest-neighbour mapping
(transpose for the load, as our conservative mapping), at most 50 iterations. Run as

    python -m benchmarks.kratos_peer WINDOWS OUT.json [--linear-solver sparse_lu] [--reynolds 250]

in its own process (one thread), it writes per-window iterations, per-call compute times of
both solvers, wall time per window and the tips' x-displacement.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

from cosim.schema import validate
from kratos_solvers.fluid import FLUID_SCHEMA, KratosFluid
from kratos_solvers.solid import LINEAR_SOLVERS, SOLID_SCHEMA, KratosSolid

ROOT = Path(__file__).resolve().parent.parent

TIPS = {"left": (1.2, 0.28), "right": (1.52, 0.28)}


def criterion(solver: str, data: str) -> dict:
    return {"type": "relative_norm_previous_residual", "solver": solver, "data_name": data,
            "abs_tolerance": 5e-3, "rel_tolerance": 5e-3}


def cosim_parameters(end: float, fluid_file: Path, solid_file: Path) -> dict:
    interface_fluid, interface_solid = "FluidModelPart.NoSlip2D_Interface", "Structure.StructureInterface2D_Struc_Fsi"
    return {
        "problem_data": {"start_time": 0.0, "end_time": end, "echo_level": 0, "print_colors": False,
                         "parallel_type": "OpenMP"},
        "solver_settings": {
            "type": "coupled_solvers.gauss_seidel_strong", "echo_level": 0, "num_coupling_iterations": 50,
            "convergence_accelerators": [{"type": "iqnils", "solver": "fluid", "data_name": "load",
                                          "timestep_horizon": 3, "alpha": 0.5, "iteration_horizon": 50}],
            "convergence_criteria": [criterion("fluid", "load"), criterion("structure", "disp")],
            "data_transfer_operators": {"mapper": {"type": "kratos_mapping",
                                                   "mapper_settings": {"mapper_type": "nearest_neighbor"}}},
            "coupling_sequence": [
                {"name": "structure",
                 "input_data_list": [{"data": "load", "from_solver": "fluid", "from_solver_data": "load",
                                      "data_transfer_operator": "mapper",
                                      "data_transfer_operator_options": ["swap_sign", "use_transpose"]}],
                 "output_data_list": [{"data": "disp", "to_solver": "fluid", "to_solver_data": "disp",
                                       "data_transfer_operator": "mapper"}]},
                {"name": "fluid", "input_data_list": [], "output_data_list": []}],
            "solvers": {
                "fluid": {"type": "solver_wrappers.kratos.fluid_dynamics_wrapper",
                          "solver_wrapper_settings": {"input_file": str(fluid_file)},
                          "data": {"disp": {"model_part_name": interface_fluid, "dimension": 2,
                                            "variable_name": "MESH_DISPLACEMENT"},
                                   "load": {"model_part_name": interface_fluid, "dimension": 2,
                                            "variable_name": "REACTION"}}},
                "structure": {"type": "solver_wrappers.kratos.structural_mechanics_wrapper",
                              "solver_wrapper_settings": {"input_file": str(solid_file)},
                              "data": {"disp": {"model_part_name": interface_solid, "dimension": 2,
                                                "variable_name": "DISPLACEMENT"},
                                       "load": {"model_part_name": interface_solid, "dimension": 2,
                                                "variable_name": "POINT_LOAD"}}}}}}


def timed(method, log: list):
    def wrapper(*args, **kwargs):
        started = time.perf_counter()
        result = method(*args, **kwargs)
        log.append(time.perf_counter() - started)
        return result
    return wrapper


def run_coupled(settings: dict, probes: dict[str, tuple[float, float]]) -> dict:
    """Kratos's coupled analysis of ``settings``, window by window: per window the coupling iterations (fluid
    calls), wall time, whether it converged, and the x and y displacement of the structure's node nearest each
    probe point; per call each solver's compute time."""
    import KratosMultiphysics as KM
    from KratosMultiphysics.CoSimulationApplication.co_simulation_analysis import CoSimulationAnalysis
    analysis = CoSimulationAnalysis(KM.Parameters(json.dumps(settings)))
    coupled = analysis._GetSolver()
    compute: dict[str, list[float]] = {"fluid": [], "structure": []}
    for name, log in compute.items():
        wrapper = coupled.solver_wrappers[name]
        wrapper.SolveSolutionStep = timed(wrapper.SolveSolutionStep, log)
    analysis.Initialize()
    structure = coupled.solver_wrappers["structure"]._analysis_stage.model["Structure"]

    def nearest(point: tuple[float, float]) -> Any:
        return min(structure.Nodes, key=lambda n: (n.X0 - point[0]) ** 2 + (n.Y0 - point[1]) ** 2)

    nodes = {name: nearest(point) for name, point in probes.items()}
    rows: dict[str, list] = {"iterations": [], "wall_seconds": [], "converged": [], **{name: [] for name in probes}}
    while analysis.KeepAdvancingSolutionLoop():
        started = time.perf_counter()
        calls_before = len(compute["fluid"])
        analysis.time = coupled.AdvanceInTime(analysis.time)
        analysis.InitializeSolutionStep()
        coupled.Predict()
        rows["converged"].append(bool(coupled.SolveSolutionStep()))
        analysis.FinalizeSolutionStep()
        analysis.OutputSolutionStep()
        rows["wall_seconds"].append(time.perf_counter() - started)
        rows["iterations"].append(len(compute["fluid"]) - calls_before)
        for name, node in nodes.items():
            rows[name].append([node.GetSolutionStepValue(KM.DISPLACEMENT_X), node.GetSolutionStepValue(KM.DISPLACEMENT_Y)])
    analysis.Finalize()
    del analysis, coupled
    return {**rows, "fluid_compute": compute["fluid"], "solid_compute": compute["structure"]}


def run_peer(windows: int, linear_solver: str = "sparse_lu", reynolds: float = 250.0, dt: float = 0.008) -> dict:
    import KratosMultiphysics as KM
    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)
    end = windows * dt
    time_section = {"start": 0.0, "end": end, "dt": dt}
    flow = {"reynolds": reynolds, "density": 1000.0, "peak_velocity": 2.5, "diameter": 0.1, "ramp_time": 1.0,
            "channel_height": 0.492, "profile_coefficient": 41.32}
    fluid_prm = {"time": time_section, "flow": flow, "tolerance": 1e-6, "max_iterations": 20,
                 "interface": "NoSlip2D_Interface"}
    solid_prm = {"time": time_section, "young_modulus": 10e6, "poisson_ratio": 0.3, "density": 1000.0,
                 "linear_solver": linear_solver, "tolerance": 1e-6, "max_iterations": 25,
                 "clamped": "DISPLACEMENT_BCDisp"}
    assert linear_solver in LINEAR_SOLVERS
    # every default filled in, as the components' own validation does (the mesh comes separately)
    fluid_prm = validate({**fluid_prm, "mesh": "-"}, FLUID_SCHEMA)
    solid_prm = validate({**solid_prm, "mesh": "-"}, SOLID_SCHEMA)
    with tempfile.TemporaryDirectory(prefix="cosim-peer-") as folder:
        tmp = Path(folder)
        (tmp / "fluid_materials.json").write_text(json.dumps(KratosFluid._materials(flow)))
        (tmp / "solid_materials.json").write_text(json.dumps(KratosSolid._materials(solid_prm)))
        fluid_file, solid_file = tmp / "fluid.json", tmp / "solid.json"
        fluid_file.write_text(json.dumps(KratosFluid._project(fluid_prm, ROOT / "scenes/double_flap/fluid",
                                                              tmp / "fluid_materials.json")))
        solid_file.write_text(json.dumps(KratosSolid._project(solid_prm, ROOT / "scenes/double_flap/solid",
                                                              tmp / "solid_materials.json")))
        result = run_coupled(cosim_parameters(end, fluid_file, solid_file), TIPS)
    if not all(result["converged"]):
        first = result["converged"].index(False)
        raise RuntimeError(f"Kratos's coupler did not converge at t = {(first + 1) * dt:g}")
    tips = {f"tip_{side}": [xy[0] for xy in result.pop(side)] for side in TIPS}
    return {**result, **tips, "linear_solver": linear_solver, "reynolds": reynolds}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("windows", type=int)
    parser.add_argument("out")
    parser.add_argument("--linear-solver", default="sparse_lu", choices=sorted(LINEAR_SOLVERS))
    parser.add_argument("--reynolds", type=float, default=250.0)
    args = parser.parse_args(argv)
    result = run_peer(args.windows, args.linear_solver, args.reynolds)
    Path(args.out).write_text(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
