"""Scene files (TOML): schema, validation, and ``--set key=value`` overrides.

Top-level tables: ``time``, ``components.<name>``, ``[[exchange]]``, ``coupling``
(with ``[[coupling.convergence]]`` and ``coupling.acceleration``), ``output``, plus
model sections that components name in their ``sections`` list (for the tube:
``tube`` and ``inlet``); each such section is handed to those components under its
own name. Every error names the dotted key and the file. The plug-ins a scene names
(scheme, acceleration, convergence measures, mappings) own their settings: the coupler
checks those tables against the chosen plug-in before anything starts.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cosim.errors import CosimError, SceneError
from cosim.input_file import read_input
from cosim.schema import (
    AnyTable,
    Choice,
    FilePath,
    OpenTable,
    Positive,
    Required,
    Value,
    file_paths,
    unknown_key_message,
    validate,
)
from cosim.subcycling import MAX_SUBSTEPS

BACKEND = {"entry": "", "switch_time": 0.0}
COMPONENT = {
    "entry": "",
    "address": "",
    "command": "",           # a program that calls the coupler itself (a preCICE participant), run in cwd
    "cwd": FilePath(),
    "rendezvous": FilePath(),    # or such a program started by hand, which finds the coupler in this file
    "curve": FilePath(),
    "sections": [],
    "parameters": AnyTable(),
    "record": False,
    "timeout": Positive(120.0),
    "startup_timeout": Positive(60.0),
    "substeps": Value(1, low=1, high=MAX_SUBSTEPS),    # steps per window (cosim.subcycling)
    "threads": Positive(1),
    "cores": [],
    "environment": AnyTable(),
    "names": AnyTable(),            # the scene's name of each variable it renames -> the component's own name
    "mesh_dimensions": Value(0, low=0, high=3),
    "backend": Choice("fom", ("fom", "rom", "fmu")),
    # a backend's table: its class (default: the installed backend of that kind), when it takes over, and the
    # class's own parameters (checked against its parameter_schema before a run starts)
    "rom": OpenTable(BACKEND),
    "fmu": OpenTable(BACKEND),
}
BACKENDS = "cosim.backends"     # entry points: a backend kind's component class, registered by its package
MAX_WINDOWS = 10_000_000
MAX_FILE_BYTES = 16 << 20
SCHEMA: dict[str, Any] = {
    "name": "",
    "case": "",
    "time": {"start": 0.0, "end": Required(float), "dt": Positive()},
    "components": AnyTable(),
    "output": {"run_plot": True, "plot_field": "", "plot_index": Value(0, low=0), "plot_label": "", "plot_unit": "",
               "plots": [],   # a scene's own run plots: names of cosim.run_plots entry points
               "watch_points": [],   # a component's data at a point, window by window (cosim.watch_points)
               "checkpoint_every": Value(0, low=0)},
}
SCENE_RULES = "cosim.scene_rules"   # entry points: the tables a package above owns (the coupler's coupling)
# what each key means, for the scene reference (docs/reference/scene.md, written by the scene reference generator;
# tests/test_docs.py fails when a key of the schema has no meaning here or the page is not the generated one)
MEANINGS = {
    "name": "a name for the scene, recorded in the results",
    "case": "the case the scene belongs to: `cosim report` adds the report plots and figures its case package "
            "registers under that name (`tube`, `double_flap`)",
    "output.checkpoint_every": "write a checkpoint (checkpoint.npz next to results.h5) every this many windows (0: "
                               "only when Ctrl-C or SIGTERM stops the run, if every component can checkpoint); "
                               "`cosim run --resume` goes on from the last one",
    "time.start": "the start of the first time window [s]",
    "time.end": "the end of the last time window [s]; end - start must be a multiple of dt",
    "time.dt": "the time window (coupling time step) [s]",
    "components": "one table per component, `[components.<name>]`: the keys below",
    "output.run_plot": "draw DIR/run.png when the run ends (a preCICE case: false, as preCICE draws nothing; "
                       "`cosim plot DIR --run` draws it from results.h5 at any time)",
    "output.plot_field": "the exchanged data drawn in run.png (default: the first)",
    "output.plot_index": "the value of that field drawn",
    "output.plot_label": "its label in run.png",
    "output.plot_unit": "its unit in run.png",
    "output.watch_points": "tables of component, mesh, name and coordinate: the component's data at the mesh's "
                           "vertex nearest the coordinate, window by window, into "
                           "DIR/precice-<component>-watchpoint-<name>.log (preCICE's watch points)",
    "output.plots": "the scene's own run plots: names of `cosim.run_plots` entry points (the double flap: "
                    "\"double_flap\")",
    "component.entry": "the component's class, \"package.module:Class\", started as a local process (a module next "
                       "to the scene is found)",
    "component.address": "or the address of a component started by hand with `cosim serve`",
    "component.command": "or a program that owns its time loop and calls the coupler (a preCICE participant, "
                         "[Bring your preCICE case](../precice.md)), run as a shell would split it",
    "component.cwd": "with command: the folder it runs in (default: the scene's)",
    "component.rendezvous": "or a program that calls the coupler, started by hand: the JSON file where the coupler "
                            "writes its address and the run's token for it (a preCICE participant looks in the "
                            "folder cosim-run next to its configuration)",
    "component.curve": "with address: a key directory from `cosim keys` (its client.key_secret and server.key); "
                       "the connection is CURVE-authenticated and encrypted, as `cosim serve --curve` serves it",
    "component.sections": "the scene's model sections handed to the component's instantiate (the tube: "
                          "[\"tube\", \"inlet\"])",
    "component.parameters": "the component's own parameters, checked against its class's parameter_schema",
    "component.record": "record every call (every sub-iteration) into /snapshots/<name>: a ROM's training set",
    "component.timeout": "seconds a request may take before the run stops naming the component",
    "component.startup_timeout": "seconds the process may take to start and answer",
    "component.substeps": "steps the component takes per window, each of dt / substeps, with its inputs "
                          "interpolated in time at the step's end (the exchange's waveform_degree; docs/time.md); "
                          "its outputs at the steps inside the window go with the window's end when the exchange has "
                          "substeps",
    "component.threads": "OpenMP and BLAS threads of the component's process",
    "component.cores": "CPU cores the component's process may run on (Linux affinity; empty: any)",
    "component.environment": "extra environment variables of the component's process",
    "component.names": "the scene's names of the component's variables, `{ SceneName = \"its_name\" }`: the "
                       "exchanges, measures and results speak of the scene's names (a native component in a preCICE "
                       "participant's place, under the configuration's data names)",
    "component.mesh_dimensions": "the component's meshes seen in this many dimensions, their extra coordinates zero "
                                 "(a 1-D tube's nodes on a plane's axis; 0: as the component gives them)",
    "component.backend": "what serves the component: its entry ('fom'), a trained ROM ('rom', table rom) or an "
                         "FMU ('fmu', table fmu)",
    "component.rom.entry": "the ROM component's class (empty: the installed `rom` backend, an entry point of the "
                           "group `cosim.backends`); the table's other keys are that class's parameters (below)",
    "component.rom.switch_time": "the full-order entry serves until this time, the ROM after it",
    "component.fmu.entry": "the FMU component's class (empty: the installed `fmu` backend); the table's other keys "
                           "are that class's parameters (below)",
    "component.fmu.switch_time": "the full-order entry serves until this time, the FMU after it",
}


@dataclass(frozen=True)
class TimeGrid:
    """A validated scene's time: its windows of ``dt`` from ``start`` to ``end``."""

    start: float
    end: float
    dt: float

    @property
    def windows(self) -> int:
        """How many windows the grid has (``end - start`` a multiple of ``dt``: ``check``)."""
        return int(math.floor((self.end - self.start) / self.dt + 0.5))

    def check(self, source: str) -> None:
        """Refuse an end that is not a whole number of windows after the start."""
        if abs(self.start + self.windows * self.dt - self.end) > 1e-9 * max(1.0, abs(self.end)):
            raise SceneError(f"{source}: time.end - time.start = {self.end - self.start:g} is not a multiple of "
                             f"time.dt = {self.dt:g}")

    def window_start(self, window: int) -> float:
        """The time window ``window`` (from 0) starts at."""
        return self.start + window * self.dt


