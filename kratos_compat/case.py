"""A Kratos CoSimulation case as a cosim scene: ``CASE.toml`` names the ``ProjectParametersCoSim.json``; each solver
wrapper becomes a component running Kratos's own analysis stage from its unmodified ProjectParameters
(``kratos_compat.stage_component``), and the coupled solver's settings become the scene's coupling.

```toml
[kratos]
cosim = "ProjectParametersCoSim.json"    # relative to CASE.toml
folder = ""                              # where Kratos would run (default: the file's folder)

[solvers.structure]                      # optional, per solver wrapper
timeout = 120.0
```

What each CoSimulation setting becomes (``docs/kratos.md``):

- ``gauss_seidel_strong`` / ``_weak``: serial-implicit / -explicit, the coupling sequence's order;
  ``jacobi_strong`` / ``_weak``: parallel-implicit / -explicit. ``num_coupling_iterations``: ``max_iterations``,
  and a window that does not converge is accepted (Kratos moves on).
- A transfer of data (an ``input_data_list`` or ``output_data_list`` entry): an exchange named after the data it
  fills; ``copy``: the identity; ``kratos_mapping`` ``nearest_neighbor``: nearest-neighbour, consistent, or
  conservative with ``use_transpose``; ``nearest_element``: nearest-element, the same way; ``swap_sign``: the
  exchange's scale -1.
- Accelerators: ``constant_relaxation``: constant, ``aitken``: kratos-aitken, ``iqnils``: kratos-iqn-ils,
  ``mvqn``: kratos-mvqn (the same updates, tested against Kratos's own classes).
- Criteria: ``relative_norm_previous_residual``: any of absolute-rms and relative; ``relative_norm_initial_residual``:
  any of absolute-rms and residual-relative; all criteria must hold.
- Predictors: ``linear`` on the accelerated data: extrapolation order 0, as it acts in Kratos (it reads a
  buffer the solvers' advance in time has just filled with the last window's values).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from cosim.errors import SceneError
from cosim.scene import MAX_WINDOWS
from cosim.schema import AnyTable, Positive, unknown_key_message, validate
from kratos_compat.cosim_parameters import CoSimParameters, Data, Role, Transfer, read_cosim_parameters
from kratos_compat.json_source import JsonSource

ENTRY = "kratos_compat.stage_component:KratosStage"
CASE = {"kratos": {"cosim": "", "folder": ""}, "solvers": AnyTable(), "name": "", "output": AnyTable()}
SOLVER = {"timeout": Positive(600.0), "startup_timeout": Positive(120.0), "record": True}
CASE_KEYS = ("kratos", "solvers")


def scene_of(params: CoSimParameters, solvers: dict[str, dict[str, Any]] | None = None, name: str = "") -> dict:
    """The scene ``params`` becomes; ``solvers``: the case's own settings of each solver's component."""
    solvers = solvers or {}
    start, dt = params.start, _time_step(params)
    if (params.end - start) / dt > MAX_WINDOWS:
        raise SceneError(f"{params.source.where(('problem_data', 'end_time'))}: {params.end:g} makes "
                         f"{(params.end - start) / dt:.3g} windows of {dt:g} s; at most {MAX_WINDOWS:,} are allowed")
    windows, t = 0, start
    while t < params.end:          # Kratos steps while its time is before end_time
        t += dt
        windows += 1
    exchanges, fields = _exchanges(params)
    components = {}
    for solver_name, solver in params.solvers.items():
        spec = validate(solvers.get(solver_name, {}), SOLVER, f"solvers.{solver_name}.")
        components[solver_name] = {
            "entry": ENTRY, "record": spec["record"], "timeout": spec["timeout"],
            "startup_timeout": spec["startup_timeout"], "threads": solver.threads or 1,
            "parameters": {"solver": solver_name, "analysis": solver.analysis, "project": str(solver.project),
                           "folder": str(params.folder), "threads": 0, "fields": list(fields[solver_name].values()),
                           "inputs": solver_inputs(solver.project, params.folder)}}
    coupling: dict[str, Any] = {"scheme": params.scheme, "participants": list(params.sequence),
                                "max_iterations": params.max_iterations, "on_max_iterations": "accept"}
    if params.scheme.endswith("implicit"):
        accelerated = _accelerated(params, exchanges)
        coupling["acceleration"] = _acceleration(params, accelerated)
        coupling["convergence"] = [_measure(params, role, exchanges, accelerated) for role in params.criteria]
    elif params.predictors:
        raise SceneError(f"{params.predictors[0].where}: '{params.scheme}' takes no predictor in cosim")
    if params.predictors:
        _check_predictors(params, exchanges, accelerated)
        coupling["extrapolation_order"] = 0
    return {"name": name or f"Kratos case {params.source.path.name}",
            "time": {"start": start, "end": start + windows * dt, "dt": dt},
            "components": components, "exchange": [spec for spec, _ in exchanges], "coupling": coupling,
            "output": {"plot_field": exchanges[0][0]["data"] if exchanges else ""}}


def solver_inputs(project: Path, folder: Path) -> dict[str, str]:
    """The files a solver reads (its ProjectParameters, its materials, its .mdpa mesh), by label: the scene names
    them, so a resumed run checks that none changed (``components.<name>.parameters.inputs``)."""
    source = JsonSource(project)
    at: tuple[str, ...] = ("solver_settings",)
    if source.typed((*at, "solver_type"), str, "") == "ale_fluid":
        at = (*at, "fluid_solver_settings")
    files = {"project": project,
             "materials": folder / source.typed((*at, "material_import_settings", "materials_filename"), str, ""),
             "mesh": folder / (source.typed((*at, "model_import_settings", "input_filename"), str, "") + ".mdpa")}
    return {label: str(path.resolve()) for label, path in files.items() if path.is_file()}


def _time_step(params: CoSimParameters) -> float:
    """The solvers' common time step (each ProjectParameters' ``time_stepping.time_step``)."""
    steps = {}
    for solver in params.solvers.values():
        source = JsonSource(solver.project)
        path: tuple[str, ...] = ("solver_settings",)
        source.typed(path, dict, {})
        if source.typed((*path, "solver_type"), str, "") == "ale_fluid":
            path = (*path, "fluid_solver_settings")
        stepping = source.typed((*path, "time_stepping"), dict, {})
        if source.typed((*path, "time_stepping", "automatic_time_step"), bool, False):
            raise SceneError(f"{source.where((*path, 'time_stepping', 'automatic_time_step'))}: an automatic time "
                             "step is not supported (the coupling needs a fixed window)")
        step = stepping.get("time_step")
        if not isinstance(step, int | float) or isinstance(step, bool) or not step > 0 or not math.isfinite(step):
            raise SceneError(f"{source.where((*path, 'time_stepping', 'time_step'))}: must be a positive number, "
                             f"got {step!r}")
        steps[solver.name] = float(step)
    values = set(steps.values())
    if len(values) != 1:
        raise SceneError(f"{params.source.path}: the solvers' time steps differ "
                         f"({', '.join(f'{k}: {v:g} s' for k, v in steps.items())}); cosim couples them window by "
                         "window")
    return values.pop()


def _exchanges(params: CoSimParameters) -> tuple[list[tuple[dict, Transfer]], dict[str, dict[str, dict]]]:
    """One exchange per transfer, named after the data it fills; each solver's fields by variable name."""
    exchanges: list[tuple[dict, Transfer]] = []
    fields: dict[str, dict[str, dict]] = {name: {} for name in params.solvers}
    names: dict[str, Transfer] = {}
    for transfer in params.transfers:
        name = transfer.target.name
        if name in names:
            other = names[name]
            if (other.source, other.target) == (transfer.source, transfer.target):
                raise SceneError(f"{transfer.where}: '{transfer.source.solver}.{transfer.source.name}' goes to "
                                 f"'{transfer.target.solver}.{transfer.target.name}' twice")
            name = f"{transfer.target.name}_{transfer.target.solver}"
        names[name] = transfer
        for data, role in ((transfer.source, "output"), (transfer.target, "input")):
            field = {"name": name, "data": data.name, "model_part": data.model_part, "variable": data.variable,
                     "dimension": data.dimension, "location": data.location, "role": role}
            known = fields[data.solver].get(name)
            if known is not None and known != field:
                raise SceneError(f"{transfer.where}: '{data.solver}.{data.name}' would be read and written in one "
                                 "coupling; cosim's exchanges go one way")
            if any(f["data"] == data.name and f["role"] != role for f in fields[data.solver].values()):
                raise SceneError(f"{transfer.where}: '{data.solver}.{data.name}' is both read and written by the "
                                 "coupling; cosim's exchanges go one way")
            fields[data.solver][name] = field
        mapping: dict[str, Any]
        if transfer.operator == "copy":
            mapping = {"type": "identity"}
        else:
            kind = "nearest-neighbour" if transfer.mapper == "nearest_neighbor" else "nearest-element"
            mapping = {"type": kind, **transfer.mapper_settings,
                       "constraint": "conservative" if "use_transpose" in transfer.options else "consistent"}
        spec = {"data": name, "from": transfer.source.solver, "to": transfer.target.solver, "mapping": mapping,
                "scale": -1.0 if "swap_sign" in transfer.options else 1.0,
                "at_window_end": _written_at_window_end(params, transfer)}
        exchanges.append((spec, transfer))
    for solver in params.solvers.values():       # data no transfer uses: recorded with every call, not exchanged
        used = {f["data"] for f in fields[solver.name].values()}
        for data in solver.data.values():
            if data.name not in used and data.name not in fields[solver.name]:
                fields[solver.name][data.name] = {
                    "name": data.name, "data": data.name, "model_part": data.model_part, "variable": data.variable,
                    "dimension": data.dimension, "location": data.location, "role": "local"}
    return exchanges, fields


