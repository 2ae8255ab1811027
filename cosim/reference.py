"""Reference pages in Markdown, generated from schemas (``cosim.schema``) and plug-in registries.

Every key needs a meaning: a key or setting without one raises ``MissingMeaning``, so that a page generated
in a test fails when the code gains a key its documentation does not explain.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

from cosim.registry import Registry
from cosim.schema import describe, leaves

HEAD = ["| key | type | default | allowed | meaning |", "| --- | --- | --- | --- | --- |"]


class MissingMeaning(KeyError):
    """A key of a schema, or a plug-in's setting, that the reference cannot explain."""


def row(key: str, spec: Any, meaning: str) -> str:
    kind, default, allowed = describe(spec)
    default = default if default == "required" else f"`{default}`"
    return f"| {key} | {kind} | {default} | {allowed} | {meaning} |"


def table(schema: Mapping[str, Any], meanings: Mapping[str, str], prefix: str = "", meaning_prefix: str = "",
          owner: str = "MEANINGS") -> list[str]:
    """A table of every leaf of ``schema``; a leaf's meaning is ``meanings[meaning_prefix + key]``."""
    lines = list(HEAD)
    for key, spec in leaves(schema):
        meaning = meanings.get(meaning_prefix + key)
        if meaning is None:
            raise MissingMeaning(f"no meaning for key '{meaning_prefix + key}' ({owner})")
        lines.append(row(f"`{prefix}{key}`", spec, meaning))
    return lines


def plugins(registry: Registry[Any], title: str, where: str, level: int = 2) -> list[str]:
    """A section per registered class: its docstring's first paragraph and a table of its ``SETTINGS``."""
    lines = [f"{'#' * level} {title}", "", f"`{where}`: a name, or a table with `type` and the plug-in's settings.", ""]
    for name, cls in registry.classes.items():
        if not cls.__doc__:
            raise MissingMeaning(f"the {registry.kind} '{name}' ({cls.__name__}) has no docstring")
        doc = inspect.cleandoc(cls.__doc__).split("\n\n")[0].replace("\n", " ")
        lines += [f"{'#' * (level + 1)} `{name}`", "", doc, ""]
        aliases = registry.aliases_of(name)
        if aliases:
            lines += [f"Also chosen by its former name{'s' if len(aliases) > 1 else ''} "
                      f"{', '.join(f'`{alias}`' for alias in aliases)}.", ""]
        settings = getattr(cls, "SETTINGS", {})
        if not settings:
            lines += ["No settings.", ""]
            continue
        help_ = getattr(cls, "HELP", {})
        lines += ["| setting" + HEAD[0][len("| key"):], HEAD[1]]
        for key, spec in leaves(settings):
            if key not in help_:
                raise MissingMeaning(f"no meaning for the {registry.kind} '{name}' setting '{key}' ({cls.__name__}.HELP)")
            lines.append(row(f"`{key}`", spec, help_[key]))
        lines.append("")
    return lines