@dataclass
class Scene:
    """A validated scene: ``data`` holds every key with defaults filled in."""

    data: dict[str, Any]
    text: str
    source: str
    overridden: frozenset[str] = frozenset()    # dotted keys given by --set
    file_keys: set[str] = field(default_factory=set)     # dotted keys that name a file the run reads
    notes: str = ""      # a case another tool wrote (a preCICE configuration): what of it the scene does not use
    translated: frozenset[str] = frozenset()    # dotted keys a case reader gave, which --set then changed

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def time(self) -> TimeGrid:
        """The scene's time grid, typed."""
        time = self.data["time"]
        return TimeGrid(time["start"], time["end"], time["dt"])

    @property
    def folder(self) -> Path:
        """The scene file's folder: relative paths and component modules in the scene are found there."""
        return Path(self.source).resolve().parent

    def resolve_paths(self, keys: list[str]) -> None:
        """Make the relative file paths at the dotted ``keys`` the scene folder's, unless --set gave them
        (those stay the working directory's, as the shell gave them)."""
        self.file_keys.update(keys)
        for key in keys:
            node, last = self._holder(key)
            value = node.get(last) if node is not None else None
            if node is not None and isinstance(value, str) and value and not Path(value).is_absolute() \
                    and not self.given(key):
                node[last] = str(self.folder / value)

    def digest(self) -> str:
        """SHA-256 of the resolved scene: the same for scenes that mean the same (the order of keys and of
        ``--set`` items, ``20`` against ``20.0``, comments and layout aside)."""
        return hashlib.sha256(json.dumps(_canonical(self.data), sort_keys=True).encode()).hexdigest()

    def input_files(self) -> dict[str, Path]:
        """Every file the scene names that exists (tables, ROM models, FMUs, meshes), by its dotted key."""
        found = {}
        for key in sorted(self.file_keys):
            parts = key.split(".")
            if parts[0] == "components" and len(parts) > 3 and parts[2] in ("rom", "fmu") \
                    and self.data["components"][parts[1]]["backend"] != parts[2]:
                continue      # a backend the scene does not select: its files are not read
            value = self.value(key)
            if isinstance(value, str) and value and Path(value).is_file():
                found[key] = Path(value)
        return found

    def value(self, key: str) -> Any:
        """The value at the dotted ``key`` (None if there is none)."""
        node, last = self._holder(key)
        return node.get(last) if node is not None else None

    def given(self, key: str) -> bool:
        """Whether --set gave ``key`` (or a table holding it)."""
        return any(key == item or key.startswith(item + ".") for item in self.overridden)

    def _holder(self, key: str) -> tuple[dict | None, str]:
        """The table holding the dotted ``key``'s last part, and that part."""
        *parents, last = key.split(".")
        node: Any = self.data
        for part in parents:
            node = node.get(part) if isinstance(node, dict) else None
        return (node if isinstance(node, dict) else None), last

    def component_parameters(self, name: str) -> dict[str, Any]:
        """A component's full-order parameters plus the model sections it names."""
        spec = self.data["components"][name]
        parameters = {section: self.data[section] for section in spec["sections"]}
        parameters.update(spec["parameters"])
        return parameters


