"""A Kratos solid behind the component contract: static (the double flap) or dynamic (Mok's wall).

Elements come from the mesh (total Lagrangian bilinear quadrilaterals in both cases); the material law
is a parameter: plane strain Neo-Hookean (``HyperElasticPlaneStrain2DLaw``, the double flap's) or linear
elastic plane stress. ``dynamics`` is ``static`` (Kratos's static solver, no history) or an implicit
``newmark`` / ``bossak`` scheme (Kratos's dynamic solver: inertia, state from window to window). Newton
on the residual to 1e-6, clamped base. Input ``force`` (POINT_LOAD on the interface nodes, (n, 2) N);
output ``displacement`` on the same nodes; local ``displacement_field`` on all nodes, and the
displacement of each named probe point (the node nearest it), recorded, not exchanged. A coupling
iteration is repeated by solving the same step again from the last iterate (``repeats_steps``): the
dynamic schemes update velocity and acceleration from the window's start values, which Kratos keeps.
The linear solver is a parameter: the authors' ``sparse_qr`` or a fast direct one.
Kratos is imported only here, in the component's own process.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import Variable
from cosim.errors import ComponentError
from cosim.schema import AnyTable, Choice, FilePath, Positive, Required, Value, validate
from kratos_solvers.stage import KratosComponent, SteppedStage, kratos_parameters, nodal_vector, node_coordinates

LINEAR_SOLVERS = {
    "sparse_qr": "LinearSolversApplication.sparse_qr",     # the authors' (slow)
    "sparse_lu": "LinearSolversApplication.sparse_lu",     # Eigen's SparseLU (fast, same displacements)
    "skyline_lu_factorization": "skyline_lu_factorization",
}
CONSTITUTIVE_LAWS = ("HyperElasticPlaneStrain2DLaw", "LinearElasticPlaneStress2DLaw", "LinearElasticPlaneStrain2DLaw")
SOLID_SCHEMA = {
    "time": {"start": 0.0, "end": Required(float), "dt": Positive()},
    "mesh": FilePath(required=True),       # the .mdpa file
    "young_modulus": Positive(10e6),
    "poisson_ratio": Value(0.3, low=0.0, high=0.5, high_open=True),
    "density": Positive(1000.0),           # unused by the static solver, required by the material
    "constitutive_law": Choice("HyperElasticPlaneStrain2DLaw", CONSTITUTIVE_LAWS),
    "dynamics": Choice("static", ("static", "newmark", "bossak")),
    "probes": AnyTable(),                  # name = [x, y]: the displacement of the node nearest each, recorded
    "linear_solver": Choice("sparse_lu", tuple(LINEAR_SOLVERS)),
    "tolerance": Positive(1e-6),
    "max_iterations": Positive(25),
    "on_unconverged": Choice("warn", ("warn", "fail")),   # when Newton hits max_iterations
    "interface": "StructureInterface2D_Struc_Fsi",
    "clamped": "DISPLACEMENT_BCDisp",
}


class KratosSolid(KratosComponent):
    """Kratos StructuralMechanicsAnalysis, one Newton solve per coupling iteration."""

    name = "solid"
    parameter_schema = SOLID_SCHEMA
    input_name = "force"
    solve_label = "Newton solve"

    part_name = "Structure"
    problem_name = "double_flap_solid"

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, self.parameter_schema)
        self._prm = prm
        self._files = self.prepare(prm, self._materials(prm))
        self.build()
        part = self.model[self.part_name]
        self.interface_nodes = node_coordinates(self.interface, 2)
        self.field_nodes = node_coordinates(self.all_nodes, 2)
        self.quads = np.array([[n.Id for n in e.GetNodes()] for e in part.Elements], dtype=np.int64)
        self._node_index = {node.Id: i for i, node in enumerate(self.all_nodes)}
        self.probes = {name: self._probe_node(name, point) for name, point in prm["probes"].items()}
        self.input = np.zeros((len(self.interface_nodes), 2))   # the interface force

    def _probe_node(self, name: str, point: Any) -> int:
        """The index of the node nearest ``point`` (a probe), checked to be a point of the plane."""
        if (not isinstance(point, list) or len(point) != 2
                or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in point)):
            raise ComponentError(self.name, f"probe '{name}' must be [x, y] in metres, got {point!r}")
        return int(np.argmin(np.linalg.norm(self.field_nodes - np.asarray(point, dtype=float), axis=1)))

    def build(self, import_settings: dict[str, Any] | None = None) -> None:
        import KratosMultiphysics as KM
        import KratosMultiphysics.StructuralMechanicsApplication as SMA
        from KratosMultiphysics.StructuralMechanicsApplication.structural_mechanics_analysis import (
            StructuralMechanicsAnalysis,
        )
        project = self._project(self._prm, *self._files)
        if import_settings is not None:
            project["solver_settings"]["model_import_settings"] = import_settings
        self.model = KM.Model()
        stage = StructuralMechanicsAnalysis(self.model, kratos_parameters(project))
        self.stepped = SteppedStage(self.name, stage, static=self._prm["dynamics"] == "static")
        part = self.model[self.part_name]
        self.interface = part.GetSubModelPart(self._prm["interface"]).Nodes
        self.clamped = part.GetSubModelPart(self._prm["clamped"]).Nodes
        self.all_nodes = part.Nodes
        self.KM, self.SMA = KM, SMA

    @staticmethod
    def _materials(prm: dict) -> dict:
        return {"properties": [{
            "model_part_name": "Structure.Parts_Solid_Structure", "properties_id": 1,
            "Material": {"constitutive_law": {"name": prm["constitutive_law"]},
                         "Variables": {"DENSITY": prm["density"], "YOUNG_MODULUS": prm["young_modulus"],
                                       "POISSON_RATIO": prm["poisson_ratio"], "THICKNESS": 1.0},
                         "Tables": {}}}]}

    @classmethod
    def _project(cls, prm: dict, mesh: Path, materials: Path) -> dict:
        tolerance = prm["tolerance"]
        dynamics = ({} if prm["dynamics"] == "static" else
                    {"solver_type": "Dynamic", "time_integration_method": "implicit", "scheme_type": prm["dynamics"]})
        return {
            "problem_data": {"problem_name": cls.problem_name, "parallel_type": "OpenMP", "echo_level": 0,
                             "start_time": prm["time"]["start"], "end_time": prm["time"]["end"]},
            "solver_settings": {
                "solver_type": "Static", "model_part_name": "Structure", "domain_size": 2, "echo_level": 0,
                **dynamics,
                "analysis_type": "non_linear",
                "model_import_settings": {"input_type": "mdpa", "input_filename": str(mesh)},
                "material_import_settings": {"materials_filename": str(materials)},
                "time_stepping": {"time_step": prm["time"]["dt"]},
                "line_search": False, "convergence_criterion": "residual_criterion",
                "displacement_relative_tolerance": tolerance, "displacement_absolute_tolerance": tolerance,
                "residual_relative_tolerance": tolerance, "residual_absolute_tolerance": tolerance,
                "max_iteration": prm["max_iterations"],
                "linear_solver_settings": {"solver_type": LINEAR_SOLVERS[prm["linear_solver"]]},
                "rotation_dofs": False},
            "processes": {
                "constraints_process_list": [{
                    "python_module": "assign_vector_variable_process", "kratos_module": "KratosMultiphysics",
                    "process_name": "AssignVectorVariableProcess",
                    "Parameters": {"model_part_name": f"Structure.{prm['clamped']}", "variable_name": "DISPLACEMENT",
                                   "interval": [0.0, "End"], "constrained": [True, True, True],
                                   "value": [0.0, 0.0, 0.0]}}],
                "loads_process_list": [], "list_other_processes": []},
            "output_processes": {},
        }

    def variables(self) -> list[Variable]:
        n, m = len(self.interface_nodes), len(self.field_nodes)
        return [Variable("force", "input", 2 * n, "N", mesh="interface", components=2),
                Variable("displacement", "output", 2 * n, "m", mesh="interface", components=2,
                         precision=self.settings["tolerance"]),
                Variable("displacement_field", "local", 2 * m, "m", mesh="solid", components=2),
                *[Variable(name, "local", 2, "m") for name in self.probes]]

    def meshes(self) -> dict[str, np.ndarray]:
        return {"interface": self.interface_nodes, "solid": self.field_nodes}

    def input_variable(self) -> Any:
        return self.SMA.POINT_LOAD

    def readers(self) -> dict[str, Callable[[], np.ndarray]]:
        field = lambda: nodal_vector(self.all_nodes, self.KM.DISPLACEMENT, 2)
        probes = {name: (lambda node=node: field()[node].copy()) for name, node in self.probes.items()}
        return {"displacement": lambda: nodal_vector(self.interface, self.KM.DISPLACEMENT, 2),
                "displacement_field": field, **probes}

    def reactions(self) -> np.ndarray:
        """Reactions at the clamped base, (n_base, 2) N (for the equilibrium check)."""
        return nodal_vector(self.clamped, self.KM.REACTION, 2)

    def terminate(self) -> dict[str, np.ndarray]:
        final = {"nodes": self.field_nodes, "quads": np.vectorize(self._node_index.get)(self.quads),
                 "displacement_field": nodal_vector(self.all_nodes, self.KM.DISPLACEMENT, 2),
                 "newton_unconverged": np.array(self.stepped.unconverged)}
        self.close()
        return final


def standalone_solid(mesh: str | Path, linear_solver: str = "sparse_lu") -> KratosSolid:
    """A Kratos solid instantiated outside a coupled run, for re-solving single calls (the static solid keeps
    nothing from one call to the next but its Newton start); ``close()`` it when done."""
    solid = KratosSolid()
    solid.instantiate({"time": {"start": 0.0, "end": 1.0, "dt": 0.008}, "mesh": str(mesh),
                       "linear_solver": linear_solver})
    return solid