def _written_at_window_end(params: CoSimParameters, transfer: Transfer) -> bool:
    """Whether Kratos writes ``transfer`` into its target after the target's last solve of a window (a Gauss-Seidel
    transfer back to an earlier solver, or any Jacobi transfer, done in the source's output list): the target then
    ends the window holding a value it did not solve with, and its history (an ALE mesh's) keeps it."""
    if not transfer.after_source:
        return False
    if params.scheme.startswith("parallel"):
        return True
    return params.sequence.index(transfer.source.solver) > params.sequence.index(transfer.target.solver)


def _exchange_of(data: Data, exchanges: list[tuple[dict, Transfer]], where: str) -> tuple[str, str]:
    """The exchange ``data`` is an end of, and which end ("target" or "source"; the target when both)."""
    for end in ("target", "source"):
        for spec, transfer in exchanges:
            if getattr(transfer, end) == data:
                return spec["data"], end
    raise SceneError(f"{where}: '{data.solver}.{data.name}' is not transferred between the solvers")


def _accelerated(params: CoSimParameters, exchanges: list) -> tuple[list[str], dict[str, str]]:
    """The exchanges the accelerators act on, and the end of each they sit on."""
    accelerated, ends = [], {}
    for role in params.accelerators:
        name, end = _exchange_of(role.data, exchanges, role.where)
        spec = next(s for s, _ in exchanges if s["data"] == name)
        if params.scheme == "serial-implicit" and (spec["from"], spec["to"]) != tuple(reversed(params.sequence)):
            raise SceneError(f"{role.where}: '{role.data.solver}.{role.data.name}' goes from '{spec['from']}' to "
                             f"'{spec['to']}'; in a Gauss-Seidel sequence ({', '.join(params.sequence)}) only data "
                             f"going back to '{params.sequence[0]}' can be accelerated")
        accelerated.append(name)
        ends[name] = end
    if len(params.accelerators) > 1:
        kinds = {(r.type, tuple(sorted(r.settings.items()))) for r in params.accelerators}
        if len(kinds) > 1 or params.accelerators[0].type != "constant_relaxation":
            raise SceneError(f"{params.accelerators[1].where}: more than one accelerator is supported only as the "
                             "same constant relaxation on each data (cosim accelerates the data as one system)")
    return accelerated, ends


