"""The coupler's part of a scene, each rule in one place: the ``coupling`` table and the ``[[exchange]]`` list
(their schemas and meanings), the rules across them, the components and the time grid, and the plug-ins they name
resolved into their classes' settings. The scene layer (``cosim.scene``) reads the file, the overrides and the
component table, and hands these tables here (the ``cosim.scene_rules`` entry point ``coupling``); the scheme
classes alone say which schemes are explicit.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import Any

from cosim.component import declares_state, undeclared_state_message
from cosim.errors import CosimError, SceneError
from cosim.scene import Scene, string_list, table_list
from cosim.schema import AnyTable, Choice, PluginChoice, Positive, Required, Value, validate
from cosim.server import load_entry
from coupler.accelerations import resolve_acceleration
from coupler.convergence import resolve_measure
from coupler.mapping import MAPPINGS
from coupler.schemes import SCHEMES
from coupler.surrogate import SETTINGS as SURROGATE_SETTINGS
from coupler.surrogate import InterfaceSurrogate, load_model_class

COUPLING: dict[str, Any] = {
    "scheme": "serial-implicit",
    "participants": Required(list),
    "max_iterations": Positive(50),
    "on_max_iterations": Choice("fail", ("fail", "accept")),
    "divergence_factor": Value(1e3, low=1.0, low_open=True),  # residual growth in a window that is divergence
    "extrapolation_order": Value(0, low=0, high=2),
    # the first iterate of a window: "none" (the last window's values, extrapolated by extrapolation_order)
    # or "acceleration" (the acceleration's update from the last window's converged iteration)
    "predictor": Choice("none", ("none", "acceleration", "surrogate")),
    "acceleration": PluginChoice("none"),
    "first_iterate_zero": [],
    # the online interface surrogate (checked by the coupler against its own settings)
    "surrogate": AnyTable(),
}
EXCHANGE = {"data": Required(str), "from": Required(str), "to": Required(str), "mapping": PluginChoice("identity"),
            "waveform_degree": Value(0, low=0, high=3), "substeps": False, "scale": 1.0,
            "at_window_end": False}
MEANINGS = {
    "coupling.scheme": "the coupling scheme: a registered scheme's name (below)",
    "coupling.participants": "the components the scheme couples, in its order (serial: the first goes first); two, "
                             "or two or more for multi",
    "coupling.max_iterations": "the coupling iterations a window may take",
    "coupling.first_iterate_zero": "parallel schemes: data whose initial values the measures and the acceleration "
                                   "take as zero in the first iteration of the first window, though the receiver "
                                   "gets them (preCICE does so for initial data the accelerating participant "
                                   "receives)",
    "coupling.on_max_iterations": "a window that reaches max_iterations: stop the run ('fail') or take the last "
                                  "iterate with a warning ('accept')",
    "coupling.divergence_factor": "a window whose coupling residual grows by this factor has diverged: the run stops",
    "coupling.extrapolation_order": "the first iterate of a window from the last windows' values: 0 repeats the last "
                                    "value, 1 linear, 2 quadratic",
    "coupling.predictor": "'acceleration': a window starts from the acceleration's update of the last window's "
                          "converged iteration instead (extrapolation_order must be 0); 'surrogate': from the "
                          "fixed point of the online surrogate (coupling.surrogate, below)",
    "coupling.surrogate": "the online interface surrogate: a table with start_window turns it on (its keys below)",
    "coupling.acceleration": "the acceleration: a registered acceleration's name or table (below), with `data`, "
                             "the exchanged data it accelerates",
    "coupling.convergence": "`[[coupling.convergence]]`: one convergence measure per table (below), each on the "
                            "exchanged variable `data`; a window has converged when all of them are met, or one "
                            "with `suffices = true` is (preCICE's suffices)",
    "exchange.data": "the exchanged variable's name (an output of `from`, an input of `to`)",
    "exchange.from": "the component that sends it",
    "exchange.to": "the component that receives it",
    "exchange.at_window_end": "the receiver gets the window's last values when the window converges "
                              "(Component.end_window), as Kratos's coupler writes data after the last solve",
    "exchange.scale": "a factor on the mapped values (-1: the sign swapped, as a reaction becomes a load)",
    "exchange.mapping": "how values go from the sender's mesh to the receiver's: a registered mapping (below)",
    "exchange.waveform_degree": "the receiver's interpolation in time across the window (docs/time.md): 0, the "
                                "window-end value at every step; 1, linear through the window's start, the sender's "
                                "substeps and its end; 2 or 3, the B-spline of that degree through them",
    "exchange.substeps": "the sender's values at each of its steps inside the window are sent, not only the "
                         "window's end (a participant that subcycles); the acceleration works on all of them",
}


def is_explicit(scheme: str) -> bool:
    """Whether the registered scheme ``scheme`` takes one iteration a window (its class says)."""
    return not SCHEMES.classes[scheme].implicit


class CouplingRules:
    """The ``coupling`` table and the ``[[exchange]]`` list of a scene (the ``cosim.scene_rules`` entry point)."""

    tables = ("coupling", "exchange")
    schemas = {"coupling": COUPLING}      # the plain tables, for the reference page ([[exchange]] has its own)
    meanings = MEANINGS

    def validate(self, raw: dict[str, Any], data: dict[str, Any], source: str) -> None:
        """Both tables of ``raw`` validated into ``data`` (defaults filled in), then the rules across them."""
        given = raw.get("coupling", {})
        if not isinstance(given, dict):
            raise SceneError(f"{source}: 'coupling' must be a table, got {given!r}")
        convergence = given.get("convergence", [])
        data["coupling"] = validate({k: v for k, v in given.items() if k != "convergence"}, COUPLING, "coupling.",
                                    source)
        data["coupling"]["convergence"] = [dict(m) for m in table_list(convergence, "coupling.convergence", source)]
        data["exchange"] = [validate(e, EXCHANGE, f"exchange.{i}.", source)
                            for i, e in enumerate(table_list(raw.get("exchange", []), "exchange", source))]
        check_coupling(data, source)


RULES = CouplingRules()


def check_coupling(data: dict[str, Any], source: str) -> None:
    """The rules across the coupling, the exchanges, the components and the output."""
    coupling = data["coupling"]
    SCHEMES.lookup(coupling["scheme"], "coupling.scheme", source)
    explicit = is_explicit(coupling["scheme"])
    names = set(data["components"])
    if coupling["predictor"] == "acceleration" and coupling["extrapolation_order"] > 0:
        raise SceneError(f"{source}: 'coupling.predictor' = \"acceleration\" replaces extrapolation; "
                         f"'coupling.extrapolation_order' must be 0, got {coupling['extrapolation_order']}")
    acceleration = coupling["acceleration"]
    accelerated = acceleration.get("data", []) if isinstance(acceleration, dict) else []
    if not isinstance(accelerated, list):
        raise SceneError(f"{source}: 'coupling.acceleration.data' must be a list, got {accelerated!r}")
    participants = coupling["participants"]
    string_list(participants, "coupling.participants", source)
    if SCHEMES.classes[coupling["scheme"]].many_participants:
        if len(participants) < 2 or len(set(participants)) != len(participants):
            raise SceneError(f"{source}: 'coupling.participants' must name two or more different components "
                             f"for {coupling['scheme']}, got {participants}")
    elif len(participants) != 2 or len(set(participants)) != 2:
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
        exchanged.add(exchange["data"])
    if not exchanged:
        raise SceneError(f"{source}: the scene exchanges no data (add [[exchange]] tables)")
    for i, measure in enumerate(coupling["convergence"]):
        minimum = measure.get("iterations") if measure.get("type") == "min-iterations" else None
        if isinstance(minimum, int) and not isinstance(minimum, bool) and minimum > coupling["max_iterations"]:
            raise SceneError(f"{source}: 'coupling.convergence.{i}.iterations' is {minimum}, above "
                             f"'coupling.max_iterations' ({coupling['max_iterations']}): no window could converge")
        if "data" in measure and measure["data"] not in exchanged:
            raise SceneError(f"{source}: 'coupling.convergence.{i}.data' is {measure['data']!r}, "
                             f"not exchanged data ({', '.join(sorted(exchanged))})")
    second = participants[1]
    fed_back = sorted(e["data"] for e in data["exchange"] if e["from"] == second)
    zeroed = coupling["first_iterate_zero"]
    string_list(zeroed, "coupling.first_iterate_zero", source)
    for i, name in enumerate(zeroed):
        if name not in exchanged:
            raise SceneError(f"{source}: 'coupling.first_iterate_zero.{i}' is {name!r}, not exchanged data "
                             f"({', '.join(sorted(exchanged))})")
    if zeroed and not SCHEMES.classes[coupling["scheme"]].takes_first_iterate_zero:
        raise SceneError(f"{source}: 'coupling.first_iterate_zero' is for the parallel implicit schemes, not "
                         f"{coupling['scheme']}")
    for i, name in enumerate(accelerated):
        where = f"coupling.acceleration.data.{i}"
        if not isinstance(name, str) or name not in exchanged:
            raise SceneError(f"{source}: '{where}' is {name!r}, not exchanged data ({', '.join(sorted(exchanged))})")
        if accelerated.index(name) != i:
            raise SceneError(f"{source}: '{where}' repeats '{name}'")
        if coupling["scheme"] == "serial-implicit" and name not in fed_back:
            raise SceneError(f"{source}: '{where}' is '{name}', but serial-implicit accelerates the data the second "
                             f"participant '{second}' sends: {', '.join(fed_back) or 'none'}")
    kind = acceleration.get("type", "none") if isinstance(acceleration, dict) else acceleration
    iterated = fed_back if coupling["scheme"] == "serial-implicit" else sorted(exchanged)
    for i, exchange in enumerate(data["exchange"]):
        if exchange["substeps"] and not explicit and kind != "none" and accelerated \
                and exchange["data"] in iterated and exchange["data"] not in accelerated:
            raise SceneError(f"{source}: 'exchange.{i}.substeps' is on for '{exchange['data']}', which the "
                             f"acceleration does not hold (coupling.acceleration.data: {', '.join(accelerated)}): "
                             "add it there, or exchange the window's end alone")
    if explicit and (kind != "none" or coupling["predictor"] != "none"):
        key = "coupling.acceleration" if kind != "none" else "coupling.predictor"
        raise SceneError(f"{source}: '{key}' is set, but {coupling['scheme']} takes one iteration a window and "
                         "accelerates nothing; use serial-implicit or parallel-implicit, or remove it")
    if not explicit and not coupling["convergence"]:
        raise SceneError(f"{source}: an implicit scheme needs at least one [[coupling.convergence]] measure")
    plot = data["output"]["plot_field"]
    if plot and plot not in exchanged:
        raise SceneError(f"{source}: 'output.plot_field' is '{plot}', not exchanged data")


def resolve_plugins(scene: Scene) -> None:
    """Validate every plug-in table of ``scene`` and fill in its defaults, in place (idempotent)."""
    source = scene.source
    coupling = scene.data["coupling"]
    SCHEMES.lookup(coupling["scheme"], "coupling.scheme", source)
    resolve_surrogate(scene)
    coupling["acceleration"] = resolve_acceleration(coupling["acceleration"], "coupling.acceleration", source)
    coupling["convergence"] = [resolve_measure(m, f"coupling.convergence.{i}", source)
                               for i, m in enumerate(coupling["convergence"])]
    for i, exchange in enumerate(scene.data["exchange"]):
        exchange["mapping"] = MAPPINGS.settings(exchange["mapping"], f"exchange.{i}.mapping", source)


def coupling_model(coupling: dict) -> InterfaceSurrogate | None:
    """The model of the coupled map a resolved ``coupling`` table asks for (its ``surrogate`` table), or None."""
    settings = coupling["surrogate"]
    if not settings.get("start_window"):
        return None
    model_class, model = load_model_class(settings["model_type"]), settings["model"]   # checked by resolve_plugins
    return InterfaceSurrogate(settings, settings["static"] == coupling["participants"][0], lambda: model_class(model),
                              predicts_start=coupling["predictor"] == "surrogate")


def check_model(surrogate: dict, source: str) -> None:
    """The surrogate's static model plug-in exists and takes its settings (checked now, not in the training
    thread)."""
    try:
        model_class = load_model_class(surrogate["model_type"])
    except KeyError as exc:
        raise SceneError(f"{source}: 'coupling.surrogate.model_type': {exc.args[0]}") from None
    try:
        model_class(surrogate["model"])
    except (ValueError, SceneError) as exc:
        raise SceneError(f"{source}: {exc}") from None


def resolve_surrogate(scene: Scene) -> None:
    """``coupling.surrogate`` checked and filled in; with it, the predictor and an IQN-ILS acceleration become the
    surrogate's unless the table says otherwise (``predictor``, ``jacobian``)."""
    source, coupling = scene.source, scene.data["coupling"]
    given = coupling.get("surrogate", {})
    surrogate = validate(given, SURROGATE_SETTINGS, "coupling.surrogate.", source)
    coupling["surrogate"] = surrogate
    on = surrogate["start_window"] > 0
    if given and "start_window" not in given:
        raise SceneError(f"{source}: 'coupling.surrogate' is given without 'coupling.surrogate.start_window' "
                         "(the window the surrogate starts in, at least 1; 0: no surrogate)")
    if coupling["predictor"] == "surrogate" and not on:
        raise SceneError(f"{source}: 'coupling.predictor' is \"surrogate\" but there is no 'coupling.surrogate' "
                         "table with a start_window")
    if not on:
        return
    if coupling["scheme"] != "serial-implicit":
        raise SceneError(f"{source}: 'coupling.surrogate' needs the serial-implicit scheme, not "
                         f"'{coupling['scheme']}'")
    if surrogate["training_windows"] == 1:
        raise SceneError(f"{source}: 'coupling.surrogate.training_windows' is 1; allowed: 0 (every call so far) or "
                         "at least 2 (the static model is validated across windows)")
    check_model(surrogate, source)
    participants = coupling["participants"]
    static = surrogate["static"] or next(
        (name for name in participants if scene.data["components"].get(name, {}).get("record")), "")
    if static not in participants:
        known = ", ".join(participants)
        raise SceneError(f"{source}: 'coupling.surrogate.static' is {surrogate['static']!r}: name the participant "
                         f"whose output depends on its input alone ({known})" if surrogate["static"] else
                         f"{source}: 'coupling.surrogate.static' is needed (no participant has record = true): name "
                         f"the participant whose output depends on its input alone ({known})")
    surrogate["static"] = static
    if surrogate["predictor"] and coupling["predictor"] in ("none", "acceleration"):
        coupling["predictor"] = "surrogate"
    acceleration = coupling["acceleration"]
    if surrogate["jacobian"] and isinstance(acceleration, dict) and acceleration.get("type") == "iqn-ils":
        coupling["acceleration"] = {**acceleration, "type": "iqn-surrogate"}
    elif surrogate["jacobian"] and acceleration == "iqn-ils":
        coupling["acceleration"] = "iqn-surrogate"


