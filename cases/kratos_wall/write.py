"""Write a Kratos CoSimulation case of Mok's channel in Kratos's own layout, as a Kratos user would have it:
``ProjectParametersCoSim.json``, ``ProjectParametersCFD.json``, ``ProjectParametersCSM.json``, the two materials
files and the two ``.mdpa`` meshes (made by ``kratos_solvers.mok_mesh``), plus a ``case.toml`` for ``cosim run``.

- ``static``: a quasi-static wall (Kratos's static solver, ten times Mok's stiffness), Gauss-Seidel strong with the structure first, IQN-ILS on
  the fluid's load (three windows reused), criteria on the load and on the displacement, the load mapped by the
  transpose of nearest neighbour with its sign swapped: the layout of the paper's double flap.
- ``dynamic``: Mok's wall with inertia (Newmark), Gauss-Seidel strong with the fluid first, MVQN on the fluid's
  displacement, the linear predictor, the criterion on the displacement: the layout of Kratos's Mok example.

    python -m cases.kratos_wall.write OUT --kind static|dynamic [--windows N] [--wall-cells 2 20] ...

Both files run unchanged under ``python MainKratosCoSim.py`` in OUT and under ``cosim run OUT/case.toml``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path
from typing import Any

from cosim.schema import validate
from kratos_solvers.mok import FLUID_SCHEMA, STRUCTURE_SCHEMA, MokFluid, MokStructure
from kratos_solvers.mok_mesh import FLUID_INTERFACE, SOLID_INTERFACE, mok_meshes

DT = 0.1
# the static wall is ten times stiffer than Mok's: a massless wall as soft as Mok's, against an incompressible
# fluid, is a coupling that IQN-ILS (Kratos's and ours alike) loses on the finer mesh
STATIC_YOUNG_MODULUS = 2.3e7
COARSE = {"wall_cells": [2, 20], "far_size": 0.06, "wall_size": 0.0125}


def cosim_parameters(kind: str, end: float) -> dict[str, Any]:
    """The ``ProjectParametersCoSim.json`` of ``kind``, ``end`` its end_time."""
    fluid_interface, structure_interface = f"FluidModelPart.{FLUID_INTERFACE}", f"Structure.{SOLID_INTERFACE}"

    def data(part: str, variable: str) -> dict:
        return {"model_part_name": part, "dimension": 2, "variable_name": variable}

    def criterion(solver: str, name: str, tolerance: float) -> dict:
        return {"type": "relative_norm_previous_residual", "solver": solver, "data_name": name,
                "abs_tolerance": tolerance, "rel_tolerance": tolerance}

    load = {"data": "load", "from_solver": "fluid", "from_solver_data": "load", "data_transfer_operator": "mapper",
            "data_transfer_operator_options": ["swap_sign", "use_transpose"]}
    disp = {"data": "disp", "to_solver": "fluid", "to_solver_data": "disp", "data_transfer_operator": "mapper"}
    if kind == "static":
        sequence = [{"name": "structure", "input_data_list": [load], "output_data_list": [disp]},
                    {"name": "fluid", "input_data_list": [], "output_data_list": []}]
        accelerators = [{"type": "iqnils", "solver": "fluid", "data_name": "load", "iteration_horizon": 20,
                         "timestep_horizon": 3, "alpha": 0.5}]
        criteria = [criterion("fluid", "load", 1e-5), criterion("fluid", "disp", 1e-7)]
        predictors: list[dict] = []
    else:
        sequence = [{"name": "fluid", "input_data_list": [], "output_data_list": []},
                    {"name": "structure", "input_data_list": [load], "output_data_list": [disp]}]
        accelerators = [{"type": "mvqn", "solver": "fluid", "data_name": "disp", "horizon": 15, "alpha": 0.1}]
        criteria = [criterion("fluid", "disp", 1e-6)]
        predictors = [{"type": "linear", "solver": "fluid", "data_name": "disp"}]
    return {
        "problem_data": {"problem_name": f"wall_{kind}", "start_time": 0.0, "end_time": end, "echo_level": 0,
                         "print_colors": False, "parallel_type": "OpenMP"},
        "solver_settings": {
            "type": "coupled_solvers.gauss_seidel_strong", "echo_level": 0, "num_coupling_iterations": 30,
            "predictors": predictors, "convergence_accelerators": accelerators, "convergence_criteria": criteria,
            "data_transfer_operators": {"mapper": {"type": "kratos_mapping",
                                                   "mapper_settings": {"mapper_type": "nearest_neighbor"}}},
            "coupling_sequence": sequence,
            "solvers": {
                "fluid": {"type": "solver_wrappers.kratos.fluid_dynamics_wrapper",
                          "solver_wrapper_settings": {"input_file": "ProjectParametersCFD"},
                          "data": {"disp": data(fluid_interface, "MESH_DISPLACEMENT"),
                                   "load": data(fluid_interface, "REACTION")}},
                "structure": {"type": "solver_wrappers.kratos.structural_mechanics_wrapper",
                              "solver_wrapper_settings": {"input_file": "ProjectParametersCSM"},
                              "data": {"disp": data(structure_interface, "DISPLACEMENT"),
                                       "load": data(structure_interface, "POINT_LOAD"),
                                       # the whole wall, in no transfer: cosim records it for a ROM's decoder
                                       "disp_field": data("Structure", "DISPLACEMENT")}}}}}


def write_case(out: Path, kind: str, windows: int, mesh: dict[str, Any] | None = None) -> Path:
    """The case folder ``out`` (made), for ``windows`` windows of 0.1 s; returns its ``case.toml``."""
    out.mkdir(parents=True, exist_ok=True)
    mesh = {**COARSE, **(mesh or {})}
    end = windows * DT
    time_section = {"start": 0.0, "end": end, "dt": DT}
    fluid = validate({"time": time_section, "mesh": mesh}, FLUID_SCHEMA)
    wall = {"dynamics": "static", "young_modulus": STATIC_YOUNG_MODULUS} if kind == "static" else {"dynamics": "newmark"}
    structure = validate({"time": time_section, "mesh": mesh, **wall}, STRUCTURE_SCHEMA)
    meshes = mok_meshes(mesh)
    shutil.copyfile(meshes["fluid"], out / "fluid.mdpa")
    shutil.copyfile(meshes["solid"], out / "structure.mdpa")
    files = {
        "FluidMaterials.json": MokFluid._materials(fluid["flow"]),
        "StructuralMaterials.json": MokStructure._materials(structure),
        "ProjectParametersCFD.json": MokFluid._project(fluid, Path("fluid"), Path("FluidMaterials.json")),
        "ProjectParametersCSM.json": MokStructure._project(structure, Path("structure"),
                                                           Path("StructuralMaterials.json")),
        # Kratos steps while its time is below end_time: half a step less than the last window's end
        "ProjectParametersCoSim.json": cosim_parameters(kind, end - 0.5 * DT),
    }
    for name, content in files.items():
        (out / name).write_text(json.dumps(content, indent=4) + "\n")
    case = out / "case.toml"
    case.write_text(f'# cosim run {case.name}: the Kratos CoSimulation case in this folder, unchanged\n'
                    f'name = "Kratos wall, {kind}"\n\n[kratos]\ncosim = "ProjectParametersCoSim.json"\n')
    return case


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--kind", choices=("static", "dynamic"), default="dynamic")
    parser.add_argument("--windows", type=int, default=10)
    parser.add_argument("--wall-cells", type=int, nargs=2, default=COARSE["wall_cells"])
    parser.add_argument("--wall-size", type=float, default=COARSE["wall_size"])
    parser.add_argument("--far-size", type=float, default=COARSE["far_size"])
    args = parser.parse_args(argv)
    case = write_case(Path(args.out), args.kind, args.windows,
                      {"wall_cells": args.wall_cells, "wall_size": args.wall_size, "far_size": args.far_size})
    print(case)
    return 0


if __name__ == "__main__":
    sys.exit(main())
