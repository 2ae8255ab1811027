"""A Kratos ``ProjectParametersCoSim.json`` read and checked: its solvers, their data, the coupling sequence and the
coupled solver's accelerators, criteria, predictors and data transfer operators.

Only what cosim can run the way Kratos's CoSimulationApplication means it is accepted; anything else is refused
at load, in one line naming the file, the line and the key path, and what is supported
(``docs/kratos.md`` has the table).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cosim.errors import SceneError
from cosim.scene import MAX_THREADS_PER_CORE
from kratos_compat.json_source import JsonSource, Path_

COUPLED_SOLVERS = {"coupled_solvers.gauss_seidel_strong": "serial-implicit",
                   "coupled_solvers.gauss_seidel_weak": "serial-explicit",
                   "coupled_solvers.jacobi_strong": "parallel-implicit",
                   "coupled_solvers.jacobi_weak": "parallel-explicit"}
WRAPPERS = {"solver_wrappers.kratos.fluid_dynamics_wrapper": "fluid_dynamics",
            "solver_wrappers.kratos.structural_mechanics_wrapper": "structural_mechanics"}
# each accelerator: its settings with their defaults (Kratos's), and the cosim plug-in it becomes
ACCELERATORS: dict[str, dict[str, Any]] = {
    "constant_relaxation": {"alpha": 0.125},
    "aitken": {"init_alpha": 0.1, "init_alpha_max": 0.45, "alpha_max": 2.0, "alpha_min": -2.0},
    "iqnils": {"iteration_horizon": 20, "timestep_horizon": 1, "alpha": 0.125},
    "mvqn": {"horizon": 15, "alpha": 0.125},
}
REFUSED_ACCELERATORS = {"anderson": "Anderson acceleration", "block_mvqn": "a block accelerator",
                        "block_ibqnls": "a block accelerator", "ibqnls": "a block accelerator"}
CRITERIA = {"relative_norm_previous_residual": {"abs_tolerance": 1e-5, "rel_tolerance": 1e-5, "label": ""},
            "relative_norm_initial_residual": {"abs_tolerance": 1e-5, "rel_tolerance": 1e-5, "label": ""}}
PREDICTORS: dict[str, dict[str, Any]] = {"linear": {}}
REFUSED_PREDICTORS = ("average_value_based", "linear_derivative_based")
MAPPERS = ("nearest_neighbor", "nearest_element")
TRANSFER_OPTIONS = {"kratos_mapping": ("swap_sign", "use_transpose"), "copy": ("swap_sign",)}
LOCATIONS = ("node_historical", "node_non_historical")
COMMON = {"type", "solver", "data_name", "echo_level", "label"}




@dataclass
class Data:
    """One entry of a solver's ``data``: a Kratos variable on a model part."""

    solver: str
    name: str
    model_part: str
    variable: str
    dimension: int
    location: str
    where: str            # the entry in the file, for messages


@dataclass
class Solver:
    """A solver wrapper: the analysis stage it runs, its own ProjectParameters, its data."""

    name: str
    analysis: str                 # fluid_dynamics, structural_mechanics
    project: Path                 # its ProjectParameters file
    threads: int | None
    data: dict[str, Data] = field(default_factory=dict)


@dataclass
class Transfer:
    """Data going from one solver's entry to another's through a data transfer operator."""

    source: Data
    target: Data
    operator: str                 # copy, kratos_mapping
    mapper: str                   # the mapper type of kratos_mapping ("" for copy)
    mapper_settings: dict[str, Any]
    options: tuple[str, ...]
    where: str
    after_source: bool = False    # in the source's output_data_list: done right after the source solves


@dataclass
class Role:
    """An accelerator, criterion or predictor: its type, settings, and the data it acts on."""

    type: str
    settings: dict[str, Any]
    data: Data
    where: str


@dataclass
class CoSimParameters:
    """A checked ``ProjectParametersCoSim.json``."""

    source: JsonSource
    folder: Path                  # where Kratos would run: relative paths in the files start here
    scheme: str
    start: float
    end: float
    max_iterations: int
    sequence: list[str]
    solvers: dict[str, Solver]
    transfers: list[Transfer]
    accelerators: list[Role]
    criteria: list[Role]
    predictors: list[Role]


def read_cosim_parameters(path: Path, folder: Path | None = None) -> CoSimParameters:
    """Read and check ``path``; ``folder``: the working directory Kratos would run in (default: the file's)."""
    source = JsonSource(path)
    return _Reader(source, Path(folder or source.path.parent).resolve()).read()


