"""The scene's plug-in tables (scheme, acceleration, convergence measures, mappings),
checked against the chosen plug-in classes' own settings before a run starts."""

from __future__ import annotations

from cosim.errors import SceneError
from cosim.scene import Scene
from cosim.schema import validate
from coupler.accelerations import resolve_acceleration
from coupler.convergence import resolve_measure
from coupler.mapping import MAPPINGS
from coupler.schemes import SCHEMES
from coupler.surrogate import SETTINGS as SURROGATE_SETTINGS


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


def check_model(surrogate: dict, source: str) -> None:
    """The surrogate's static model plug-in exists and takes its settings (checked now, not in the training
    thread)."""
    from coupler.surrogate import load_model_class
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