def _canonical(value: Any) -> Any:
    """``value`` with every number a float (a TOML integer and float of one value mean the same here)."""
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_canonical(v) for v in value]
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) < 2**53:
        return float(value)
    return value


def parse_override(text: str) -> tuple[list[str], Any]:
    """``a.b=value`` as (["a", "b"], value); the value is read as TOML, else kept as a string."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise SceneError(f"--set '{text}' is not of the form key=value")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    except RecursionError:
        raise SceneError(f"--set '{key}': the value nests arrays or tables too deeply") from None
    return [part.strip() for part in key.strip().split(".")], value


def apply_override(data: dict[str, Any], path: list[str], value: Any) -> None:
    """Set ``path`` in ``data`` to ``value``; list entries are named by index."""
    node: Any = data
    for depth, part in enumerate(path):
        last = depth == len(path) - 1
        if isinstance(node, list):
            try:
                index = int(part)
                node[index]
                if index < 0:
                    raise IndexError
            except (ValueError, IndexError):
                raise SceneError(f"--set {'.'.join(path)}: '{part}' is not an index of '{'.'.join(path[:depth])}' "
                                 f"(a list of {len(node)} entries: 0 to {len(node) - 1})") from None
            if last:
                node[index] = value
            else:
                node = node[index]
        elif isinstance(node, dict):
            if last:
                node[part] = value
            else:
                node = node.setdefault(part, {})
        else:
            raise SceneError(f"--set {'.'.join(path)}: '{'.'.join(path[:depth])}' is {node!r}, not a table")


def backend_entry(kind: str, where: str, source: str) -> str:
    """The ``package.module:Class`` registered for the backend ``kind`` (its entry point, not imported here)."""
    from cosim.registry import entry_points
    found = {point.name: point.value for point in entry_points(group=BACKENDS)}
    if kind not in found:
        raise SceneError(f"{source}: '{where}' is not set and no '{kind}' backend is installed (entry points "
                         f"{BACKENDS}: {', '.join(found) or 'none'})")
    return found[kind]


SCENE_READERS = "cosim.scene_readers"   # entry points: cases other tools write (a preCICE case), read into a scene


def _reader_for(path: Path, raw: dict[str, Any] | None) -> Any:
    """The installed scene reader for a file of its suffix, or for a TOML file holding its table (None: a scene)."""
    from cosim.registry import entry_points
    for point in entry_points(group=SCENE_READERS):
        if raw is not None and point.name not in raw:
            continue            # a TOML file names its reader by its table (the entry point's name)
        reader = point.load()
        if path.suffix in reader.suffixes or (raw is not None and reader.table in raw):
            return reader
    return None


def load_scene(path: str | Path, overrides: list[str] | tuple[str, ...] = ()) -> Scene:
    """Read, override and validate a scene file, or a case another tool wrote that an installed reader turns into
    a scene (``cosim.scene_readers``: a preCICE case); ``--set`` acts on the case's own keys before it is read, and
    on the scene it becomes after."""
    path = Path(path)
    reader = _reader_for(path, None) if path.suffix != ".toml" else None
    if reader is not None:
        text, raw = read_input(path, "case", MAX_FILE_BYTES).decode("utf-8", errors="replace"), None
    else:
        text, raw = read_toml(path, "scene")
        reader = _reader_for(path, raw)
    given = set()
    translated = set()
    notes = ""
    data: dict[str, Any] = raw or {}
    if reader is not None:
        own = [item for item in overrides if parse_override(item)[0][0] in reader.case_keys]
        for item in own:
            key, value = parse_override(item)
            apply_override(data, key, value)
            given.add(".".join(key))
        data, notes = reader.read(path, data if raw is not None else None)
        overrides = [item for item in overrides if item not in own]
    for item in overrides:
        key, value = parse_override(item)
        if reader is not None and _holds(data, key):
            translated.add(".".join(key))
        apply_override(data, key, value)
        given.add(".".join(key))
    scene = Scene(validate_scene(data, str(path)), text, str(path), frozenset(given), notes=notes,
                  translated=frozenset(translated))
    scene.resolve_paths([f"components.{name}.{key}" for name in scene["components"]
                         for key in file_paths(COMPONENT)])
    # the files a component says it reads (its parameters' ``inputs`` table, as a Kratos case's solvers give it)
    scene.file_keys.update(f"components.{name}.parameters.inputs.{label}"
                           for name, spec in scene["components"].items()
                           if isinstance(spec["parameters"].get("inputs"), dict)
                           for label in spec["parameters"]["inputs"])
    if overrides:
        scene.text += "\n# --set " + "\n# --set ".join(overrides) + "\n"
    return scene


def _holds(data: Any, key: list[str]) -> bool:
    """Whether ``data`` has a value at ``key`` (a list entry by its index)."""
    node = data
    for part in key:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return False
    return True


MAX_DEPTH = 32   # tables and arrays nested deeper than this are no scene (and would exhaust the stack)


def read_toml(path: str | Path, what: str = "scene") -> tuple[str, dict[str, Any]]:
    """The text of a TOML file and its data; every failure is a one-line ``SceneError`` naming the file."""
    path = Path(path)
    try:
        text = _input_text(path, what)
    except UnicodeDecodeError as exc:
        line = exc.object[:exc.start].count(b"\n") + 1
        raise SceneError(f"{path}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x} on line {line})") from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: {exc}") from None
    except RecursionError:
        raise SceneError(f"{path}: tables or arrays nest more than {MAX_DEPTH} deep") from None
    if _depth(raw) > MAX_DEPTH:
        raise SceneError(f"{path}: tables or arrays nest more than {MAX_DEPTH} deep")
    return text, raw


def _input_text(path: Path, what: str) -> str:
    try:
        return read_input(path, what, MAX_FILE_BYTES).decode("utf-8")
    except CosimError as exc:
        raise SceneError(str(exc)) from None


def _depth(value: Any) -> int:
    """How deep tables and arrays nest in ``value`` (iterative: no recursion limit)."""
    deepest, stack = 0, [(value, 0)]
    while stack:
        item, depth = stack.pop()
        children = item.values() if isinstance(item, dict) else item if isinstance(item, list) else ()
        deepest = max(deepest, depth)
        if depth <= MAX_DEPTH:
            stack.extend((child, depth + 1) for child in children)
    return deepest


def _address(value: str, where: str, source: str) -> None:
    """A component served by hand is reached at tcp://HOST:PORT (or ipc://PATH)."""
    transport, sep, rest = value.partition("://")
    host, colon, port = rest.rpartition(":")
    tcp = transport == "tcp" and colon and host and port.isdigit() and 0 < int(port) < 65536
    if not value or not (tcp or (transport == "ipc" and sep and rest)):
        raise SceneError(f"{source}: '{where}' is {value!r}; allowed: tcp://HOST:PORT (PORT 1 to 65535) or "
                         "ipc://PATH, the address `cosim serve` printed")