def check_state_declared(scene: Scene) -> None:
    """Implicit coupling repeats windows: every participant class importable here must say how (state methods,
    ``repeats_steps`` or ``stateless``); the others are checked once described."""
    if is_explicit(scene["coupling"]["scheme"]):
        return
    for name in scene["coupling"]["participants"]:
        spec = scene["components"][name]
        entries = [spec["entry"]] if spec["entry"] else []
        if spec["backend"] != "fom":
            entries.append(spec[spec["backend"]]["entry"])
        for entry in entries:
            try:
                cls = load_entry(entry, [scene.folder])
            except CosimError:
                continue        # reported where the entry is checked, or by its own process
            if not declares_state(cls):
                raise SceneError(f"{scene.source}: components.{name}: {undeclared_state_message(name, entry)}")


def check_described(scene: Scene, proxies: Mapping[str, Any]) -> None:
    """What the scene asks of its described components (``proxies``, all or some of them): each exchanged variable
    an output of its sender and an input of its receiver, and, under implicit coupling, a participant that says
    how it repeats a window."""
    for i, spec in enumerate(scene["exchange"]):
        data = spec["data"]
        for end, causality in (("from", "output"), ("to", "input")):
            proxy = proxies.get(spec[end])
            if proxy is None:
                continue      # cosim check: a component served by hand, or a participant, is described by its run
            variable = proxy.variables.get(data)
            why = getattr(proxy, "variable_notes", {}).get(data)
            if variable is None and why:
                raise SceneError(f"{scene.source}: 'exchange.{i}.data' is '{data}', but component '{spec[end]}' "
                                 f"cannot couple it: {why}")
            if variable is None or variable.causality != causality:
                names = [v.name for v in proxy.variables.values() if v.causality == causality]
                raise SceneError(f"{scene.source}: 'exchange.{i}.data' is '{data}', but component '{spec[end]}' has "
                                 f"no {causality} '{data}' ({causality}s: {', '.join(names) or 'none'})")
    if is_explicit(scene["coupling"]["scheme"]):
        return
    for name in (n for n in scene["coupling"]["participants"] if n in proxies):
        proxy = proxies[name]
        if not (proxy.can_get_and_set_state or proxy.repeats_steps or proxy.stateless):
            spec = scene["components"][name]
            note = getattr(proxy, "state_note", "")
            raise SceneError(f"{scene.source}: components.{name}: " + (
                f"coupled implicitly, which repeats each window until it converges, but {note}" if note
                else undeclared_state_message(name, spec["entry"] or spec["address"])))


def check_precision(measures: list[dict], precision: dict[str, float]) -> None:
    """Flag, at start, relative limits tighter than the precision the producer declares for the data."""
    def relative_limits(measure: dict, where: str):
        if measure["type"] == "relative":
            yield measure["limit"], where
        for i, member in enumerate(measure.get("measures", [])):
            if measure["type"] == "all-of" or len(measure["measures"]) == 1:
                yield from relative_limits(member, f"{where}.measures.{i}")
    for i, measure in enumerate(measures):
        carried = precision.get(measure["data"], 0.0)
        for limit, where in relative_limits(measure, f"coupling.convergence.{i}"):
            if 0.0 < limit < carried:
                print(f"warning: '{where}' asks for a relative change below {limit:g}, but '{measure['data']}' is "
                      f"computed to {carried:g} only: the window may stall; a residual-relative measure suits "
                      "such data", file=sys.stderr)
