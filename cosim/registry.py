"""Plug-ins chosen by name: each class registers under a name and owns its settings.

A plug-in class declares ``SETTINGS``, a schema in the form ``cosim.schema.validate``
reads (defaults, ranges, required keys). A scene names a plug-in by a table with a
``type`` key and the plug-in's settings, or by its name alone (or by one of the class's aliases, a former name
that keeps working); ``Registry.settings``
checks that table against the class's own schema, so a setting that does not belong to
the chosen plug-in is an error naming the key, and ``Registry.create`` builds the plug-in
from the validated settings.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from importlib.metadata import EntryPoints
from typing import Any, Generic, TypeVar

from cosim.errors import SceneError
from cosim.schema import validate

P = TypeVar("P")    # the plug-in kind's base class


@functools.cache
def _installed_entry_points() -> Any:     # EntryPoints from Python 3.12 on, SelectableGroups before: both select
    import importlib.metadata
    return importlib.metadata.entry_points()


def entry_points(group: str) -> EntryPoints:
    """The installed distributions' entry points of ``group`` (plug-ins of other rooms and packages), read from
    their metadata once a process: a run looks up several groups, and each lookup read every distribution again."""
    points: EntryPoints = _installed_entry_points().select(group=group)
    return points


class Registry(Generic[P]):
    """Named plug-in classes of one kind (accelerations, measures, mappings, schemes), subclasses of ``P``."""

    def __init__(self, kind: str):
        self.kind = kind
        self.classes: dict[str, type[P]] = {}
        self.aliases: dict[str, str] = {}      # another name a class is chosen by -> its name

    def register(self, name: str, aliases: Sequence[str] = ()) -> Callable[[type[P]], type[P]]:
        """Register a class under ``name``; each of ``aliases`` (a former name, say) chooses it too."""
        def decorate(cls: type[P]) -> type[P]:
            for key in (name, *aliases):
                if key in self.classes or key in self.aliases:
                    raise ValueError(f"{self.kind} '{key}' is registered twice")
            self.classes[name] = cls
            self.aliases.update(dict.fromkeys(aliases, name))
            setattr(cls, "type_name", name)     # noqa: B010 (the name the class is chosen by)
            return cls
        return decorate

    def names(self) -> list[str]:
        return list(self.classes)

    def aliases_of(self, name: str) -> list[str]:
        """The other names that choose the class registered as ``name``."""
        return [alias for alias, target in self.aliases.items() if target == name]

    def get(self, name: str) -> type[P]:
        """The class registered under ``name`` or under one of its aliases (KeyError if none)."""
        return self.classes[self.aliases.get(name, name)]

    def lookup(self, name: Any, where: str, source: str = "") -> type[P]:
        if name not in self.classes and name not in self.aliases:
            raise SceneError(f"{_at(source)}'{where}' is {name!r}; known {self.kind}s: {', '.join(self.classes)}")
        return self.get(name)

    def settings(self, table: Any, where: str, source: str = "", common: Mapping[str, Any] | None = None,
                 context: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """``table`` (a name, or a table with ``type``) checked against the chosen class's settings.

        ``common`` are keys every plug-in of this kind accepts (validated with it);
        ``context`` is handed to a class's ``check_settings`` for cross-checks.
        """
        if isinstance(table, str):
            table = {"type": table}
        if not isinstance(table, Mapping):
            raise SceneError(f"{_at(source)}'{where}' must be a name or a table with 'type', got {table!r}")
        table = dict(table)
        if "type" not in table:
            raise SceneError(f"{_at(source)}missing key '{where}.type' (known {self.kind}s: {', '.join(self.classes)})")
        name = table.pop("type")
        cls = self.lookup(name, f"{where}.type", source)
        schema = {**(common or {}), **getattr(cls, "SETTINGS", {})}
        settings = validate(table, schema, f"{where}.", source)
        check = getattr(cls, "check_settings", None)
        if check is not None:
            check(settings, where, source, **(context or {}))
        return {"type": name, **settings}

    def create(self, settings: Mapping[str, Any], **context: Any) -> P:
        """An instance from settings returned by ``settings`` (``type`` picks the class, by its name or an alias)."""
        options = {k: v for k, v in settings.items() if k != "type"}
        return self.get(settings["type"])(**options, **context)


def _at(source: str) -> str:
    return f"{source}: " if source else ""
