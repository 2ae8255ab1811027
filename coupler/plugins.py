"""The scene's plug-in tables (scheme, acceleration, convergence measures, mappings),
checked against the chosen plug-in classes' own settings before a run starts."""

from __future__ import annotations

from cosim.scene import Scene
from coupler.acceleration import resolve_acceleration
from coupler.convergence import resolve_measure
from coupler.mapping import MAPPINGS
from coupler.schemes import SCHEMES


def resolve_plugins(scene: Scene) -> None:
    """Validate every plug-in table of ``scene`` and fill in its defaults, in place (idempotent)."""
    source = scene.source
    coupling = scene.data["coupling"]
    SCHEMES.lookup(coupling["scheme"], "coupling.scheme", source)
    coupling["acceleration"] = resolve_acceleration(coupling["acceleration"], "coupling.acceleration", source)
    coupling["convergence"] = [resolve_measure(m, f"coupling.convergence.{i}", source)
                               for i, m in enumerate(coupling["convergence"])]
    for i, exchange in enumerate(scene.data["exchange"]):
        exchange["mapping"] = MAPPINGS.settings(exchange["mapping"], f"exchange.{i}.mapping", source)
