"""The double flap's fluid: Kratos's ALE Navier-Stokes solver behind the component contract.

The authors' settings (shared/scenes/double_flap.md): mesh motion by structural similarity,
monolithic ``dvms`` element, Bossak scheme, Newton to 1e-6 (at most 20 iterations), parabolic
inlet v(y) = 41.32 y (0.492 - y) ramped by (1 - cos(pi t)) / 2 over the first second, outlet
p = 0, no slip elsewhere; the viscosity mu = rho v_max D / Re sets the Reynolds number.
Input ``displacement`` (MESH_DISPLACEMENT of the 265 interface nodes, (265, 2) m); output
``force`` on the solid (minus the interface REACTION, (265, 2) N). A coupling iteration is
repeated by solving the same step again from the last iterate (``repeats_steps``).
Kratos is imported only here, in the component's own process.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import Variable
from cosim.schema import Choice, FilePath, Positive, Required, validate
from kratos_solvers.stage import KratosComponent, SteppedStage, kratos_parameters, nodal_vector, node_coordinates

FLUID_SCHEMA = {
    "time": {"start": 0.0, "end": Required(float), "dt": Positive()},
    "flow": {"reynolds": Positive(250.0), "density": Positive(1000.0), "peak_velocity": Positive(2.5),
             "diameter": Positive(0.1), "ramp_time": Positive(1.0), "channel_height": Positive(0.492),
             "profile_coefficient": Positive(41.32)},   # v(y) = c y (h - y): the authors' 41.32 (4 v_max / h^2 = 41.31)
    "mesh": FilePath(required=True),       # the .mdpa file
    "tolerance": Positive(1e-6),
    "max_iterations": Positive(20),
    "on_unconverged": Choice("warn", ("warn", "fail")),   # when Newton hits max_iterations
    "interface": "NoSlip2D_Interface",
}
WALLS = ("NoSlip2D_Top", "NoSlip2D_Bottom", "NoSlip2D_Cylinder")
INLET, OUTLET = "AutomaticInlet2D_Inlet", "Outlet2D_Outlet"


class KratosFluid(KratosComponent):
    """Kratos FluidDynamicsAnalysis with the ``ale_fluid`` solver, one solve per coupling iteration.

    The class attributes name the mesh's sub-model parts and the element; a case with other boundaries
    or another inlet overrides them, ``inlet_moduli`` and the schema (``kratos_solvers.mok``).
    """

    name = "fluid"
    parameter_schema = FLUID_SCHEMA
    input_name = "displacement"
    solve_label = "fluid solve"

    part_name = "FluidModelPart"
    problem_name = "double_flap_fluid"
    volume_part = "FluidParts_FluidPart"
    inlet_part, outlet_part = INLET, OUTLET
    walls: tuple[str, ...] = WALLS           # no slip, fixed mesh
    slip_walls: tuple[str, ...] = ()         # slip, fixed mesh
    element = "dvms"

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, self.parameter_schema)
        self._prm = prm
        self._files = self.prepare(prm, self._materials(prm["flow"]))
        self.build()
        self.interface_nodes = node_coordinates(self.interface, 2)
        self.input = np.zeros((len(self.interface_nodes), 2))   # the interface displacement

    def build(self, import_settings: dict[str, Any] | None = None) -> None:
        import KratosMultiphysics as KM
        import KratosMultiphysics.MeshMovingApplication  # noqa: F401  (registers the mesh-motion solvers)
        from KratosMultiphysics.FluidDynamicsApplication.fluid_dynamics_analysis import FluidDynamicsAnalysis
        project = self._project(self._prm, *self._files)
        if import_settings is not None:
            project["solver_settings"]["fluid_solver_settings"]["model_import_settings"] = import_settings
        self.model = KM.Model()
        stage = FluidDynamicsAnalysis(self.model, kratos_parameters(project))
        self.stepped = SteppedStage(self.name, stage, self._solve_step)
        part = self.model[self.part_name]
        self.interface = part.GetSubModelPart(self._prm["interface"]).Nodes
        self.volume = part.GetSubModelPart(self.volume_part)
        self.KM = KM

    def _solve_step(self) -> bool:
        """The ALE solver's step, judged by the fluid's Newton alone.

        Kratos's ALE solver also folds in the mesh-motion solve's return value, which is a
        norm (0.0 when the mesh does not move), not a convergence flag.
        """
        ale = self.stepped.solver
        for mesh_solver in ale.GetMeshMotionSolvers():
            mesh_solver.SolveSolutionStep()
        ale._AleFluidSolver__ApplyALEBoundaryCondition()   # mesh velocity -> fluid velocity on the interface
        return bool(ale.GetFluidSolver().SolveSolutionStep())

    @staticmethod
    def viscosity(flow: dict) -> float:
        """mu = rho v_max D / Re."""
        return flow["density"] * flow["peak_velocity"] * flow["diameter"] / flow["reynolds"]

    @classmethod
    def _materials(cls, flow: dict) -> dict:
        return {"properties": [{
            "model_part_name": f"FluidModelPart.{cls.volume_part}", "properties_id": 1,
            "Material": {"constitutive_law": {"name": "Newtonian2DLaw"},
                         "Variables": {"DENSITY": flow["density"], "DYNAMIC_VISCOSITY": cls.viscosity(flow)},
                         "Tables": None}}]}

    @staticmethod
    def inlet_moduli(flow: dict) -> list[tuple[list, str]]:
        """(time interval, velocity modulus as a Kratos expression of x, y, t) of the inlet, in order."""
        h = flow["channel_height"]
        profile = f"y*({h!r}-y)*{flow['profile_coefficient']!r}"
        ramp = flow["ramp_time"]
        return [([0.0, ramp], f"0.5*(1-cos(pi*t/{ramp!r}))*{profile}"), ([ramp, "End"], profile)]

    @classmethod
    def _project(cls, prm: dict, mesh: Path, materials: Path) -> dict:
        tolerance, interface = prm["tolerance"], prm["interface"]
        walls, slip_walls = (*cls.walls, interface), cls.slip_walls

        def inlet(interval: list, modulus: str) -> dict:
            return {"python_module": "apply_inlet_process", "kratos_module": "KratosMultiphysics.FluidDynamicsApplication",
                    "process_name": "ApplyInletProcess",
                    "Parameters": {"model_part_name": f"FluidModelPart.{cls.inlet_part}", "variable_name": "VELOCITY",
                                   "interval": interval, "modulus": modulus, "direction": "automatic_inwards_normal"}}

        def no_slip(part: str) -> dict:
            return {"python_module": "apply_noslip_process", "kratos_module": "KratosMultiphysics.FluidDynamicsApplication",
                    "process_name": "ApplyNoSlipProcess", "Parameters": {"model_part_name": f"FluidModelPart.{part}"}}

        def slip(part: str) -> dict:
            return {"python_module": "apply_slip_process", "kratos_module": "KratosMultiphysics.FluidDynamicsApplication",
                    "process_name": "ApplySlipProcess", "Parameters": {"model_part_name": f"FluidModelPart.{part}"}}

        def fixed_mesh(part: str) -> dict:
            return {"python_module": "fix_vector_variable_process", "kratos_module": "KratosMultiphysics",
                    "process_name": "AssignVectorVariableProcess",
                    "Parameters": {"model_part_name": f"FluidModelPart.{part}", "variable_name": "MESH_DISPLACEMENT",
                                   "constrained": [True, True, True]}}

        outlet = {"python_module": "apply_outlet_process", "kratos_module": "KratosMultiphysics.FluidDynamicsApplication",
                  "process_name": "ApplyOutletProcess",
                  "Parameters": {"model_part_name": f"FluidModelPart.{cls.outlet_part}", "variable_name": "PRESSURE",
                                 "constrained": True, "value": 0.0, "hydrostatic_outlet": False, "h_top": 0.0}}
        return {
            "problem_data": {"problem_name": cls.problem_name, "parallel_type": "OpenMP", "echo_level": 0,
                             "start_time": prm["time"]["start"], "end_time": prm["time"]["end"]},
            "solver_settings": {
                "solver_type": "ale_fluid", "ale_boundary_parts": [interface],
                "mesh_motion_solver_settings": {"solver_type": "structural_similarity"},
                "fluid_solver_settings": {
                    "model_part_name": "FluidModelPart", "domain_size": 2, "solver_type": "Monolithic",
                    "model_import_settings": {"input_type": "mdpa", "input_filename": str(mesh)},
                    "material_import_settings": {"materials_filename": str(materials)},
                    "echo_level": 0, "compute_reactions": True, "maximum_iterations": prm["max_iterations"],
                    "relative_velocity_tolerance": tolerance, "absolute_velocity_tolerance": tolerance,
                    "relative_pressure_tolerance": tolerance, "absolute_pressure_tolerance": tolerance,
                    "volume_model_part_name": cls.volume_part,
                    "skin_parts": [cls.inlet_part, cls.outlet_part, *walls, *slip_walls], "no_skin_parts": [],
                    "time_scheme": "bossak",
                    "time_stepping": {"automatic_time_step": False, "time_step": prm["time"]["dt"]},
                    "formulation": {"element_type": cls.element, "use_orthogonal_subscales": False, "dynamic_tau": 1.0},
                    "reform_dofs_at_each_step": False}},
            "processes": {
                "initial_conditions_process_list": [],
                "boundary_conditions_process_list": [
                    *[inlet(interval, modulus) for interval, modulus in cls.inlet_moduli(prm["flow"])],
                    outlet, *[no_slip(p) for p in walls], *[slip(p) for p in slip_walls]],
                "gravity": [],
                "ale_boundary_conditions": [fixed_mesh(p) for p in (*cls.walls, cls.inlet_part, cls.outlet_part,
                                                                    *slip_walls, interface)]},
            "output_processes": {},
        }

    def variables(self) -> list[Variable]:
        n = 2 * len(self.interface_nodes)
        return [Variable("displacement", "input", n, "m", mesh="interface", components=2),
                Variable("force", "output", n, "N", mesh="interface", components=2,
                         precision=self.settings["tolerance"])]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"interface": self.interface_nodes}

    def input_variable(self) -> Any:
        return self.KM.MESH_DISPLACEMENT

    def readers(self) -> dict[str, Callable[[], np.ndarray]]:
        return {"force": lambda: -nodal_vector(self.interface, self.KM.REACTION, 2)}

    def terminate(self) -> dict[str, np.ndarray]:
        """The last window for the run's picture: deformed nodes, triangles, velocity and pressure."""
        nodes = self.volume.Nodes
        index = {node.Id: i for i, node in enumerate(nodes)}
        final = {
            "nodes": np.asarray(self.KM.VariableUtils().GetCurrentPositionsVector(nodes, 2)).reshape(-1, 2),
            "triangles": np.array([[index[n.Id] for n in e.GetNodes()] for e in self.volume.Elements], dtype=np.int64),
            "velocity": nodal_vector(nodes, self.KM.VELOCITY, 2),
            "pressure": np.asarray(self.KM.VariableUtils().GetSolutionStepValuesVector(nodes, self.KM.PRESSURE, 0)),
            "newton_unconverged": np.array(self.stepped.unconverged),
        }
        self.close()
        return final
