"""A preCICE case as a cosim scene: ``CASE.toml`` names the ``precice-config.xml`` and how to start each participant,
and may swap a participant for a cosim component (its trained ROM, an FMU, a native solver) by one line.

```toml
[precice]
config = "precice-config.xml"            # relative to CASE.toml

[participants.Fluid]                     # the name in the config
command = "python3 FluidSolver.py ../precice-config.xml"
cwd = "fluid-python"                     # relative to CASE.toml

[participants.Solid]
command = "python3 SolidSolver.py ../precice-config.xml"
cwd = "solid-python"
backend = "participant"                  # or "rom" (table rom), "fmu" (table fmu), "component" (entry, parameters)
rom = { model = "model.npz" }
```

A configuration alone (``cosim run precice-config.xml``) is a case whose participants are all started by hand:
the coupler writes where it listens into each participant's exchange directory (``cosim-run/coupler.json``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from cosim.errors import SceneError
from cosim.schema import AnyTable, Choice, OpenTable, Positive, Value, unknown_key_message, validate
from precice_compat.config import Config, read_config
from precice_compat.libprecice.build import installed

PARTICIPANT_SHIM = Path(__file__).resolve().parent / "participant"    # the folder holding `import precice`
CASE = {"precice": {"config": ""}, "participants": AnyTable(), "name": "", "output": AnyTable()}
PARTICIPANT = {
    "command": "",
    "cwd": "",
    "environment": AnyTable(),
    "timeout": Positive(120.0),
    "startup_timeout": Positive(60.0),
    "record": True,
    "backend": Choice("participant", ("participant", "rom", "fmu", "component")),
    "rom": OpenTable({"entry": ""}),
    "fmu": OpenTable({"entry": ""}),
    "entry": "",
    "parameters": AnyTable(),
    "names": AnyTable(),            # backend "component": the configuration's data -> the component's variables
    "mesh_dimensions": Value(0, low=0, high=3),
}
CASE_KEYS = ("precice", "participants")      # --set on these reads the case anew; the others act on its scene


def setup_of(config: Config, name: str) -> dict[str, Any]:
    """What a participant is told when it says hello: its meshes, the data it writes and reads, the window."""
    participant = config.participants[name]
    scheme = config.scheme
    with_elements = {mesh for p in config.participants.values() for m in p.mappings
                     if m.kind in ("nearest-element", "cell-interpolation") for mesh in (m.source, m.target)}
    meshes = {mesh: {"dimensions": config.meshes[mesh]["dimensions"], "provided": mesh in participant.provides,
                     "connectivity": mesh in with_elements, "direct_access": mesh in participant.direct,
                     "from": participant.receives.get(mesh, name), "data": list(config.meshes[mesh]["data"])}
              for mesh in [*participant.provides, *participant.receives]}
    for mapping in participant.mappings:       # just in time: nearest-neighbor onto a mesh accessed directly
        if not mapping.source or not mapping.target:
            meshes[mapping.source or mapping.target].setdefault("just_in_time", []).append(mapping.direction)

    def dimensions(data: str, mesh: str) -> int:
        return config.meshes[mesh]["dimensions"] if config.data[data]["vector"] else 1

    exchanged = {e.data for e in config.exchanges}
    # data a nearest-neighbor-gradient mapping maps from the mesh it is written on: its writer gives gradients
    with_gradients = {(mapping.source, e.data) for p in config.participants.values() for mapping in p.mappings
                      if mapping.kind == "nearest-neighbour-gradient" for e in config.exchanges
                      if e.source == name and participant.writes.get(e.data) == mapping.source}
    return {
        "dimensions": max((config.meshes[m]["dimensions"] for m in meshes), default=2),
        "meshes": meshes,
        "write": [{"mesh": mesh, "data": data, "dimensions": dimensions(data, mesh),
                   "substeps": any(e.substeps for e in config.exchanges if e.data == data and e.source == name),
                   "gradient": (mesh, data) in with_gradients}
                  for data, mesh in participant.writes.items() if data in exchanged],
        "read": [{"mesh": mesh, "data": data, "dimensions": dimensions(data, mesh),
                  "degree": config.data[data]["degree"]} for data, mesh in participant.reads.items()
                 if data in exchanged],
        "initial": [e.data for e in config.exchanges if e.initialize and e.source == name],
        "implicit": scheme["kind"].endswith("implicit") or scheme["kind"] == "multi",
        "window": scheme["window"],
        "start": 0.0,
        "experimental": config.experimental,
        "exports": [{k: v for k, v in export.items() if k != "line"} for export in participant.exports],
    }


def mapping_of(config: Config, data: str, source: str, target: str, line: int) -> dict[str, Any]:
    """The mapping of ``data`` from ``source``'s mesh to ``target``'s, as the participants' mapping elements say."""
    written, read = config.participants[source].writes[data], config.participants[target].reads[data]
    if written == read:
        return {"type": "identity"}
    for participant in (config.participants[source], config.participants[target]):
        for mapping in participant.mappings:
            if (mapping.source, mapping.target) == (written, read):
                return {"type": mapping.kind, **mapping.settings}
    raise SceneError(f"{config.path}, line {line}: '{data}' goes from mesh '{written}' of '{source}' to mesh '{read}' "
                     f"of '{target}', and no <mapping:...> maps '{written}' to '{read}' (add one to '{target}' with "
                     f"direction=\"read\", or to '{source}' with direction=\"write\")")