class _Reader:
    def __init__(self, source: JsonSource, folder: Path):
        self.source = source
        self.folder = folder

    def fail(self, path: Path_, message: str) -> SceneError:
        return SceneError(f"{self.source.where(path)}: {message}")

    def get(self, table: dict, path: Path_, key: str, kind: type | tuple, default: Any = ...) -> Any:
        if key not in table:
            if default is ...:
                raise self.fail((*path, key), "is missing")
            return default
        value = table[key]
        kinds = kind if isinstance(kind, tuple) else (kind,)
        if float in kinds and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if isinstance(value, bool) and bool not in kinds or not isinstance(value, kinds):
            names = " or ".join({str: "a string", int: "an integer", float: "a number", list: "a list",
                                 dict: "an object", bool: "true or false"}[k] for k in kinds)
            raise self.fail((*path, key), f"must be {names}, got {value!r}")
        return value

    def only(self, table: dict, path: Path_, allowed: set[str] | dict, what: str) -> None:
        for key in table:
            if key not in allowed:
                raise self.fail((*path, key), f"is not a setting of {what} (its settings: "
                                              f"{', '.join(sorted(allowed))})")

    def read(self) -> CoSimParameters:
        data = self.source.data
        self.only(data, (), {"problem_data", "solver_settings"}, "a CoSimulation parameters file")
        problem = self.get(data, (), "problem_data", dict)
        start = self.get(problem, ("problem_data",), "start_time", float, 0.0)
        end = self.get(problem, ("problem_data",), "end_time", float)
        if not (math.isfinite(start) and math.isfinite(end)):
            raise self.fail(("problem_data", "end_time" if math.isfinite(start) else "start_time"),
                            "must be a finite time")
        if not end > start:
            raise self.fail(("problem_data", "end_time"), f"{end} is not after start_time {start}")
        settings = self.get(data, (), "solver_settings", dict)
        at = ("solver_settings",)
        kind = self.get(settings, at, "type", str)
        if kind not in COUPLED_SOLVERS:
            raise self.fail((*at, "type"), f"'{kind}' is not supported (supported: {', '.join(COUPLED_SOLVERS)})")
        scheme = COUPLED_SOLVERS[kind]
        allowed = {"type", "echo_level", "num_coupling_iterations", "predictors", "convergence_accelerators",
                   "convergence_criteria", "data_transfer_operators", "coupling_sequence", "solvers",
                   "coupling_operations"}
        self.only(settings, at, allowed, f"'{kind}'")
        if self.get(settings, at, "coupling_operations", dict, {}):
            raise self.fail((*at, "coupling_operations"), "coupling operations are not supported by cosim")
        implicit = scheme.endswith("implicit")
        iterations = self.get(settings, at, "num_coupling_iterations", int, 10)
        if iterations < 1:
            raise self.fail((*at, "num_coupling_iterations"), f"must be at least 1, got {iterations}")
        solvers = {name: self.solver(name, spec) for name, spec in self.get(settings, at, "solvers", dict).items()}
        if len(solvers) != 2:
            raise self.fail((*at, "solvers"), f"cosim couples two solvers; the file has {len(solvers)}")
        operators = self.operators(self.get(settings, at, "data_transfer_operators", dict, {}))
        sequence, transfers = self.sequence(self.get(settings, at, "coupling_sequence", list), solvers, operators)
        roles = {}
        for key, known, refused in (("convergence_accelerators", ACCELERATORS, REFUSED_ACCELERATORS),
                                    ("convergence_criteria", CRITERIA, {}),
                                    ("predictors", PREDICTORS, dict.fromkeys(REFUSED_PREDICTORS, "a predictor"))):
            items = self.get(settings, at, key, list, [])
            if items and not implicit and key != "predictors":
                raise self.fail((*at, key), f"'{kind}' iterates once a window: it takes no {key.replace('_', ' ')}")
            roles[key] = [self.role((*at, key, i), item, known, refused, solvers) for i, item in enumerate(items)]
        if implicit and not roles["convergence_criteria"]:
            raise self.fail((*at, "convergence_criteria"), f"'{kind}' needs at least one convergence criterion")
        return CoSimParameters(self.source, self.folder, scheme, start, end, iterations, sequence, solvers,
                               transfers, roles["convergence_accelerators"], roles["convergence_criteria"],
                               roles["predictors"])

    def solver(self, name: str, spec: Any) -> Solver:
        at: Path_ = ("solver_settings", "solvers", name)
        if not isinstance(spec, dict):
            raise self.fail(at, "must be an object")
        self.only(spec, at, {"type", "solver_wrapper_settings", "data", "echo_level", "io_settings"},
                  "a solver wrapper")
        kind = self.get(spec, at, "type", str)
        if kind not in WRAPPERS:
            raise self.fail((*at, "type"), f"'{kind}' is not a supported solver wrapper (supported: "
                                           f"{', '.join(WRAPPERS)})")
        if self.get(spec, at, "io_settings", dict, {}).get("type", "kratos_io") not in ("kratos_io", "dummy_io"):
            raise self.fail((*at, "io_settings", "type"), "only Kratos solvers in this run are supported")
        wrapper = self.get(spec, at, "solver_wrapper_settings", dict)
        self.only(wrapper, (*at, "solver_wrapper_settings"), {"input_file", "num_threads"}, "a Kratos solver wrapper")
        given = self.get(wrapper, (*at, "solver_wrapper_settings"), "input_file", str)
        project = self.folder / (given if given.endswith(".json") else given + ".json")
        if not project.is_file():
            raise self.fail((*at, "solver_wrapper_settings", "input_file"),
                            f"'{project}' is not a regular file" if project.exists() else
                            f"'{project}' does not exist (paths are relative to {self.folder})")
        threads = self.get(wrapper, (*at, "solver_wrapper_settings"), "num_threads", int, None)
        most = MAX_THREADS_PER_CORE * (os.cpu_count() or 1)
        if threads is not None and not 1 <= threads <= most:
            raise self.fail((*at, "solver_wrapper_settings", "num_threads"),
                            f"{threads} threads; from 1 to {most} ({MAX_THREADS_PER_CORE} a core of this machine's "
                            f"{os.cpu_count() or 1}: Kratos dies at start with far more)")
        solver = Solver(name, WRAPPERS[kind], project, threads)
        parts = model_parts(project, self.folder)
        for data_name, entry in self.get(spec, at, "data", dict).items():
            solver.data[data_name] = self.data(solver, data_name, entry, parts)
        return solver

    def data(self, solver: Solver, name: str, entry: Any, parts: set[str] | None) -> Data:
        at: Path_ = ("solver_settings", "solvers", solver.name, "data", name)
        if not isinstance(entry, dict):
            raise self.fail(at, "must be an object")
        if not name or "." in name or " " in name:
            raise self.fail(at, "a data name must be non-empty, without '.' or spaces")
        self.only(entry, at, {"model_part_name", "variable_name", "dimension", "location", "additional_info"},
                  "a data entry")
        part = self.get(entry, at, "model_part_name", str)
        if parts is not None and part not in parts:
            raise self.fail((*at, "model_part_name"), f"model part '{part}' does not exist in {solver.name}'s mesh "
                                                      f"(it has: {', '.join(sorted(parts))})")
        variable = self.get(entry, at, "variable_name", str)
        if not variable.isidentifier() or not variable.isupper():
            raise self.fail((*at, "variable_name"), f"'{variable}' is not a Kratos variable name")
        dimension = self.get(entry, at, "dimension", int, 1)
        if dimension not in (1, 2, 3):
            raise self.fail((*at, "dimension"), f"must be 1, 2 or 3, got {dimension}")
        location = self.get(entry, at, "location", str, "node_historical")
        if location not in LOCATIONS:
            raise self.fail((*at, "location"), f"'{location}' is not supported (supported: {', '.join(LOCATIONS)})")
        return Data(solver.name, name, part, variable, dimension, location, self.source.where(at))

    def operators(self, table: dict) -> dict[str, tuple[str, str, dict[str, Any]]]:
        result = {}
        for name, spec in table.items():
            at: Path_ = ("solver_settings", "data_transfer_operators", name)
            if not isinstance(spec, dict):
                raise self.fail(at, "must be an object")
            kind = self.get(spec, at, "type", str)
            if kind not in TRANSFER_OPTIONS:
                raise self.fail((*at, "type"), f"'{kind}' is not supported (supported: {', '.join(TRANSFER_OPTIONS)})")
            mapper = ""
            if kind == "kratos_mapping":
                self.only(spec, at, {"type", "mapper_settings", "echo_level"}, "kratos_mapping")
                settings = self.get(spec, at, "mapper_settings", dict)
                mapper = self.get(settings, (*at, "mapper_settings"), "mapper_type", str)
                if mapper not in MAPPERS:
                    raise self.fail((*at, "mapper_settings", "mapper_type"),
                                    f"'{mapper}' is not supported (supported: {', '.join(MAPPERS)})")
                allowed = {"mapper_type", "echo_level", "search_settings"}
                if mapper == "nearest_element":
                    allowed.add("local_coord_tolerance")
                    tolerance = self.get(settings, (*at, "mapper_settings"), "local_coord_tolerance", float, 0.25)
                    if not tolerance >= 0:
                        raise self.fail((*at, "mapper_settings", "local_coord_tolerance"),
                                        f"must be at least 0, got {tolerance}")
                self.only(settings, (*at, "mapper_settings"), allowed, f"the {mapper} mapper")
                extra = {"local_coordinate_tolerance": float(settings.get("local_coord_tolerance", 0.25))} \
                    if mapper == "nearest_element" else {}
            else:
                self.only(spec, at, {"type", "echo_level"}, "copy")
                extra = {}
            result[name] = (kind, mapper, extra)
        return result

    def sequence(self, items: list, solvers: dict[str, Solver],
                 operators: dict[str, tuple[str, str, dict[str, Any]]]) -> tuple[list[str], list[Transfer]]:
        at: Path_ = ("solver_settings", "coupling_sequence")
        order, transfers = [], []
        for i, item in enumerate(items):
            here = (*at, i)
            if not isinstance(item, dict):
                raise self.fail(here, "must be an object")
            self.only(item, here, {"name", "input_data_list", "output_data_list"}, "a coupling sequence entry")
            name = self.get(item, here, "name", str)
            if name not in solvers:
                raise self.fail((*here, "name"), f"no solver '{name}' (solvers: {', '.join(solvers)})")
            if name in order:
                raise self.fail((*here, "name"), f"solver '{name}' is in the sequence twice")
            order.append(name)
            for key, other_key, other_data in (("input_data_list", "from_solver", "from_solver_data"),
                                               ("output_data_list", "to_solver", "to_solver_data")):
                for j, entry in enumerate(self.get(item, here, key, list, [])):
                    transfers.append(self.transfer((*here, key, j), entry, name, other_key, other_data,
                                                   key == "input_data_list", solvers, operators))
        missing = [name for name in solvers if name not in order]
        if missing:
            raise self.fail(at, f"solver '{missing[0]}' is not in the coupling sequence")
        return order, transfers

    def transfer(self, at: Path_, entry: Any, solver: str, other_key: str, other_data: str, incoming: bool,
                 solvers: dict[str, Solver], operators: dict[str, tuple[str, str, dict[str, Any]]]) -> Transfer:
        if not isinstance(entry, dict):
            raise self.fail(at, "must be an object")
        self.only(entry, at, {"data", other_key, other_data, "data_transfer_operator",
                              "data_transfer_operator_options", "before_data_transfer_operations",
                              "after_data_transfer_operations", "interval"}, "a data list entry")
        for key in ("before_data_transfer_operations", "after_data_transfer_operations"):
            if self.get(entry, at, key, list, []):
                raise self.fail((*at, key), "coupling operations are not supported by cosim")
        interval = self.get(entry, at, "interval", list, [0.0, 1e30])
        numbers = [isinstance(v, int | float) and not isinstance(v, bool) for v in interval]
        if len(interval) != 2 or not numbers[0] or not (numbers[1] or interval[1] == "End"):
            raise self.fail((*at, "interval"), f"must be [start, end] of numbers (end may be \"End\"), got {interval}")
        if interval != [0.0, 1e30] and not (interval[0] <= 0 and (interval[1] == "End" or interval[1] >= 1e30)):
            raise self.fail((*at, "interval"), "a transfer for part of the run is not supported (only the whole run)")
        own = self.lookup(solvers, solver, self.get(entry, at, "data", str), (*at, "data"))
        other_name = self.get(entry, at, other_key, str)
        if other_name not in solvers:
            raise self.fail((*at, other_key), f"no solver '{other_name}' (solvers: {', '.join(solvers)})")
        if other_name == solver:
            raise self.fail((*at, other_key), "a solver's data cannot go to the same solver")
        other = self.lookup(solvers, other_name, self.get(entry, at, other_data, str), (*at, other_data))
        operator = self.get(entry, at, "data_transfer_operator", str)
        if operator not in operators:
            raise self.fail((*at, "data_transfer_operator"), f"no data transfer operator '{operator}' "
                                                             f"(defined: {', '.join(operators) or 'none'})")
        kind, mapper, mapper_settings = operators[operator]
        options = self.get(entry, at, "data_transfer_operator_options", list, [])
        for k, option in enumerate(options):
            if option not in TRANSFER_OPTIONS[kind]:
                raise self.fail((*at, "data_transfer_operator_options", k),
                                f"'{option}' is not supported for {kind} (supported: "
                                f"{', '.join(TRANSFER_OPTIONS[kind])}; add_values and distribute_values are not)")
        source, target = (other, own) if incoming else (own, other)
        if source.dimension != target.dimension:
            raise self.fail(at, f"'{source.solver}.{source.name}' has dimension {source.dimension} and "
                                f"'{target.solver}.{target.name}' has {target.dimension}: {kind} cannot map "
                                "between them")
        return Transfer(source, target, kind, mapper, mapper_settings, tuple(options), self.source.where(at),
                        not incoming)

    def lookup(self, solvers: dict[str, Solver], solver: str, name: str, at: Path_) -> Data:
        if name not in solvers[solver].data:
            raise self.fail(at, f"solver '{solver}' has no data '{name}' (it has: "
                                f"{', '.join(solvers[solver].data) or 'none'})")
        return solvers[solver].data[name]

    def role(self, at: Path_, item: Any, known: dict[str, dict], refused: dict[str, str],
             solvers: dict[str, Solver]) -> Role:
        if not isinstance(item, dict):
            raise self.fail(at, "must be an object")
        kind = self.get(item, at, "type", str)
        if kind in refused:
            raise self.fail((*at, "type"), f"'{kind}' ({refused[kind]}) is not supported (supported: "
                                           f"{', '.join(known)})")
        if kind not in known:
            raise self.fail((*at, "type"), f"'{kind}' is not supported (supported: {', '.join(known)})")
        defaults = known[kind]
        self.only(item, at, COMMON | set(defaults), f"'{kind}'")
        settings = {}
        for key, default in defaults.items():
            kind_of = type(default) if not isinstance(default, float) else float
            settings[key] = self.get(item, at, key, kind_of, default)
            if isinstance(settings[key], float) and not math.isfinite(settings[key]):
                raise self.fail((*at, key), "must be finite")
        for key in ("iteration_horizon", "timestep_horizon", "horizon"):
            if key in settings and settings[key] < 1:
                raise self.fail((*at, key), f"must be at least 1, got {settings[key]}")
        if "alpha" in settings and not settings["alpha"] > 0:
            raise self.fail((*at, "alpha"), f"must be positive, got {settings['alpha']}")
        solver = self.get(item, at, "solver", str)
        if solver not in solvers:
            raise self.fail((*at, "solver"), f"no solver '{solver}' (solvers: {', '.join(solvers)})")
        data = self.lookup(solvers, solver, self.get(item, at, "data_name", str), (*at, "data_name"))
        return Role(kind, settings, data, self.source.where(at))


