"""Checks of a scene against its components before any process starts.

A component class that declares ``parameter_schema`` has its scene parameters checked in the
coupler's process, so that a bad key fails at once (in a sweep: before any run starts) and the
error names the scene key: ``tube.a0`` for a model section, ``components.solid.parameters.E``
for the component's own table. A component whose module cannot be imported here is checked by
its own process at ``instantiate`` instead.
"""

from __future__ import annotations

from cosim.errors import CosimError, SceneError
from cosim.scene import Scene
from cosim.schema import unknown_key_message, validate


def check_parameters(scene: Scene) -> None:
    """Every component's parameters against its declared schema; raises ``SceneError`` naming the key."""
    from cosim.server import load_entry
    for name, spec in scene["components"].items():
        if not spec["entry"]:
            continue
        try:
            schema = load_entry(spec["entry"]).parameter_schema
        except CosimError as exc:
            if "cannot import module" in str(exc):
                continue                 # its own process will say what is missing
            raise SceneError(f"{scene.source}: 'components.{name}.entry': {exc}") from None
        if schema is not None:
            _check(scene, name, schema)


def _check(scene: Scene, name: str, schema: dict) -> None:
    spec = scene["components"][name]
    own = f"components.{name}.parameters."
    for key in spec["sections"]:
        if key not in schema and key not in spec["parameters"]:
            raise SceneError(f"{scene.source}: 'components.{name}.sections' names '{key}', which "
                             f"'{spec['entry']}' does not take (it takes: {', '.join(schema)})")
    for key in spec["parameters"]:
        if key not in schema:
            raise SceneError(unknown_key_message(key, own, list(schema), scene.source))
    given = scene.component_parameters(name)
    for key, item in schema.items():
        prefix = "" if key in spec["sections"] and key not in spec["parameters"] else own
        validate({key: given[key]} if key in given else {}, {key: item}, prefix, scene.source)
