"""Scene files (TOML): schema, validation, and ``--set key=value`` overrides.

Top-level tables: ``time``, ``components.<name>``, ``[[exchange]]``, ``coupling``
(with ``[[coupling.convergence]]`` and ``coupling.acceleration``), ``output``, plus
model sections that components name in their ``sections`` list (for the tube:
``tube`` and ``inlet``); each such section is handed to those components under its
own name. Every error names the dotted key and the file.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cosim.errors import SceneError
from cosim.schema import AnyTable, Required, unknown_key_message, validate

SCHEMES = ("serial-explicit", "serial-implicit", "parallel-implicit")
ACCELERATIONS = ("none", "constant", "aitken", "iqn-ils")
FILTERS = ("qr1", "qr1-absolute", "qr2", "none")
MEASURES = ("relative", "absolute", "residual-relative")
MAPPINGS = ("identity", "nearest-neighbour", "nearest-neighbour-conservative")

COMPONENT = {
    "entry": "",            # "package.module:Class", started as a local process
    "address": "",          # or the address of a component started by hand with `cosim serve`
    "sections": [],         # model sections of the scene passed to instantiate
    "parameters": AnyTable(),
    "record": False,        # record every call into /snapshots/<name>
    "timeout": 120.0,       # seconds per request
    "startup_timeout": 60.0,
    "backend": "fom",       # "fom": the entry above; "rom" or "fmu": see the tables below
    "rom": {                # a trained ROM (the .npz written by `cosim train`)
        "entry": "rom_component.component:RomSolid",
        "model": "",
        "switch_time": 0.0,  # the full-order entry serves until this time, the ROM after it
        "arithmetic": "reproducible",  # bit-identical to the exported FMU; "fast": BLAS products
    },
    "fmu": {                # any FMI 2.0 Co-Simulation FMU (for example from `cosim export-fmu`)
        "entry": "solid_component.fmu:FmuSolid",
        "path": "",
        "switch_time": 0.0,
        "stateful": False,   # true: roll the FMU back with fmi2GetFMUstate/fmi2SetFMUstate
    },
}
BACKEND_FILE = {"rom": "model", "fmu": "path"}
EXCHANGE = {"data": Required(str), "from": Required(str), "to": Required(str), "mapping": "identity"}
MEASURE = {"data": Required(str), "type": "relative", "limit": Required(float)}
SCHEMA = {
    "name": "",
    "time": {"start": 0.0, "end": Required(float), "dt": Required(float)},
    "components": AnyTable(),
    "coupling": {
        "scheme": "serial-implicit",
        "participants": Required(list),
        "max_iterations": 50,
        "on_max_iterations": "fail",
        "extrapolation_order": 0,
        "acceleration": {
            "type": "none",
            "data": [],
            "initial_relaxation": 0.5,
            "max_used_iterations": 50,
            "reused_time_windows": 0,
            "filter": "qr2",
            "filter_limit": 1e-3,
        },
    },
    "output": {"plot_field": "", "plot_index": 0, "plot_label": ""},
}
LISTS = {"exchange": EXCHANGE}


@dataclass
class Scene:
    """A validated scene: ``data`` holds every key with defaults filled in."""

    data: dict[str, Any]
    text: str
    source: str

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    def component_parameters(self, name: str) -> dict[str, Any]:
        """A component's full-order parameters plus the model sections it names."""
        spec = self.data["components"][name]
        parameters = {section: self.data[section] for section in spec["sections"]}
        parameters.update(spec["parameters"])
        return parameters


def parse_override(text: str) -> tuple[list[str], Any]:
    """``a.b=value`` as (["a", "b"], value); the value is read as TOML, else kept as a string."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise SceneError(f"--set '{text}' is not of the form key=value")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return [part.strip() for part in key.strip().split(".")], value


def apply_override(data: dict[str, Any], path: list[str], value: Any) -> None:
    node: Any = data
    for depth, part in enumerate(path[:-1]):
        if isinstance(node, list):
            try:
                node = node[int(part)]
            except (ValueError, IndexError):
                raise SceneError(f"--set {'.'.join(path)}: '{part}' is not an index of "
                                 f"'{'.'.join(path[:depth])}' (it has {len(node)} entries)") from None
        else:
            node = node.setdefault(part, {})
            if not isinstance(node, (dict, list)):
                raise SceneError(f"--set {'.'.join(path)}: '{'.'.join(path[:depth + 1])}' is not a table")
    if isinstance(node, list):
        node[int(path[-1])] = value
    else:
        node[path[-1]] = value


def load_scene(path: str | Path, overrides: list[str] | tuple[str, ...] = ()) -> Scene:
    """Read, override and validate a scene file."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise SceneError(f"cannot read scene '{path}': {exc.strerror}") from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: {exc}") from None
    for item in overrides:
        apply_override(raw, *parse_override(item))
    scene = Scene(validate_scene(raw, str(path)), text, str(path))
    if overrides:
        scene.text += "\n# --set " + "\n# --set ".join(overrides) + "\n"
    return scene