def scene_of(config: Config, participants: dict[str, dict[str, Any]], folder: Path, name: str = "") -> dict[str, Any]:
    """The scene a configuration makes, each participant started as ``participants`` says (a participant the case
    does not name is one started by hand)."""
    scheme = config.scheme
    window = scheme["window"]
    end = scheme.get("max_time")
    if "max_windows" in scheme:
        end = scheme["max_windows"] * window if end is None else min(end, scheme["max_windows"] * window)
    components = {}
    for participant in scheme["participants"]:
        spec = participants.get(participant, {})
        component = _component(config, participant, spec, folder)
        components[participant] = component
    exchanges = [{"data": e.data, "from": e.source, "to": e.target,
                  "mapping": mapping_of(config, e.data, e.source, e.target, e.line),
                  "waveform_degree": config.data[e.data]["degree"], "substeps": e.substeps}
                 for e in config.exchanges]
    strict = any(m["strict"] for m in scheme["measures"])
    measures = [{k: v for k, v in m.items() if k not in ("strict", "line")} for m in scheme["measures"]]
    minimum = scheme.get("min_iterations")
    if minimum:
        measures.append({"data": config.exchanges[0].data, "type": "min-iterations", "iterations": minimum})
    coupling: dict[str, Any] = {
        "scheme": scheme["kind"],
        "participants": list(scheme["participants"]),
        "max_iterations": scheme.get("max_iterations", 100),
        # preCICE goes on after max-iterations unless a measure is strict
        "on_max_iterations": "fail" if strict else "accept",
        # preCICE watches no growth of the residual: a window that ends at max-iterations is accepted whatever its
        # residual did (CalculiX's elastic beam starts from a residual of 1e-12 and ends its first window at 3e-4)
        "divergence_factor": 1e300,
        "extrapolation_order": scheme.get("extrapolation_order", 0),
        "convergence": measures,
    }
    if scheme["kind"] in ("parallel-implicit", "multi"):
        # the participant that accelerates (the second; multi's controller) keeps the initial data it receives out
        # of the first window's first iterate, as preCICE 3 does
        accelerating = scheme["participants"][1 if scheme["kind"] == "parallel-implicit" else 0]
        zeroed = [e.data for e in config.exchanges if e.initialize and e.target == accelerating]
        if zeroed:
            coupling["first_iterate_zero"] = list(dict.fromkeys(zeroed))
    if scheme["acceleration"] is not None:
        coupling["acceleration"] = {k: v for k, v in scheme["acceleration"].items() if k != "line"}
    watch_points = [{"component": participant.name, "mesh": point["mesh"], "name": point["name"],
                     "coordinate": point["coordinate"]}
                    for participant in config.participants.values() if participant.name in components
                    for point in participant.watch_points]
    return {"name": name or f"preCICE case {config.path.name}", "time": {"start": 0.0, "end": end, "dt": window},
            "components": components, "exchange": exchanges, "coupling": coupling,
            "output": {"run_plot": False, "plot_field": config.exchanges[0].data, "watch_points": watch_points}}


