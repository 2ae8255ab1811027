"""Checks of a scene against its components before any process starts.

A component class that declares ``parameter_schema`` has its scene parameters checked in the
coupler's process, so that a bad key fails at once (in a sweep: before any run starts) and the
error names the scene key: ``tube.a0`` for a model section, ``components.solid.parameters.E``
for the component's own table. A component whose module cannot be imported here is checked by
its own process at ``instantiate`` instead. A backend's table (``components.<name>.rom``, ``.fmu``) is
checked the same way against its class's ``parameter_schema``: the scene layer knows only its ``entry`` and
``switch_time``.
"""

from __future__ import annotations

from pathlib import Path

from cosim.errors import CosimError, SceneError
from cosim.scene import BACKEND, Scene
from cosim.schema import file_paths, unknown_key_message, validate
from cosim.server import EntryImportError, load_entry
from coupler.scene_rules import check_state_declared


def check_parameters(scene: Scene) -> None:
    """Every component's parameters, and its backends' tables, against their declared schemas; raises
    ``SceneError`` naming the key."""
    for name, spec in scene["components"].items():
        if spec["curve"]:
            from cosim.curve import check_client_keys
            try:
                check_client_keys(spec["curve"])
            except CosimError as exc:
                raise SceneError(f"{scene.source}: 'components.{name}.curve': {exc}") from None
        schema = _schema_of(scene, spec["entry"], f"components.{name}.entry") if spec["entry"] else None
        if schema is not None:
            _check(scene, name, schema)
    check_backends(scene)
    check_state_declared(scene)


def _schema_of(scene: Scene, entry: str, where: str) -> dict | None:
    """The ``parameter_schema`` of the class ``entry`` names (None: it declares none, or only its own process can
    import it, and will say what is missing). The class is found as its process finds it: a module next to the
    scene is loaded from its file."""
    try:
        return getattr(load_entry(entry, [scene.folder]), "parameter_schema", None)
    except EntryImportError:
        return None
    except CosimError as exc:
        raise SceneError(f"{scene.source}: '{where}': {exc}") from None


def check_backends(scene: Scene) -> None:
    """Every backend table the scene selects or fills, against its class's ``parameter_schema``: unknown keys and
    bad values are named, defaults filled in, relative file paths resolved; a selected backend's files must be
    set (not yet exist: a campaign checks its ROM-FOM runs before it trains their models)."""
    for name, spec in scene["components"].items():
        for kind in ("rom", "fmu"):
            table = spec[kind]
            given = {k: v for k, v in table.items() if k not in BACKEND}
            if spec["backend"] != kind and not given:
                continue
            where = f"components.{name}.{kind}"
            schema = _schema_of(scene, table["entry"], f"{where}.entry")
            if schema is None:
                continue
            for key in given:
                if key not in schema:
                    raise SceneError(unknown_key_message(key, f"{where}.", list(schema), scene.source))
            table.update(validate(given, schema, f"{where}.", scene.source))
            keys = [f"{where}.{p}" for p in file_paths(schema)]
            scene.resolve_paths(keys)
            for dotted in keys if spec["backend"] == kind else ():
                if not scene.value(dotted):
                    raise SceneError(f"{scene.source}: components.{name}.backend is '{kind}' but '{dotted}' is "
                                     "not set")
                if Path(scene.value(dotted)).is_dir():
                    raise SceneError(f"{scene.source}: '{dotted}' names '{scene.value(dotted)}', which is a "
                                     "directory, not a file")


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
        keys = [p if prefix == "" else own + p for p in file_paths({key: item})]
        scene.resolve_paths(keys)
        for dotted in keys:
            _check_file(scene, dotted)


def _check_file(scene: Scene, key: str) -> None:
    """The file a component parameter names must exist (it is read once the component starts)."""
    node = scene.value(key)
    if isinstance(node, str) and node and not Path(node).is_file():
        given = "given by --set, the working directory's" if scene.given(key) else "the scene folder's"
        what = "a directory" if Path(node).is_dir() else "not a file"
        raise SceneError(f"{scene.source}: '{key}' names '{node}', which is {what} (a relative path is {given})")