def model_parts(project: Path, folder: Path) -> set[str] | None:
    """The model parts a solver's ProjectParameters and its ``.mdpa`` file define (``Main``, ``Main.Sub``, ...);
    None when they cannot be told without Kratos (a mesh in another format)."""
    source = JsonSource(project)
    at: tuple[str, ...] = ("solver_settings",)
    source.typed(at, dict, {})
    if source.typed((*at, "solver_type"), str, "") == "ale_fluid":
        at = (*at, "fluid_solver_settings")
    main = source.typed((*at, "model_part_name"), str, "")
    if not main or source.typed((*at, "model_import_settings", "input_type"), str, "mdpa") != "mdpa":
        return None
    mesh = folder / (source.typed((*at, "model_import_settings", "input_filename"), str, "") + ".mdpa")
    if not mesh.is_file():
        raise SceneError(f"{project}: 'solver_settings.model_import_settings.input_filename': '{mesh}' does not exist")
    names, stack = {main}, [main]
    with mesh.open(encoding="utf-8", errors="replace") as lines:
        for line in lines:
            words = line.split()
            if len(words) >= 3 and words[0] == "Begin" and words[1] == "SubModelPart":
                stack.append(words[2])
                names.add(".".join(stack))
            elif len(words) >= 2 and words[0] == "End" and words[1] == "SubModelPart" and len(stack) > 1:
                stack.pop()
    return names