def _acceleration(params: CoSimParameters, accelerated: tuple[list[str], dict[str, str]]) -> dict[str, Any]:
    names, _ = accelerated
    if not params.accelerators:
        return {"type": "none"}
    role = params.accelerators[0]
    s = role.settings
    if role.type == "constant_relaxation":
        if not 0 < s["alpha"] <= 1:
            raise SceneError(f"{role.where}: 'alpha' {s['alpha']} is outside (0, 1], which cosim's constant "
                             "relaxation takes")
        table = {"type": "constant", "relaxation": s["alpha"]}
    elif role.type == "aitken":
        table = {"type": "kratos-aitken", "initial_relaxation": s["init_alpha"],
                 "initial_relaxation_max": s["init_alpha_max"], "relaxation_min": s["alpha_min"],
                 "relaxation_max": s["alpha_max"]}
    elif role.type == "iqnils":
        table = {"type": "kratos-iqn-ils", "initial_relaxation": s["alpha"],
                 "iteration_horizon": s["iteration_horizon"], "timestep_horizon": s["timestep_horizon"]}
    else:
        table = {"type": "kratos-mvqn", "initial_relaxation": s["alpha"], "horizon": s["horizon"]}
    return {**table, "data": names}


def _measure(params: CoSimParameters, role: Role, exchanges: list,
             accelerated: tuple[list[str], dict[str, str]]) -> dict[str, Any]:
    names, ends = accelerated
    name, at = _exchange_of(role.data, exchanges, role.where)
    if name in ends and at != ends[name]:
        raise SceneError(f"{role.where}: the criterion is on the {at} of '{name}' and the accelerator on its "
                         f"{ends[name]}; put both on the same data (Kratos would measure another residual)")
    s = role.settings
    relative = "relative" if role.type == "relative_norm_previous_residual" else "residual-relative"
    return {"data": name, "type": "any-of", "measures": [{"type": "absolute-rms", "limit": s["abs_tolerance"]},
                                                         {"type": relative, "limit": s["rel_tolerance"]}]}