def _names(names: Mapping[str, Any], where: str, source: str) -> None:
    """A renaming: distinct non-empty strings both ways."""
    for outer, inner in names.items():
        if not isinstance(inner, str) or not inner or not outer:
            raise SceneError(f"{source}: '{where}.{outer}' is {inner!r}; it names the component's variable, a string")
    if len(set(names.values())) != len(names):
        raise SceneError(f"{source}: '{where}' gives one variable of the component two names")


# the tables that tell the project's other TOML files from a scene, and the command each is for
OTHER_KINDS = ((("snapshots", "model", "dynamics"), "a ROM configuration, for cosim train RESULTS --config FILE"),
               (("fom", "models", "recipes", "predictions"), "a campaign file, for cosim campaign FILE --out DIR"))


def _other_kind(raw: dict[str, Any]) -> str:
    """"this is ..., not a scene; " when ``raw`` has the tables of another kind of file, else ""."""
    for tables, kind in OTHER_KINDS:
        if not raw.get("components") and sum(table in raw for table in tables) >= 2:
            return f"this is {kind}, not a scene: "
    return ""


def validate_scene(raw: dict[str, Any], source: str = "scene") -> dict[str, Any]:
    """Validated scene dict (defaults filled in); raises SceneError naming the key."""
    raw = dict(raw)
    components_raw = raw.get("components", {})
    if not isinstance(components_raw, dict) or not components_raw:
        raise SceneError(f"{source}: {_other_kind(raw)}the scene defines no [components.<name>] table")
    components = {name: validate(spec, COMPONENT, f"components.{name}.", source)
                  for name, spec in components_raw.items()}
    for name, spec in components.items():
        for kind in ("rom", "fmu"):
            spec[kind]["entry"] = spec[kind]["entry"] or backend_entry(kind, f"components.{name}.{kind}.entry", source)
        string_list(spec["sections"], f"components.{name}.sections", source)
        _cores(spec["cores"], f"components.{name}.cores", source)
        _threads(spec["threads"], f"components.{name}.threads", source)
        _names(spec["names"], f"components.{name}.names", source)
    # in the order the components name them: the resolved scene (and results.h5) is the same on every run
    sections = list(dict.fromkeys(s for spec in components.values() for s in spec["sections"]))
    rules = scene_rules()
    known = set(SCHEMA) | {table for owner in rules for table in owner.tables} | set(sections)
    for key in raw:
        if key not in known:
            raise SceneError(unknown_key_message(key, "", sorted(known), source))
    for name, spec in components.items():
        if [bool(spec[k]) for k in ("entry", "address", "command", "rendezvous")].count(True) != 1:
            raise SceneError(f"{source}: components.{name} needs exactly one of 'entry', 'address', 'command' or "
                             "'rendezvous'")
        if spec["cwd"] and not spec["command"]:
            raise SceneError(f"{source}: 'components.{name}.cwd' is the folder of a command: set "
                             f"'components.{name}.command' too")
        if spec["address"]:
            _address(spec["address"], f"components.{name}.address", source)
        if spec["substeps"] > 1 and (spec["command"] or spec["rendezvous"]):
            raise SceneError(f"{source}: 'components.{name}.substeps' is {spec['substeps']}, but '{name}' is a program "
                             "that calls the coupler: it takes its own steps (get_max_time_step_size), remove it")
        if spec["substeps"] > 1 and spec["backend"] != "fom" and spec[spec["backend"]]["switch_time"] > 0:
            raise SceneError(f"{source}: 'components.{name}.substeps' is {spec['substeps']} with a switch of backend "
                             f"during the run (components.{name}.{spec['backend']}.switch_time): a component that "
                             "subcycles is served by one backend from the start (switch_time = 0)")
        if spec["curve"] and not spec["address"]:
            raise SceneError(f"{source}: 'components.{name}.curve' is set, but CURVE is for a component served by "
                             f"hand: set 'components.{name}.address' too")
        for section in spec["sections"]:
            if section not in raw:
                raise SceneError(f"{source}: components.{name}.sections names '{section}', "
                                 f"but the scene has no [{section}] table")
    data = validate({k: v for k, v in raw.items() if k in SCHEMA}, SCHEMA, "", source)
    data["components"] = components
    _check_time(data["time"], source)
    for owner in rules:
        owner.validate(raw, data, source)
    for section in sections:
        data.setdefault(section, raw[section])   # "time" may be handed to components too (validated)
    from cosim.watch_points import check as check_watch_points
    check_watch_points(data["output"]["watch_points"], data["components"], source)
    return data


