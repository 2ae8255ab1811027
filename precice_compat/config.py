"""A ``precice-config.xml`` (preCICE v2 or v3) read into a cosim scene: its participants as components, its
exchanges with their mappings, its coupling scheme, measures and acceleration as the coupler's plug-ins.

What preCICE configures and cosim does the same way is translated; what cosim does not do is refused, one line
naming the file, the line, the element and what to do instead. Nothing is dropped silently: elements that only
concern output (``export``, ``log``, ``profiling``) and the transport (``m2n`` but its exchange directory,
``intra-comm``) are accepted and listed as notes, which ``cosim check`` prints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cosim.errors import SceneError
from cosim.watch_points import file_name_part
from coupler.accelerations.preconditioners import PRECONDITIONERS
from coupler.mapping import BASES, COMPACT_BASES
from precice_compat.xml_tree import Element, parse

SCHEMES = {"serial-explicit": "serial-explicit", "parallel-explicit": "parallel-explicit",
           "serial-implicit": "serial-implicit", "parallel-implicit": "parallel-implicit", "multi": "multi"}
MEASURES = {"relative-convergence-measure": "relative", "absolute-convergence-measure": "absolute",
            "residual-relative-convergence-measure": "residual-relative"}
FILTERS = {"QR1": "qr1", "QR2": "qr2", "QR1-absolute": "qr1-absolute"}
V2_RBF = {f"rbf-{basis}": basis for basis in BASES}     # v2's mapping:rbf-<basis>, the basis's parameters on it
V3_RBF = ("rbf", "rbf-global-direct", "rbf-global-iterative", "rbf-pum-direct")     # v3's, with <basis-function:...>
EXPORT_FORMATS = ("vtu", "vtk", "csv")
# where preCICE solves an RBF system, by mapping (accepted, not used)
EXECUTORS = {"rbf": (), "rbf-global-direct": ("cpu", "cuda", "hip"),
             "rbf-global-iterative": ("cpu", "cuda", "hip", "openmp"),
             "rbf-pum-direct": ("cpu", "cuda", "hip", "sycl", "openmp")}
INTEGRATED_POLYNOMIAL = ("thin-plate-splines", "multiquadrics", "volume-splines")   # where preCICE takes polynomial="on"


@dataclass
class Mapping:
    kind: str
    direction: str
    source: str
    target: str
    constraint: str
    settings: dict[str, Any]
    line: int


@dataclass
class Participant:
    name: str
    line: int
    provides: list[str] = field(default_factory=list)
    receives: dict[str, str] = field(default_factory=dict)      # mesh -> the participant it comes from
    direct: set[str] = field(default_factory=set)               # received meshes it accesses directly (no mapping)
    writes: dict[str, str] = field(default_factory=dict)        # data -> mesh
    reads: dict[str, str] = field(default_factory=dict)
    mappings: list[Mapping] = field(default_factory=list)
    watch_points: list[dict[str, Any]] = field(default_factory=list)
    exports: list[dict[str, Any]] = field(default_factory=list)   # <export:vtu|vtk|csv>: written by the participant


@dataclass
class Exchange:
    data: str
    mesh: str
    source: str
    target: str
    initialize: bool
    line: int
    substeps: bool = False          # every substep's values are sent (v3's default)
    substeps_given: bool = False    # substeps="true" written out


@dataclass
class Config:
    """What a configuration holds, by name."""

    path: Path
    version: int
    data: dict[str, dict[str, Any]] = field(default_factory=dict)       # name -> {vector, degree, line}
    meshes: dict[str, dict[str, Any]] = field(default_factory=dict)     # name -> {dimensions, data, line}
    participants: dict[str, Participant] = field(default_factory=dict)
    exchange_directories: dict[str, str] = field(default_factory=dict)  # participant -> its m2n's directory
    scheme: dict[str, Any] = field(default_factory=dict)
    exchanges: list[Exchange] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    experimental: bool = False      # the experimental API (gradient data) unlocked


class _Reader:
    """Walks the tree; every element and attribute is either read or refused."""

    def __init__(self, path: Path):
        self.path = path

    def fail(self, element: Element, why: str) -> SceneError:
        return SceneError(f"{self.path}, line {element.line}: <{element.tag}>: {why}")

    def required(self, element: Element, name: str) -> str:
        value = element.get(name)
        if value is None or not value.strip():
            raise self.fail(element, f"the attribute '{name}' is required")
        return value.strip()

    def number(self, element: Element, name: str, default: float | None = None, integer: bool = False,
               low: float | None = None, above: float | None = None, high: float | None = None,
               below: float | None = None) -> float:
        """The attribute ``name`` as a number: at least ``low``, more than ``above``, at most ``high``, less than
        ``below`` (each if given); refused naming the file, line, element and attribute."""
        text = element.get(name)
        if text is None:
            if default is None:
                raise self.fail(element, f"the attribute '{name}' is required")
            return default
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise self.fail(element, f"'{name}' is {text!r}, not {'an integer' if integer else 'a number'}") \
                from None
        bounds = [f"at least {low:g}" if low is not None else "", f"above {above:g}" if above is not None else "",
                  f"at most {high:g}" if high is not None else "", f"below {below:g}" if below is not None else ""]
        if not math.isfinite(value) or (low is not None and value < low) or (above is not None and value <= above) \
                or (high is not None and value > high) or (below is not None and value >= below):
            raise self.fail(element, f"'{name}' is {text}; allowed: {' and '.join(b for b in bounds if b) or 'finite'}")
        return value

    def flag(self, element: Element, name: str, default: bool = False) -> bool:
        text = element.get(name)
        if text is None:
            return default
        if text.strip().lower() in ("true", "yes", "1", "on"):
            return True
        if text.strip().lower() in ("false", "no", "0", "off"):
            return False
        raise self.fail(element, f"'{name}' is {text!r}; allowed: true or false")

    def done(self, element: Element) -> None:
        """Refuse an attribute nothing read."""
        unread = sorted(set(element.attributes) - element.used)
        if unread:
            raise self.fail(element, f"the attribute '{unread[0]}' is not supported (cosim reads: "
                                     f"{', '.join(sorted(element.used)) or 'none'}); remove it")

    def value_child(self, element: Element, integer: bool = False, low: float | None = None,
                    above: float | None = None, high: float | None = None) -> float:
        value = self.number(element, "value", integer=integer, low=low, above=above, high=high)
        self.done(element)
        for child in element.children:
            raise self.fail(child, "no element goes here")
        return value


def read_config(path: str | Path) -> Config:
    """Read a preCICE v2 or v3 configuration; any element or attribute cosim does not support is refused."""
    path = Path(path).resolve()
    root = parse(path)
    reader = _Reader(path)
    if root.tag != "precice-configuration":
        raise reader.fail(root, "the root element of a preCICE configuration is <precice-configuration>")
    experimental = reader.flag(root, "experimental")    # v3's gate on experimental API calls (gradients)
    reader.flag(root, "allow-remeshing")    # a participant's reset_mesh is refused when called
    reader.done(root)
    children = root.children
    version = 3
    dimensions = 0
    v2 = [c for c in children if c.tag == "solver-interface"]
    if v2:
        version = 2
        interface = v2[0]
        dimensions = int(reader.number(interface, "dimensions", integer=True, low=1))
        if dimensions not in (2, 3):
            raise reader.fail(interface, f"'dimensions' is {dimensions}; allowed: 2 or 3")
        experimental = reader.flag(interface, "experimental") or experimental
        reader.done(interface)
        children = [c for c in children if c.tag != "solver-interface"] + interface.children
    config = Config(path, version, experimental=experimental)
    for element in children:
        prefix, kind = element.kind()
        if element.tag in ("log", "profiling") or prefix in ("export",):
            config.notes.append(f"<{element.tag}> (line {element.line}) is output only: results.h5 and the run's "
                                "logs hold what the run computed")
        elif prefix == "data":
            _data(reader, config, element, kind)
        elif element.tag == "mesh":
            _mesh(reader, config, element, dimensions)
        elif element.tag == "participant":
            _participant(reader, config, element)
        elif prefix == "m2n":
            _m2n(reader, config, element)
        elif prefix == "coupling-scheme":
            if config.scheme:
                raise reader.fail(element, "a second coupling scheme: cosim couples two participants with one "
                                           "scheme")
            _scheme(reader, config, element, kind)
        else:
            raise reader.fail(element, "this element is not supported by cosim; see 'Bring your preCICE case' "
                                       "for what is")
    if not config.scheme:
        raise SceneError(f"{path}: no <coupling-scheme:...>: the configuration couples nothing")
    _check(reader, config)
    return config


def _data(reader: _Reader, config: Config, element: Element, kind: str) -> None:
    if kind not in ("scalar", "vector"):
        raise reader.fail(element, "data is 'data:scalar' or 'data:vector'")
    name = reader.required(element, "name")
    # v3: linear in time by default; v2 reads the window's end (its read-data's waveform-order may say otherwise)
    degree = int(reader.number(element, "waveform-degree", default=1 if config.version >= 3 else 0, integer=True,
                               low=0))
    if degree > 3:
        raise reader.fail(element, f"'waveform-degree' is {degree}; allowed: 0 to 3 (0: the window-end value, 1: "
                                   "linear, 2 and 3: B-splines through the substeps)")
    reader.done(element)
    if name in config.data:
        raise reader.fail(element, f"data '{name}' is defined twice")
    config.data[name] = {"vector": kind == "vector", "degree": degree, "line": element.line}


def _mesh(reader: _Reader, config: Config, element: Element, dimensions: int) -> None:
    name = reader.required(element, "name")
    if config.version == 3:
        dimensions = int(reader.number(element, "dimensions", integer=True, low=2))
        if dimensions not in (2, 3):
            raise reader.fail(element, f"'dimensions' is {dimensions}; allowed: 2 or 3")
    reader.done(element)
    used = []
    for child in element.children:
        if child.tag != "use-data":
            raise reader.fail(child, "a mesh holds <use-data name=\"...\"/> elements only")
        data = reader.required(child, "name")
        reader.done(child)
        if data not in config.data:
            raise reader.fail(child, f"no data '{data}' is defined (data: {', '.join(config.data) or 'none'})")
        used.append(data)
    if name in config.meshes:
        raise reader.fail(element, f"mesh '{name}' is defined twice")
    config.meshes[name] = {"dimensions": dimensions, "data": used, "line": element.line}


def _mesh_of(reader: _Reader, config: Config, element: Element, name: str) -> str:
    if name not in config.meshes:
        raise reader.fail(element, f"no mesh '{name}' is defined (meshes: {', '.join(config.meshes) or 'none'})")
    return name


def _participant(reader: _Reader, config: Config, element: Element) -> None:
    participant = Participant(reader.required(element, "name"), element.line)
    reader.done(element)
    if participant.name in config.participants:
        raise reader.fail(element, f"participant '{participant.name}' is defined twice")
    for child in element.children:
        prefix, kind = child.kind()
        if child.tag == "provide-mesh":
            participant.provides.append(_mesh_of(reader, config, child, reader.required(child, "name")))
            reader.done(child)
        elif child.tag == "receive-mesh":
            mesh = _mesh_of(reader, config, child, reader.required(child, "name"))
            participant.receives[mesh] = reader.required(child, "from")
            child.get("safety-factor")
            child.get("geometric-filter")
            if reader.flag(child, "direct-access") or reader.flag(child, "api-access"):
                participant.direct.add(mesh)
            reader.done(child)
        elif child.tag == "use-mesh":        # v2
            mesh = _mesh_of(reader, config, child, reader.required(child, "name"))
            source = child.get("from")
            if reader.flag(child, "provide"):
                participant.provides.append(mesh)
            elif source:
                participant.receives[mesh] = source
            else:
                raise reader.fail(child, "a mesh is used with provide=\"yes\" or from=\"PARTICIPANT\"")
            child.get("safety-factor")
            child.get("geometric-filter")
            reader.done(child)
        elif child.tag in ("write-data", "read-data"):
            data, mesh = reader.required(child, "name"), _mesh_of(reader, config, child, reader.required(child, "mesh"))
            if data not in config.data:
                raise reader.fail(child, f"no data '{data}' is defined (data: {', '.join(config.data) or 'none'})")
            if data not in config.meshes[mesh]["data"]:
                raise reader.fail(child, f"mesh '{mesh}' does not use data '{data}' (add <use-data name=\"{data}\"/> "
                                         "to the mesh)")
            order = child.get("waveform-order")         # v2: the degree, on the reader's side
            if order is not None:
                if child.tag != "read-data":
                    raise reader.fail(child, "'waveform-order' goes on a <read-data>")
                degree = int(reader.number(child, "waveform-order", integer=True, low=0))
                if degree > 3:
                    raise reader.fail(child, f"'waveform-order' is {degree}; allowed: 0 to 3")
                config.data[data]["degree"] = degree
            reader.done(child)
            (participant.writes if child.tag == "write-data" else participant.reads)[data] = mesh
        elif prefix == "mapping":
            participant.mappings.append(_mapping(reader, config, child, kind))
        elif child.tag == "watch-point":
            name = reader.required(child, "name")
            if not file_name_part(name):
                raise reader.fail(child, f"the watch point's name {name!r} must be a plain name: it becomes a file "
                                         "name (precice-<participant>-watchpoint-<name>.log), so no '/' and not '..'")
            participant.watch_points.append({"name": name,
                                             "mesh": _mesh_of(reader, config, child, reader.required(child, "mesh")),
                                             "coordinate": _coordinate(reader, child)})
            reader.done(child)
        elif prefix == "export" and kind in EXPORT_FORMATS:
            participant.exports.append(_export(reader, child, kind))
        elif prefix == "export" or prefix in ("intra-comm", "master"):
            what = ("cosim writes exports as vtu, vtk and csv: run.xdmf beside results.h5 holds every field for "
                    "ParaView" if prefix == "export" else "cosim's participants reach the coupler by its own "
                    "transport")
            config.notes.append(f"<{child.tag}> of participant '{participant.name}' (line {child.line}) is "
                                f"accepted and not used: {what}")
        elif prefix == "action":
            raise reader.fail(child, "actions are not supported by cosim: compute the quantity in the participant")
        elif child.tag == "watch-integral":
            raise reader.fail(child, "watch integrals are not supported by cosim: a <watch-point> logs the data at "
                                     "a vertex, and results.h5 holds every field at every window")
        else:
            raise reader.fail(child, "this element of a participant is not supported by cosim")
    config.participants[participant.name] = participant


def _export(reader: Any, element: Element, kind: str) -> dict[str, Any]:
    """An ``<export:vtu|vtk|csv>``: the folder (the participant's own, relative to where it runs), how often."""
    export = {"format": kind, "directory": element.get("directory") or ".",
              "every_n_time_windows": int(reader.number(element, "every-n-time-windows", 1, integer=True)),
              "every_iteration": reader.flag(element, "every-iteration"), "line": element.line}
    element.get("normals")           # v2: the mesh's normals, which cosim's meshes do not have
    element.get("update-series")
    reader.done(element)
    return export


def _coordinate(reader: _Reader, element: Element) -> list[float]:
    text = reader.required(element, "coordinate")
    try:
        return [float(v) for v in text.replace(",", ";").split(";")]
    except ValueError:
        raise reader.fail(element, f"'coordinate' is {text!r}; expected numbers separated by ';'") from None


def _mapping(reader: _Reader, config: Config, element: Element, kind: str) -> Mapping:
    direction = reader.required(element, "direction")
    if direction not in ("read", "write"):
        raise reader.fail(element, f"'direction' is {direction!r}; allowed: read or write")
    given = {end: element.get(end) for end in ("from", "to")}
    if given["from"] is None and given["to"] is None:
        raise reader.fail(element, "a mapping names its meshes: 'from' and 'to' (one of them for a just-in-time "
                                   "mapping)")
    jit = given["to"] is None if direction == "read" else given["from"] is None     # preCICE's just-in-time form
    if given["from"] is None or given["to"] is None:
        if not jit:
            raise reader.fail(element, f"the attribute '{'from' if given['from'] is None else 'to'}' is required "
                                       f"(a {direction} mapping without it is a just-in-time one only without "
                                       f"'{'to' if direction == 'read' else 'from'}')")
    source = _mesh_of(reader, config, element, given["from"]) if given["from"] is not None else ""
    target = _mesh_of(reader, config, element, given["to"]) if given["to"] is not None else ""
    constraint = reader.required(element, "constraint")
    if constraint not in ("consistent", "conservative"):
        raise reader.fail(element, f"'constraint' is {constraint!r}; cosim maps 'consistent' or 'conservative' "
                                   "data (scaled-consistent mappings are not supported)")
    timing = element.get("timing")
    if timing not in (None, "initial", "onadvance", "ondemand"):
        raise reader.fail(element, f"'timing' is {timing!r}")
    settings: dict[str, Any] = {"constraint": constraint}
    if kind == "nearest-neighbor":
        mapped = "nearest-neighbour"
    elif kind in V2_RBF or kind in V3_RBF:
        settings.update(_rbf_settings(reader, config, element, kind))
        mapped = "rbf"
    elif kind == "nearest-projection":
        mapped = "nearest-element"
        settings.update(local_coordinate_tolerance=0.0, without_elements="nearest-node")
    elif kind == "linear-cell-interpolation":
        mapped = "cell-interpolation"
        settings["without_elements"] = "nearest-node"
    elif kind == "nearest-neighbor-gradient":
        if constraint != "consistent":
            raise reader.fail(element, "nearest-neighbor-gradient maps consistent data only (a gradient corrects "
                                       "values, not sums)")
        mapped = "nearest-neighbour-gradient"
    elif kind in ("axial-geometric-multiscale", "radial-geometric-multiscale"):
        raise reader.fail(element, f"the mapping {kind!r} is not supported by cosim: use nearest-neighbor, "
                                   "nearest-neighbor-gradient, nearest-projection, linear-cell-interpolation or rbf")
    elif kind == "coarse-graining":
        raise reader.fail(element, "the mapping 'coarse-graining' (particles to a continuum) is not supported by "
                                   "cosim: use nearest-neighbor, nearest-neighbor-gradient, nearest-projection, "
                                   "linear-cell-interpolation or rbf")
    else:
        raise reader.fail(element, f"unknown mapping kind {kind!r}")
    reader.done(element)
    if kind not in V3_RBF:
        for child in element.children:
            raise reader.fail(child, "no element goes here")
    if jit and (mapped != "nearest-neighbour" or (direction, constraint) not in (("read", "consistent"),
                                                                                  ("write", "conservative"))):
        raise reader.fail(element, "a just-in-time mapping is nearest-neighbor, read consistent or write "
                                   f"conservative, in cosim (not {kind} {direction} {constraint})")
    return Mapping(mapped, direction, source, target, constraint, settings, element.line)


def _rbf_settings(reader: _Reader, config: Config, element: Element, kind: str) -> dict[str, Any]:
    """An RBF mapping's basis, its parameters, polynomial and dead axes, as cosim's ``rbf`` mapping's settings."""
    if kind in V3_RBF:
        bases = [c for c in element.children if c.kind()[0] == "basis-function"]
        executors = [c for c in element.children if c.kind()[0] == "executor"]
        others = [c for c in element.children if c not in bases and c not in executors]
        if others:
            raise reader.fail(others[0], "no element goes here: an RBF mapping holds a <basis-function:...> and "
                                         "at most one <executor:...>")
        if len(bases) != 1 or len(executors) > 1:
            raise reader.fail(element, "an RBF mapping holds one <basis-function:...> element and at most one "
                                       "<executor:...>")
        for executor in executors:
            if executor.kind()[1] not in EXECUTORS[kind]:
                raise reader.fail(executor, f"<mapping:{kind}> takes no executor {executor.kind()[1]!r} (preCICE's "
                                            f"for it: {', '.join(EXECUTORS[kind]) or 'none'})")
            for attribute in ("gpu-device-id", "n-threads"):
                if executor.get(attribute) is not None:
                    reader.number(executor, attribute, integer=True, low=0)
            executor.get("execution-mode")
            reader.done(executor)
            config.notes.append(f"<{executor.tag}> (line {executor.line}) is accepted and not used: cosim solves "
                                "the RBF system on the CPU (the same interpolant, to the solver's round-off)")
        holder, basis = bases[0], bases[0].kind()[1]
        if basis not in BASES:
            raise reader.fail(holder, f"unknown basis function {basis!r}; preCICE's: {', '.join(BASES)}")
    else:
        holder, basis = element, V2_RBF[kind]
    settings: dict[str, Any] = {"basis": basis}
    for attribute, key in (("support-radius", "support_radius"), ("shape-parameter", "shape_parameter")):
        if holder.get(attribute) is not None:
            settings[key] = reader.number(holder, attribute, low=0.0)
    needs = ("support-radius" if basis in COMPACT_BASES else "shape-parameter or a support-radius"
             if basis == "gaussian" else "shape-parameter" if basis in ("multiquadrics", "inverse-multiquadrics")
             else None)
    given = [key for key in ("support_radius", "shape_parameter") if key in settings]
    if needs and (not given or (basis == "gaussian" and len(given) == 2)):
        raise reader.fail(holder, f"the {basis} basis needs a {needs}")
    polynomial = element.get("polynomial", "separate")
    if kind == "rbf" and polynomial != "separate":
        raise reader.fail(element, "<mapping:rbf> takes no 'polynomial': name the solver, mapping:rbf-global-direct")
    if polynomial not in ("separate", "on", "off"):
        raise reader.fail(element, f"'polynomial' is {polynomial!r}; allowed: separate, on, off")
    if polynomial == "on" and basis not in INTEGRATED_POLYNOMIAL:
        raise reader.fail(element, f"polynomial=\"on\" is not supported for the {basis} basis (preCICE's rule: "
                                   f"only {', '.join(INTEGRATED_POLYNOMIAL)}); use separate or off")
    settings["polynomial"] = polynomial
    dead = "".join(axis for axis in "xyz" if reader.flag(element, f"{axis}-dead"))
    if dead:
        settings["dead_axes"] = dead
    ignored = [name for name in ("solver-rtol", "preallocation", "use-qr-decomposition", "executor", "vertices-per-"
                                 "cluster", "relative-overlap", "project-to-input") if element.get(name) is not None]
    if kind in ("rbf-pum-direct", "rbf-global-iterative") or ignored:
        config.notes.append(f"<{element.tag}> (line {element.line}): cosim solves the global RBF system directly "
                            + ("(a partition of unity's clusters approximate that interpolant) " if kind ==
                               "rbf-pum-direct" else "")
                            + (f"; {', '.join(ignored)} do not apply" if ignored else ""))
    return settings


def _m2n(reader: _Reader, config: Config, element: Element) -> None:
    ends = [element.get("acceptor") or element.get("from"), element.get("connector") or element.get("to")]
    directory = element.get("exchange-directory") or "."
    for attribute in ("network", "port", "enforce-gather-scatter", "use-two-level-initialization"):
        element.get(attribute)
    reader.done(element)
    for name in ends:
        if name:
            config.exchange_directories[name] = directory
    config.notes.append(f"<{element.tag}> (line {element.line}): the transport is cosim's (its participants reach "
                        "the coupler on loopback)")


def _scheme(reader: _Reader, config: Config, element: Element, kind: str) -> None:
    if kind not in SCHEMES:
        raise reader.fail(element, f"the coupling scheme {kind!r} is not supported (cosim: {', '.join(SCHEMES)})")
    scheme: dict[str, Any] = {"kind": kind, "line": element.line, "measures": [], "acceleration": None}
    reader.done(element)
    controllers: list[str] = []
    for child in element.children:
        prefix, child_kind = child.kind()
        if child.tag == "participants" and kind != "multi":
            scheme["participants"] = [reader.required(child, "first"), reader.required(child, "second")]
            reader.done(child)
        elif child.tag == "participant" and kind == "multi":
            name = reader.required(child, "name")
            if name in scheme.setdefault("participants", []):
                raise reader.fail(child, f"participant '{name}' is named twice")
            scheme["participants"].append(name)
            if reader.flag(child, "control"):
                controllers.append(name)
            reader.done(child)
        elif child.tag == "max-time":
            scheme["max_time"] = reader.value_child(child, above=0.0)
        elif child.tag == "max-time-windows":
            scheme["max_windows"] = int(reader.value_child(child, integer=True, low=1))
        elif child.tag == "time-window-size":
            method = child.get("method")
            if method not in (None, "fixed"):
                raise reader.fail(child, "a window size the first participant chooses is not supported: give "
                                         "value=\"...\"")
            child.get("valid-digits")
            scheme["window"] = reader.value_child(child, above=0.0)
        elif child.tag == "max-iterations":
            scheme["max_iterations"] = int(reader.value_child(child, integer=True, low=1))
        elif child.tag == "min-iterations":
            scheme["min_iterations"] = int(reader.value_child(child, integer=True, low=1))
        elif child.tag == "extrapolation-order":
            scheme["extrapolation_order"] = int(reader.value_child(child, integer=True, low=0))
        elif child.tag == "exchange":
            given = child.get("substeps") is not None
            substeps = reader.flag(child, "substeps", default=config.version >= 3)
            if substeps and config.version < 3:
                raise reader.fail(child, "substeps is a preCICE v3 attribute (this configuration is v2)")
            config.exchanges.append(Exchange(reader.required(child, "data"), reader.required(child, "mesh"),
                                             reader.required(child, "from"), reader.required(child, "to"),
                                             reader.flag(child, "initialize"), child.line, substeps,
                                             given and substeps))
            reader.done(child)
        elif child.tag.endswith("-convergence-measure"):
            scheme["measures"].append(_measure(reader, child))
        elif prefix == "acceleration":
            if scheme["acceleration"] is not None:
                raise reader.fail(child, "a second acceleration")
            scheme["acceleration"] = _acceleration(reader, child, child_kind)
        else:
            raise reader.fail(child, "this element of a coupling scheme is not supported by cosim")
    if kind == "multi":
        if len(controllers) != 1:
            raise reader.fail(element, "exactly one <participant name=\"...\" control=\"yes\"/> must control a "
                                       f"multi-coupling, found {len(controllers)}")
        # the controller computes measures and acceleration in preCICE; cosim's coupler does, whoever controls
        scheme["participants"].remove(controllers[0])
        scheme["participants"].insert(0, controllers[0])
    config.scheme = scheme


def _measure(reader: _Reader, element: Element) -> dict[str, Any]:
    kind = element.tag
    data = reader.required(element, "data")
    element.get("mesh")
    strict = reader.flag(element, "strict")
    suffices = reader.flag(element, "suffices")
    if kind in MEASURES:
        measure = {"data": data, "type": MEASURES[kind], "limit": reader.number(element, "limit", above=0.0)}
    elif kind == "absolute-or-relative-convergence-measure":
        measure = {"data": data, "type": "any-of", "measures": [
            {"type": "absolute", "limit": reader.number(element, "abs-limit", above=0.0)},
            {"type": "relative", "limit": reader.number(element, "rel-limit", above=0.0)}]}
    elif kind == "min-iteration-convergence-measure":
        measure = {"data": data, "type": "min-iterations",
                   "iterations": int(reader.number(element, "min-iterations", integer=True, low=1))}
    else:
        raise reader.fail(element, "unknown convergence measure; cosim reads relative-, absolute-, "
                                   "residual-relative-, absolute-or-relative- and min-iteration-convergence-measure")
    reader.done(element)
    if suffices:
        measure["suffices"] = True
    measure["strict"] = strict
    measure["line"] = element.line
    return measure


def _acceleration(reader: _Reader, element: Element, kind: str) -> dict[str, Any]:
    reader.done(element)
    if kind not in ("constant", "aitken", "IQN-ILS", "IQN-IMVJ"):
        raise reader.fail(element, f"the acceleration {kind!r} is not supported (cosim: constant, aitken, IQN-ILS, "
                                   "IQN-IMVJ)")
    settings: dict[str, Any] = {"type": {"constant": "constant", "aitken": "aitken", "IQN-ILS": "iqn-ils",
                                         "IQN-IMVJ": "iqn-imvj"}[kind], "data": []}
    if kind == "IQN-ILS":     # preCICE keeps reused columns whatever the residual does, and reuses windows with columns
        settings.update(stale_step_ratio=0.0, count_emptied_windows=False)
    for child in element.children:
        if child.tag == "data":
            settings["data"].append(reader.required(child, "name"))
            child.get("mesh")
            if child.get("scaling") not in (None, "1", "1.0"):
                raise reader.fail(child, "a data scaling is not supported (cosim scales each data item by its norm)")
            reader.done(child)
        elif child.tag == "relaxation" and kind == "constant":
            settings["relaxation"] = reader.value_child(child, above=0.0, high=1.0)
        elif child.tag == "initial-relaxation" and kind != "constant":
            if reader.flag(child, "enforce"):
                raise reader.fail(child, "enforce=\"true\" is not supported")
            settings["initial_relaxation"] = reader.value_child(child, above=0.0, high=1.0)
        elif child.tag == "max-used-iterations" and kind.startswith("IQN"):
            settings["max_used_iterations"] = int(reader.value_child(child, integer=True, low=1))
        elif child.tag == "time-windows-reused" and kind.startswith("IQN"):
            reused = int(reader.value_child(child, integer=True, low=0))
            if kind == "IQN-ILS":
                settings["reused_time_windows"] = reused
            elif reused:
                raise reader.fail(child, "IQN-IMVJ keeps its Jacobian across windows; cosim reuses no columns "
                                         "with it (time-windows-reused 0)")
        elif child.tag == "filter" and kind.startswith("IQN"):
            kind_of_filter = reader.required(child, "type")
            if kind_of_filter not in FILTERS:
                raise reader.fail(child, f"the filter {kind_of_filter!r} is not supported (cosim: QR1, "
                                         "QR1-absolute, QR2)")
            settings["filter"] = FILTERS[kind_of_filter]
            settings["filter_limit"] = reader.number(child, "limit", default=1e-16 if kind_of_filter == "QR1" else
                                                     1e-2, above=0.0, below=1.0)
            reader.done(child)
        elif child.tag == "preconditioner" and kind.startswith("IQN"):
            preconditioner = reader.required(child, "type")
            if preconditioner not in PRECONDITIONERS:
                raise reader.fail(child, f"'type' is {preconditioner!r}; allowed: {', '.join(PRECONDITIONERS)}")
            freeze = reader.number(child, "freeze-after", default=-1, integer=True, low=-1)
            reader.done(child)
            settings["preconditioner"] = preconditioner      # checked against the accelerated data below
            settings["preconditioner_line"] = child.line
            if freeze > 0:
                settings["freeze_after"] = int(freeze)
        elif child.tag == "imvj-restart-mode" and kind == "IQN-IMVJ":
            mode = reader.required(child, "type")
            if mode == "RS-ZERO":
                settings["restart_windows"] = int(reader.number(child, "chunk-size", default=8, integer=True, low=1))
            elif mode != "no-restart":
                raise reader.fail(child, f"the restart mode {mode!r} is not supported (cosim: RS-ZERO, no-restart)")
            child.get("truncation-threshold")
            child.get("reused-time-windows-at-restart")
            reader.done(child)
        elif child.tag == "always-build-jacobian" and kind == "IQN-IMVJ":
            reader.value_child(child)
        else:
            raise reader.fail(child, f"this element of acceleration:{kind} is not supported by cosim")
    settings["line"] = element.line
    return settings


def _check(reader: _Reader, config: Config) -> None:
    """What only the whole configuration can say: the scheme's participants and exchanges fit the participants."""
    scheme = config.scheme
    where = f"{config.path}, line {scheme['line']}: <coupling-scheme:{scheme['kind']}>"
    names = scheme.get("participants")
    if not names:
        raise SceneError(f"{where}: <participants first=\"...\" second=\"...\"/> is required")
    if len(names) < 2:
        raise SceneError(f"{where}: a multi-coupling needs two or more <participant name=\"...\"/>")
    for name in names:
        if name not in config.participants:
            raise SceneError(f"{where}: participant '{name}' is not defined (participants: "
                             f"{', '.join(config.participants) or 'none'})")
    if names[0] == names[1]:
        raise SceneError(f"{where}: the first and second participants are both '{names[0]}'")
    if "window" not in scheme:
        raise SceneError(f"{where}: <time-window-size value=\"...\"/> is required")
    if "max_time" not in scheme and "max_windows" not in scheme:
        raise SceneError(f"{where}: <max-time value=\"...\"/> or <max-time-windows value=\"...\"/> is required")
    if not config.exchanges:
        raise SceneError(f"{where}: it exchanges nothing (no <exchange .../>)")
    for name, participant in config.participants.items():
        for mesh, source in participant.receives.items():
            if source not in config.participants:
                raise SceneError(f"{config.path}, line {participant.line}: participant '{name}' receives mesh "
                                 f"'{mesh}' from '{source}', which is not a participant")
            if mesh not in config.participants[source].provides:
                raise SceneError(f"{config.path}, line {participant.line}: participant '{name}' receives mesh "
                                 f"'{mesh}' from '{source}', which does not provide it")
        for data, mesh in {**participant.writes, **participant.reads}.items():
            if mesh not in participant.provides and mesh not in participant.receives:
                raise SceneError(f"{config.path}, line {participant.line}: participant '{name}' writes or reads "
                                 f"'{data}' on mesh '{mesh}', which it neither provides nor receives")
            if mesh in participant.receives and mesh not in participant.direct:
                raise SceneError(f"{config.path}, line {participant.line}: participant '{name}' writes or reads "
                                 f"'{data}' on mesh '{mesh}', which it receives without direct-access=\"true\" "
                                 "(map the data onto a mesh of its own, or access this one directly)")
        for mapping in participant.mappings:
            own = mapping.target if mapping.direction == "read" else mapping.source
            other = mapping.source if mapping.direction == "read" else mapping.target
            if not own:         # just in time: onto a received mesh accessed directly, from coordinates given then
                if other not in participant.direct:
                    raise SceneError(f"{config.path}, line {mapping.line}: participant '{name}' maps just in time "
                                     f"{'from' if mapping.direction == 'read' else 'to'} mesh '{other}', which it "
                                     "does not receive with api-access=\"true\"")
                continue
            if own not in participant.provides or other not in participant.receives:
                raise SceneError(f"{config.path}, line {mapping.line}: participant '{name}' maps {mapping.direction} "
                                 f"from '{mapping.source}' to '{mapping.target}': a {mapping.direction} mapping goes "
                                 f"{'from a received mesh to a provided one' if mapping.direction == 'read' else 'from a provided mesh to a received one'}")
    for exchange in config.exchanges:
        at = f"{config.path}, line {exchange.line}: <exchange data=\"{exchange.data}\">"
        for name in (exchange.source, exchange.target):
            if name not in names:
                raise SceneError(f"{at}: '{name}' is not a participant of the coupling scheme ({', '.join(names)})")
        if exchange.data not in config.data:
            raise SceneError(f"{at}: no data '{exchange.data}' is defined")
        if exchange.mesh not in config.meshes:
            raise SceneError(f"{at}: no mesh '{exchange.mesh}' is defined")
        if exchange.data not in config.participants[exchange.source].writes:
            raise SceneError(f"{at}: participant '{exchange.source}' does not write '{exchange.data}'")
        if exchange.data not in config.participants[exchange.target].reads:
            raise SceneError(f"{at}: participant '{exchange.target}' does not read '{exchange.data}'")
        if exchange.data not in config.meshes[exchange.mesh]["data"]:
            raise SceneError(f"{at}: mesh '{exchange.mesh}' does not use data '{exchange.data}'")
    for measure in scheme["measures"]:
        if measure["data"] not in {e.data for e in config.exchanges}:
            raise SceneError(f"{config.path}, line {measure['line']}: the measure's data '{measure['data']}' is not "
                             "exchanged by the coupling scheme")
    acceleration = scheme["acceleration"]
    iterated = {e.data for e in config.exchanges if scheme["kind"] in ("parallel-implicit", "multi")
                or (scheme["kind"] == "serial-implicit" and e.source == names[1])}
    if acceleration is not None and acceleration["type"] == "constant" and not acceleration["data"]:
        # preCICE relaxes all the data the scheme iterates when constant relaxation names none
        acceleration["data"] = list(dict.fromkeys(e.data for e in config.exchanges if e.data in iterated))
    for exchange in config.exchanges:
        held = acceleration is not None and exchange.data in acceleration["data"]
        if exchange.substeps and exchange.data in iterated and acceleration is not None and not held:
            if exchange.substeps_given:
                raise SceneError(f"{config.path}, line {exchange.line}: <exchange data=\"{exchange.data}\" "
                                 f"substeps=\"true\">: the acceleration (line {acceleration['line']}) does not hold "
                                 f"'{exchange.data}', and the samples of every substep are iterated by it: add <data "
                                 f"name=\"{exchange.data}\" .../> to the acceleration, or substeps=\"false\"")
            exchange.substeps = False       # the default: its window's end alone, as the acceleration sees it
    if acceleration is not None:
        for data in acceleration["data"]:
            if data not in {e.data for e in config.exchanges}:
                raise SceneError(f"{config.path}, line {acceleration['line']}: the accelerated data '{data}' is not "
                                 "exchanged by the coupling scheme")
        line = acceleration.pop("preconditioner_line", acceleration["line"])
        if acceleration["type"] == "iqn-imvj":       # cosim's IQN-IMVJ works on the data unscaled
            preconditioner = acceleration.pop("preconditioner", "constant")
            if len(acceleration["data"]) > 1 and (preconditioner != "constant" or acceleration.pop("freeze_after", 0)):
                raise SceneError(f"{config.path}, line {line}: the preconditioner {preconditioner!r}: cosim's "
                                 "IQN-IMVJ does not scale its data (type \"constant\"); use IQN-ILS to scale them")
            acceleration.pop("freeze_after", None)
    if scheme.get("min_iterations", 1) > scheme.get("max_iterations", 100):
        raise SceneError(f"{where}: <min-iterations value=\"{scheme['min_iterations']}\"/> is above "
                         f"<max-iterations value=\"{scheme.get('max_iterations', 100)}\"/>: no window could converge")
    if (scheme["kind"].endswith("implicit") or scheme["kind"] == "multi") and not scheme["measures"] \
            and not scheme.get("min_iterations"):      # min-iterations alone: every window takes that many, as preCICE
        raise SceneError(f"{where}: an implicit scheme needs a convergence measure or <min-iterations>")
