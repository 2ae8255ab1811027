"""The peer: Mok's benchmark through Kratos CoSimulationApplication's own coupler.

Same generated meshes, same fluid and structure settings (the project parameters come from the same
builders as our components), and the coupling of Kratos's own validation case: Gauss-Seidel strong,
fluid then structure, MVQN on the fluid's interface displacement, a linear predictor from the interface
velocity, nearest-neighbour mapping (transpose for the force), the scene's criterion (residual RMS or
relative norm 1e-6 on the displacement), at most 30 iterations. Run as

    python -m benchmarks.mok_peer WINDOWS OUT.json [--set mesh.KEY=VALUE ...]

in its own process (one thread); it writes per-window iterations and wall time, per-call compute times of
both solvers, and points A and B.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from benchmarks.kratos_peer import run_coupled
from cosim.schema import validate
from kratos_solvers.mok import FLUID_SCHEMA, STRUCTURE_SCHEMA, MokFluid, MokStructure
from kratos_solvers.mok_mesh import FLUID_INTERFACE, POINT_A, POINT_B, SOLID_INTERFACE, mok_meshes

LIMIT = 1e-6
DT = 0.1


def cosim_parameters(end: float, fluid_file: Path, structure_file: Path) -> dict:
    """Kratos's coupled analysis up to ``end`` (it steps while its time is below the end time: half a step less)."""
    fluid_interface, structure_interface = f"FluidModelPart.{FLUID_INTERFACE}", f"Structure.{SOLID_INTERFACE}"

    def data(part: str, variable: str) -> dict:
        return {"model_part_name": part, "dimension": 2, "variable_name": variable}

    return {
        "problem_data": {"start_time": 0.0, "end_time": end - 0.5 * DT, "echo_level": 0, "print_colors": False,
                         "parallel_type": "OpenMP"},
        "solver_settings": {
            "type": "coupled_solvers.gauss_seidel_strong", "echo_level": 0, "num_coupling_iterations": 30,
            "predictors": [{"type": "linear_derivative_based", "solver": "fluid", "data_name": "disp",
                            "derivative_data_name": "vel"}],
            "convergence_accelerators": [{"type": "mvqn", "solver": "fluid", "data_name": "disp"}],
            "convergence_criteria": [{"type": "relative_norm_previous_residual", "solver": "fluid",
                                      "data_name": "disp", "abs_tolerance": LIMIT, "rel_tolerance": LIMIT}],
            "data_transfer_operators": {"mapper": {"type": "kratos_mapping",
                                                   "mapper_settings": {"mapper_type": "nearest_neighbor"}}},
            "coupling_sequence": [
                {"name": "fluid", "input_data_list": [], "output_data_list": []},
                {"name": "structure",
                 "input_data_list": [{"data": "load", "from_solver": "fluid", "from_solver_data": "load",
                                      "data_transfer_operator": "mapper",
                                      "data_transfer_operator_options": ["swap_sign", "use_transpose"]}],
                 "output_data_list": [{"data": "disp", "to_solver": "fluid", "to_solver_data": "disp",
                                       "data_transfer_operator": "mapper"}]}],
            "solvers": {
                "fluid": {"type": "solver_wrappers.kratos.fluid_dynamics_wrapper",
                          "solver_wrapper_settings": {"input_file": str(fluid_file)},
                          "data": {"disp": data(fluid_interface, "MESH_DISPLACEMENT"),
                                   "load": data(fluid_interface, "REACTION"),
                                   "vel": data(fluid_interface, "VELOCITY")}},
                "structure": {"type": "solver_wrappers.kratos.structural_mechanics_wrapper",
                              "solver_wrapper_settings": {"input_file": str(structure_file)},
                              "data": {"disp": data(structure_interface, "DISPLACEMENT"),
                                       "load": data(structure_interface, "POINT_LOAD")}}}}}


def run_peer(windows: int, mesh: dict) -> dict:
    import KratosMultiphysics as KM
    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)
    end = windows * DT
    time_section = {"start": 0.0, "end": end, "dt": DT}
    fluid_prm = validate({"time": time_section, "mesh": mesh}, FLUID_SCHEMA)
    structure_prm = validate({"time": time_section, "mesh": mesh}, STRUCTURE_SCHEMA)
    meshes = mok_meshes(mesh)
    with tempfile.TemporaryDirectory(prefix="cosim-mok-peer-") as folder:
        tmp = Path(folder)
        (tmp / "fluid_materials.json").write_text(json.dumps(MokFluid._materials(fluid_prm["flow"])))
        (tmp / "structure_materials.json").write_text(json.dumps(MokStructure._materials(structure_prm)))
        fluid_file, structure_file = tmp / "fluid.json", tmp / "structure.json"
        fluid_file.write_text(json.dumps(MokFluid._project(fluid_prm, meshes["fluid"].with_suffix(""),
                                                           tmp / "fluid_materials.json")))
        structure_file.write_text(json.dumps(MokStructure._project(structure_prm, meshes["solid"].with_suffix(""),
                                                                   tmp / "structure_materials.json")))
        return run_coupled(cosim_parameters(end, fluid_file, structure_file), {"point_a": POINT_A, "point_b": POINT_B})


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("windows", type=int)
    parser.add_argument("out")
    parser.add_argument("--mesh", default="{}", help="the mesh resolution as JSON (the scene's [mesh] section)")
    args = parser.parse_args(argv)
    Path(args.out).write_text(json.dumps(run_peer(args.windows, json.loads(args.mesh))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