def table_list(value: Any, where: str, source: str) -> list[dict]:
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise SceneError(f"{source}: '{where}' must be a list of tables ([[{where}]])")
    return value


def string_list(value: list, where: str, source: str) -> None:
    for i, item in enumerate(value):
        if not isinstance(item, str):
            raise SceneError(f"{source}: '{where}.{i}' must be a string, got {item!r}")


MAX_THREADS_PER_CORE = 4    # a process's OpenMP and BLAS threads: more than a few a core only slows it


def _threads(value: int, where: str, source: str) -> None:
    """A component's threads: at most a few a core of this machine (a solver died at start with 100,000)."""
    most = MAX_THREADS_PER_CORE * (os.cpu_count() or 1)
    if value > most:
        raise SceneError(f"{source}: '{where}' is {value}; at most {most} ({MAX_THREADS_PER_CORE} a core of this "
                         f"machine's {os.cpu_count() or 1})")


def _cores(value: list, where: str, source: str) -> None:
    """Cores this process may use (a component's cores must be among them)."""
    allowed = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    for i, item in enumerate(value):
        if isinstance(item, bool) or not isinstance(item, int):
            raise SceneError(f"{source}: '{where}.{i}' must be a core number, got {item!r}")
        if allowed is None:
            raise SceneError(f"{source}: '{where}' is set, but this platform cannot pin processes to cores")
        if item not in allowed:
            raise SceneError(f"{source}: '{where}' names core {item}; this process may use cores "
                             f"{', '.join(map(str, allowed))}")


def _check_time(time: dict[str, Any], source: str) -> None:
    if time["end"] <= time["start"]:
        raise SceneError(f"{source}: 'time.end' ({time['end']}) must exceed 'time.start' ({time['start']})")
    windows = (time["end"] - time["start"]) / time["dt"]
    if windows > MAX_WINDOWS:
        raise SceneError(f"{source}: 'time.dt' = {time['dt']:g} makes {windows:.3g} windows on "
                         f"[{time['start']:g}, {time['end']:g}]; at most {MAX_WINDOWS:,} are allowed")


def scene_rules() -> list[Any]:
    """The installed owners of a scene's other tables (``cosim.scene_rules`` entry points, by name): each has
    ``tables`` (the top-level keys it owns) and ``validate(raw, data, source)``, which fills ``data`` in."""
    from cosim.registry import entry_points
    return [point.load() for point in sorted(entry_points(group=SCENE_RULES), key=lambda point: point.name)]