def _check_predictors(params: CoSimParameters, exchanges: list, accelerated: tuple[list[str], dict[str, str]]) -> None:
    """Predictors on the accelerated data only. Kratos's ``linear`` predicts 2 d(0) - d(1) from the nodal buffer
    right after the solvers advanced in time, which copied the last window's values into d(0): it predicts the
    last window's value (measured: ``benchmarks.kratos_case``), which is cosim's extrapolation order 0."""
    names, _ = accelerated
    for role in params.predictors:
        name, _ = _exchange_of(role.data, exchanges, role.where)
        if name not in names:
            raise SceneError(f"{role.where}: a predictor on '{role.data.solver}.{role.data.name}', which is not "
                             "accelerated, is not supported (cosim predicts the accelerated data)")


def read_case(path: Path, raw: dict[str, Any]) -> tuple[dict[str, Any], str]:
    """The scene of a ``CASE.toml`` with a ``[kratos]`` table (``raw``: its tables, --set applied to its keys)."""
    for key in raw:
        if key not in CASE:
            raise SceneError(unknown_key_message(key, "", sorted(CASE), str(path)))
    case = validate(raw, CASE, "", str(path))
    if not case["kratos"]["cosim"]:
        raise SceneError(f"{path}: 'kratos.cosim' names no ProjectParametersCoSim.json")
    cosim_file = path.parent / case["kratos"]["cosim"]
    folder = path.parent / case["kratos"]["folder"] if case["kratos"]["folder"] else None
    params = read_cosim_parameters(cosim_file, folder)
    for name, table in case["solvers"].items():
        if name not in params.solvers:
            raise SceneError(f"{path}: 'solvers.{name}': the CoSimulation file has no solver '{name}' (it has: "
                             f"{', '.join(params.solvers)})")
        if not isinstance(table, dict):
            raise SceneError(f"{path}: 'solvers.{name}' must be a table")
    scene = scene_of(params, case["solvers"], case["name"])
    if case["output"]:
        scene["output"].update(case["output"])
    return scene, ""


class KratosCases:
    """The scene reader (``cosim.scene_readers``) of Kratos CoSimulation cases: a TOML file with a ``[kratos]``
    table, or a ``ProjectParametersCoSim.json`` alone."""

    table = "kratos"
    suffixes = (".json",)
    case_keys = CASE_KEYS

    @staticmethod
    def read(path: Path, raw: dict[str, Any] | None) -> tuple[dict[str, Any], str]:
        if raw is None:
            return scene_of(read_cosim_parameters(path)), ""
        return read_case(path, raw)