def _component(config: Config, name: str, spec: dict[str, Any], folder: Path) -> dict[str, Any]:
    """A participant as a scene component: its program, or the cosim component it is swapped for."""
    setup = setup_of(config, name)
    where = f"participants.{name}"
    component: dict[str, Any] = {"record": spec.get("record", True), "timeout": spec.get("timeout", 120.0),
                                 "startup_timeout": spec.get("startup_timeout", 60.0)}
    backend = spec.get("backend", "participant")
    environment = {str(k): str(v) for k, v in (spec.get("environment") or {}).items()}
    environment["PYTHONPATH"] = os.pathsep.join(filter(None, [str(PARTICIPANT_SHIM), environment.get("PYTHONPATH")]))
    library = installed()      # a compiled participant links cosim's libprecice, where it is installed
    if library is not None:
        environment["LD_LIBRARY_PATH"] = os.pathsep.join(filter(None, [str(library / "lib"),
                                                                       environment.get("LD_LIBRARY_PATH")]))
    if spec.get("command"):
        component.update(command=spec["command"], cwd=str((folder / spec.get("cwd", "")).resolve()),
                         environment=environment, parameters={"setup": setup})
    else:       # started by hand: it finds the coupler next to its configuration
        component.update(rendezvous=str(rendezvous_of(config.path)), parameters={"setup": setup})
    if backend in ("rom", "fmu"):
        table = dict(spec.get(backend) or {})
        table["switch_time"] = 0.0      # a participant keeps its state to itself: the swap holds for the whole run
        component["backend"] = backend
        component[backend] = table
    elif backend == "component":
        if not spec.get("entry"):
            raise SceneError(f"'{where}.backend' is 'component': name its class in '{where}.entry'")
        dimensions = max((config.meshes[m]["dimensions"] for m in config.participants[name].provides), default=0)
        component = {"entry": spec["entry"], "parameters": spec.get("parameters", {}),
                     "record": component["record"], "timeout": component["timeout"],
                     "startup_timeout": component["startup_timeout"], "names": spec.get("names", {}),
                     # its meshes on the configuration's: a 1-D component's nodes on the axis of a 2-D mesh
                     "mesh_dimensions": spec.get("mesh_dimensions") or dimensions}
    return component


def read_case(path: Path, raw: dict[str, Any]) -> tuple[dict[str, Any], str]:
    """The scene of a ``CASE.toml`` (``raw``: its tables, --set applied to its own keys), and notes on what the
    configuration gave that cosim does not use."""
    folder = path.parent
    for key in raw:
        if key not in CASE:
            raise SceneError(unknown_key_message(key, "", sorted(CASE), str(path)))
    case = validate(raw, CASE, "", str(path))
    config_path = case["precice"]["config"]
    if not config_path:
        raise SceneError(f"{path}: 'precice.config' names no precice-config.xml")
    config = read_config(folder / config_path)
    participants = {}
    for name, table in case["participants"].items():
        if name not in config.participants:
            raise SceneError(f"{path}: 'participants.{name}': the configuration has no participant '{name}' "
                             f"(it has: {', '.join(config.participants)})")
        if not isinstance(table, dict):
            raise SceneError(f"{path}: 'participants.{name}' must be a table")
        participants[name] = validate(table, PARTICIPANT, f"participants.{name}.", str(path))
    scene = scene_of(config, participants, folder, case["name"])
    if case["output"]:
        scene["output"].update(case["output"])
    return scene, "\n".join(config.notes)


def rendezvous_of(config: Path) -> Path:
    """Where a participant started by hand finds the coupler of its configuration: ``cosim-run/coupler.json`` next
    to the configuration (the participant's ``precice`` package looks there)."""
    return config.resolve().parent / "cosim-run" / "coupler.json"


class PreciceCases:
    """The scene reader (``cosim.scene_readers``) of preCICE cases: a TOML file with a ``[precice]`` table, or a
    ``precice-config.xml`` alone (every participant started by hand)."""

    table = "precice"
    suffixes = (".xml",)
    case_keys = CASE_KEYS

    @staticmethod
    def read(path: Path, raw: dict[str, Any] | None) -> tuple[dict[str, Any], str]:
        if raw is None:
            config = read_config(path)
            return scene_of(config, {}, path.parent), "\n".join(config.notes)
        return read_case(path, raw)