def validate_scene(raw: dict[str, Any], source: str = "scene") -> dict[str, Any]:
    """Validated scene dict (defaults filled in); raises SceneError naming the key."""
    raw = dict(raw)
    components_raw = raw.get("components", {})
    if not isinstance(components_raw, dict) or not components_raw:
        raise SceneError(f"{source}: the scene defines no [components.<name>] table")
    components = {name: validate(spec, COMPONENT, f"components.{name}.", source)
                  for name, spec in components_raw.items()}
    sections = {s for spec in components.values() for s in spec["sections"]}
    known = set(SCHEMA) | set(LISTS) | sections
    for key in raw:
        if key not in known:
            raise SceneError(unknown_key_message(key, "", sorted(known), source))
    for name, spec in components.items():
        backend = spec["backend"]
        _one_of(backend, ("fom", "rom", "fmu"), f"components.{name}.backend", source)
        if backend != "fom" and not spec[backend][BACKEND_FILE[backend]]:
            raise SceneError(f"{source}: components.{name}.backend is '{backend}' but "
                             f"'components.{name}.{backend}.{BACKEND_FILE[backend]}' is not set")
        if bool(spec["entry"]) == bool(spec["address"]):
            raise SceneError(f"{source}: components.{name} needs exactly one of 'entry' or 'address'")
        for section in spec["sections"]:
            if section not in raw:
                raise SceneError(f"{source}: components.{name}.sections names '{section}', "
                                 f"but the scene has no [{section}] table")
    convergence = raw.get("coupling", {}).get("convergence", []) if isinstance(raw.get("coupling"), dict) else []
    coupling_raw = {k: v for k, v in raw.get("coupling", {}).items() if k != "convergence"}
    data = validate({k: v for k, v in raw.items() if k in SCHEMA and k != "coupling"},
                    {k: v for k, v in SCHEMA.items() if k != "coupling"}, "", source)
    data["coupling"] = validate(coupling_raw, SCHEMA["coupling"], "coupling.", source)
    data["coupling"]["convergence"] = [validate(m, MEASURE, f"coupling.convergence.{i}.", source)
                                       for i, m in enumerate(_table_list(convergence, "coupling.convergence", source))]
    data["components"] = components
    data["exchange"] = [validate(e, EXCHANGE, f"exchange.{i}.", source)
                        for i, e in enumerate(_table_list(raw.get("exchange", []), "exchange", source))]
    for section in sections:
        data[section] = raw[section]
    _check_consistency(data, source)
    return data


def _table_list(value: Any, where: str, source: str) -> list[dict]:
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise SceneError(f"{source}: '{where}' must be a list of tables ([[{where}]])")
    return value


def _one_of(value: Any, allowed: tuple, where: str, source: str) -> None:
    if value not in allowed:
        raise SceneError(f"{source}: '{where}' is {value!r}; allowed: {', '.join(map(str, allowed))}")


def _check_consistency(data: dict[str, Any], source: str) -> None:
    time, coupling = data["time"], data["coupling"]
    if time["dt"] <= 0:
        raise SceneError(f"{source}: 'time.dt' must be positive, got {time['dt']}")
    if time["end"] <= time["start"]:
        raise SceneError(f"{source}: 'time.end' ({time['end']}) must exceed 'time.start' ({time['start']})")
    names = set(data["components"])
    _one_of(coupling["scheme"], SCHEMES, "coupling.scheme", source)
    _one_of(coupling["on_max_iterations"], ("fail", "accept"), "coupling.on_max_iterations", source)
    _one_of(coupling["extrapolation_order"], (0, 1, 2), "coupling.extrapolation_order", source)
    acceleration = coupling["acceleration"]
    _one_of(acceleration["type"], ACCELERATIONS, "coupling.acceleration.type", source)
    _one_of(acceleration["filter"], FILTERS, "coupling.acceleration.filter", source)
    if coupling["max_iterations"] < 1:
        raise SceneError(f"{source}: 'coupling.max_iterations' must be at least 1")
    participants = coupling["participants"]
    if len(participants) != 2 or len(set(participants)) != 2:
        raise SceneError(f"{source}: 'coupling.participants' must name two different components, got {participants}")
    for i, name in enumerate(participants):
        if name not in names:
            raise SceneError(f"{source}: 'coupling.participants.{i}' is '{name}', not a component "
                             f"(components: {', '.join(sorted(names))})")
    exchanged = set()
    for i, exchange in enumerate(data["exchange"]):
        for end in ("from", "to"):
            if exchange[end] not in participants:
                raise SceneError(f"{source}: 'exchange.{i}.{end}' is '{exchange[end]}', not a participant "
                                 f"({', '.join(participants)})")
        if exchange["from"] == exchange["to"]:
            raise SceneError(f"{source}: 'exchange.{i}' goes from '{exchange['from']}' to itself")
        _one_of(exchange["mapping"], MAPPINGS, f"exchange.{i}.mapping", source)
        exchanged.add(exchange["data"])
    if not exchanged:
        raise SceneError(f"{source}: the scene exchanges no data (add [[exchange]] tables)")
    for i, measure in enumerate(coupling["convergence"]):
        _one_of(measure["type"], MEASURES, f"coupling.convergence.{i}.type", source)
        if measure["data"] not in exchanged:
            raise SceneError(f"{source}: 'coupling.convergence.{i}.data' is '{measure['data']}', "
                             f"not exchanged data ({', '.join(sorted(exchanged))})")
    for i, name in enumerate(acceleration["data"]):
        if name not in exchanged:
            raise SceneError(f"{source}: 'coupling.acceleration.data.{i}' is '{name}', "
                             f"not exchanged data ({', '.join(sorted(exchanged))})")
    if coupling["scheme"] != "serial-explicit" and not coupling["convergence"]:
        raise SceneError(f"{source}: an implicit scheme needs at least one [[coupling.convergence]] measure")
    plot = data["output"]["plot_field"]
    if plot and plot not in exchanged:
        raise SceneError(f"{source}: 'output.plot_field' is '{plot}', not exchanged data")
