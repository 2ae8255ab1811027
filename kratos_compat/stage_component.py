"""A Kratos solver wrapper of a CoSimulation case as a cosim component: Kratos's own analysis stage
(``FluidDynamicsAnalysis``, ``StructuralMechanicsAnalysis``) built from the case's unmodified ProjectParameters, in
the case's folder, driven window by window and iteration by iteration (``kratos_solvers.stage.SteppedStage``, in
the order Kratos's CoSimulation calls a wrapper: advance, predict, initialise, then solve per iteration).

Its variables are the wrapper's ``data`` entries: each a Kratos variable on a model part's nodes, ``dimension``
components per node (``(n, d)``; ``(n,)`` for a scalar); inputs are written into the step right before each
solve, outputs read after it; an entry no transfer uses is a local variable, recorded with every call (the whole
structure's displacement, for a ROM's decoder). Each model part is a mesh (its nodes' initial coordinates).
A checkpoint is Kratos's own restart serialisation of the main model part. Kratos is imported only in this
component's process.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cosim.component import Variable, check_inputs, run_directory
from cosim.errors import ComponentError
from cosim.schema import AnyTable, Choice, Required, Value, validate
from kratos_compat.json_source import JsonSource
from kratos_solvers.stage import KratosComponent, SteppedStage, kratos_parameters, node_coordinates, quiet, set_threads

FIELD = {"name": Required(str), "data": Required(str), "model_part": Required(str), "variable": Required(str),
         "dimension": Value(1, low=1, high=3), "location": "node_historical",
         "role": Choice("input", ("input", "output", "local"))}
SCHEMA = {"solver": Required(str), "analysis": Choice("fluid_dynamics", ("fluid_dynamics", "structural_mechanics")),
          "project": Required(str), "folder": Required(str), "threads": 0, "fields": Required(list),
          "inputs": AnyTable()}      # the files it reads, by label: named in the scene for a resume's checks


class KratosStage(KratosComponent):
    """One Kratos analysis stage of a CoSimulation case."""

    repeats_steps = True
    solve_label = "solve"

    def instantiate(self, parameters: Mapping[str, Any]) -> None:
        prm = validate(parameters, SCHEMA)
        self.name = prm["solver"]
        self.fields = [validate(f, FIELD, f"fields.{i}.") for i, f in enumerate(prm["fields"])]
        for f in self.fields:
            f["dimension"] = int(f["dimension"])
        os.chdir(prm["folder"])             # Kratos reads the case's paths relative to its folder
        self.project = JsonSource(Path(prm["project"])).data
        run_dir = run_directory()
        if run_dir is not None:
            outputs_into(self.project, run_dir / "kratos" / self.name)
        self.by_name = {f["name"]: f for f in self.fields}
        quiet()
        set_threads(prm["threads"] or None)
        self._workdir = tempfile.TemporaryDirectory(prefix=f"cosim-kratos-{self.name}-")
        self.analysis = prm["analysis"]
        solver = self.project["solver_settings"]
        self.ale = solver.get("solver_type") == "ale_fluid"
        inner = solver["fluid_solver_settings"] if self.ale else solver
        self.part_name = inner["model_part_name"]
        self.static = self.analysis == "structural_mechanics" and solver.get("solver_type", "Static") == "Static"
        self.build()
        self.inputs = {f["name"]: np.zeros(self._shape(f)) for f in self.fields if f["role"] == "input"}

    def build(self, import_settings: dict[str, Any] | None = None) -> None:
        import KratosMultiphysics as KM
        if self.analysis == "fluid_dynamics":
            if self.ale:
                import KratosMultiphysics.MeshMovingApplication  # noqa: F401  (registers the mesh-motion solvers)
            from KratosMultiphysics.FluidDynamicsApplication.fluid_dynamics_analysis import (
                FluidDynamicsAnalysis as Analysis,
            )
        else:
            from KratosMultiphysics.StructuralMechanicsApplication.structural_mechanics_analysis import (
                StructuralMechanicsAnalysis as Analysis,
            )
        project = kratos_parameters(self.project)
        if import_settings is not None:
            target = project["solver_settings"]["fluid_solver_settings"] if self.ale else project["solver_settings"]
            target.RemoveValue("model_import_settings")
            target.AddValue("model_import_settings", kratos_parameters(import_settings))
        self.model = KM.Model()
        try:
            stage = Analysis(self.model, project)
            self.stepped = SteppedStage(self.name, stage, static=self.static, predict_first=True)
        except RuntimeError as exc:
            raise ComponentError(self.name, f"Kratos could not set up the stage: {_first_line(exc)}") from None
        self.KM = KM
        self.nodes: dict[str, Any] = {}
        self.kratos_variables: dict[str, Any] = {}
        for f in self.fields:
            try:
                part = self.model[f["model_part"]]
            except RuntimeError:
                raise ComponentError(self.name, f"data '{f['data']}': model part '{f['model_part']}' does not "
                                                "exist") from None
            if not KM.KratosGlobals.HasVariable(f["variable"]):
                raise ComponentError(self.name, f"data '{f['data']}': Kratos has no variable '{f['variable']}'")
            variable = KM.KratosGlobals.GetVariable(f["variable"])
            if f["location"] == "node_historical" and not part.HasNodalSolutionStepVariable(variable):
                raise ComponentError(self.name, f"data '{f['data']}': '{f['variable']}' is not a solution-step "
                                                f"variable of model part '{f['model_part']}'")
            self.nodes[f["name"]] = part.Nodes
            f["count"] = len(part.Nodes)
            self.kratos_variables[f["name"]] = variable

    @staticmethod
    def _shape(f: dict) -> tuple[int, ...]:
        return (f["count"], f["dimension"]) if f["dimension"] > 1 else (f["count"],)

    def variables(self) -> list[Variable]:
        result = []
        for f in self.fields:
            size = f["count"] * f["dimension"]
            result.append(Variable(f["name"], f["role"], size, "", mesh=f["model_part"],
                                   components=f["dimension"] if f["dimension"] > 1 else 1))
        return result

    def meshes(self) -> dict[str, np.ndarray]:
        dimension = max(int(self.project["solver_settings"].get("domain_size", 2)), 2)
        return {f["model_part"]: node_coordinates(self.nodes[f["name"]], dimension) for f in self.fields}

    def lines(self) -> dict[str, np.ndarray]:
        """Each field's model part's two-node conditions, as indices of its nodes (for ``nearest_element``)."""
        lines = {}
        for name in {f["model_part"] for f in self.fields}:
            part = self.model[name]
            index = {node.Id: i for i, node in enumerate(part.Nodes)}
            pairs = [[index.get(n.Id, -1) for n in c.GetNodes()] for c in part.Conditions if len(c.GetNodes()) == 2]
            pairs = [pair for pair in pairs if min(pair) >= 0]
            if pairs:
                lines[name] = np.array(pairs, dtype=np.int64)
        return lines

    def set_values(self, values: Mapping[str, np.ndarray]) -> None:
        check_inputs(self, values, {name: value.shape for name, value in self.inputs.items()})
        for name, value in values.items():
            self.inputs[name] = np.array(value, dtype=np.float64)

    def _write_inputs(self) -> None:
        for f in self.fields:
            if f["role"] == "input":
                self._write(f, self.inputs[f["name"]])

    def _write(self, f: dict, values: np.ndarray) -> None:
        KM, nodes, variable = self.KM, self.nodes[f["name"]], self.kratos_variables[f["name"]]
        utils = KM.VariableUtils()
        if f["dimension"] == 1 and values.ndim == 1 and isinstance(variable, KM.DoubleVariable):
            if f["location"] == "node_historical":
                utils.SetSolutionStepValuesVector(nodes, variable, KM.Vector(values), 0)
            else:
                utils.SetValuesVector(nodes, variable, KM.Vector(values))
            return
        full = np.zeros((len(nodes), 3))
        full[:, :f["dimension"]] = values.reshape(len(nodes), -1)
        if f["location"] == "node_historical":
            utils.SetSolutionStepValuesVector(nodes, variable, KM.Vector(full.ravel()), 0)
        else:
            utils.SetValuesVector(nodes, variable, KM.Vector(full.ravel()))

    def _read(self, f: dict) -> np.ndarray:
        KM, nodes, variable = self.KM, self.nodes[f["name"]], self.kratos_variables[f["name"]]
        utils = KM.VariableUtils()
        if isinstance(variable, KM.DoubleVariable):
            values = (utils.GetSolutionStepValuesVector(nodes, variable, 0) if f["location"] == "node_historical"
                      else utils.GetValuesVector(nodes, variable))
            return np.asarray(values, dtype=np.float64)
        if f["location"] == "node_historical":
            values = np.asarray(utils.GetSolutionStepValuesVector(nodes, variable, 0, 3)).reshape(-1, 3)
        else:
            values = np.asarray(utils.GetValuesVector(nodes, variable, 3)).reshape(-1, 3)
        values = values[:, :f["dimension"]]
        return values.copy() if f["dimension"] > 1 else values[:, 0].copy()

    def do_step(self, t: float, dt: float) -> None:
        self.stepped.solve(t, dt, self._write_inputs)

    def end_window(self, values: Mapping[str, np.ndarray]) -> None:
        """The window's last values of data Kratos writes after this solver's last solve (``at_window_end``): the
        step that ends holds them, as in Kratos (an ALE fluid's mesh velocity in the next window starts there)."""
        check_inputs(self, values, {name: value.shape for name, value in self.inputs.items()})
        if self.stepped.window_start is not None:
            for name, value in values.items():
                self._write(self.by_name[name], np.asarray(value, dtype=np.float64))

    def get_values(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        by_name = self.by_name
        unknown = [n for n in names if n not in by_name]
        if unknown:
            raise ComponentError(self.name, f"unknown variable(s) {', '.join(unknown)}")
        return {n: self.inputs[n].copy() if by_name[n]["role"] == "input" else self._read(by_name[n]) for n in names}

    # --- checkpoints: Kratos's restart serialisation (kratos_solvers.stage), the inputs by name ----------------
    def checkpoint(self) -> Any:
        self.input = np.zeros(0)
        state = super().checkpoint()
        del state["input"]
        state.update({f"input:{name}": value.copy() for name, value in self.inputs.items()})
        return state

    def restore_checkpoint(self, state: Any) -> None:
        self.input = np.zeros(0)
        super().restore_checkpoint({**state, "input": np.zeros(0)})
        self.inputs = {name: np.array(state[f"input:{name}"]) for name in self.inputs}

    def terminate(self) -> dict[str, np.ndarray]:
        final = {"unconverged_solves": np.array(self.stepped.unconverged)}
        self.close()
        return final


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip() and not line.startswith("in ")]
    return lines[0] if lines else type(exc).__name__


# where Kratos's output processes write, by the key of their Parameters, and the default a process takes without it
OUTPUT_KEYS = {"output_path": "VTK_Output", "output_name": None, "output_file_name": None}


def outputs_into(project: dict[str, Any], folder: Path) -> list[str]:
    """Point the stage's output processes (``output_processes``: VTK, VTU, GiD, ...) into ``folder`` (the run's
    ``kratos/<solver>/``), so that two runs of one case never write over each other's files; relative paths keep
    their names under it, absolute ones are left as the user gave them. Returns the paths it set."""
    moved: list[str] = []
    outputs = project.get("output_processes")
    if not isinstance(outputs, dict):
        return moved
    for processes in outputs.values():
        for process in processes if isinstance(processes, list) else []:
            parameters = process.get("Parameters") if isinstance(process, dict) else None
            if not isinstance(parameters, dict):
                continue
            module = str(process.get("python_module", ""))
            for key, default in OUTPUT_KEYS.items():
                given = parameters.get(key, default if ("vtk" in module or "vtu" in module) else None)
                if isinstance(given, str) and not Path(given).is_absolute():
                    parameters[key] = str(folder / given)
                    (folder / given).parent.mkdir(parents=True, exist_ok=True)
                    moved.append(parameters[key])
    return moved
