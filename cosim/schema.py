"""Validation of nested tables (scene files, component parameters) against defaults.

A schema is a nested dict whose leaves are default values or ``Required(type)``.
``validate`` returns a new dict with every default filled in, and raises
``SceneError`` naming the dotted key of the first unknown, missing or mistyped entry.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import Any, Mapping

from cosim.errors import SceneError


@dataclass(frozen=True)
class Required:
    """A key with no default; ``kind`` is the expected Python type (or a tuple)."""

    kind: type | tuple[type, ...]


@dataclass(frozen=True)
class AnyTable:
    """A free-form table: any keys (validated later by whoever consumes it)."""


def _type_name(kind: type | tuple[type, ...]) -> str:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return " or ".join(k.__name__ for k in kinds)


def _check_type(value: Any, kind: type | tuple[type, ...], where: str) -> Any:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    if float in kinds and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, bool) and bool not in kinds:
        raise SceneError(f"'{where}' must be {_type_name(kind)}, got {value!r}")
    if not isinstance(value, kinds):
        raise SceneError(f"'{where}' must be {_type_name(kind)}, got {type(value).__name__} {value!r}")
    return value


def unknown_key_message(key: str, prefix: str, known: list[str], source: str = "") -> str:
    """'unknown key' message with a did-you-mean hint."""
    where = f"{prefix}{key}"
    hint = difflib.get_close_matches(key, known, n=1)
    text = f"unknown key '{where}'" + (f" in {source}" if source else "")
    text += f"; did you mean '{prefix}{hint[0]}'?" if hint else f" (known keys: {', '.join(sorted(known)) or 'none'})"
    return text


def validate(given: Mapping[str, Any] | None, schema: Mapping[str, Any], prefix: str = "", source: str = "") -> dict[str, Any]:
    """``given`` checked against ``schema`` with defaults filled in."""
    given = dict(given or {})
    for key in given:
        if key not in schema:
            raise SceneError(unknown_key_message(key, prefix, list(schema), source))
    result: dict[str, Any] = {}
    for key, spec in schema.items():
        where = f"{prefix}{key}"
        if isinstance(spec, AnyTable):
            value = given.get(key, {})
            result[key] = dict(_check_type(value, dict, where))
        elif isinstance(spec, Mapping):
            value = given.get(key, {})
            _check_type(value, dict, where)
            result[key] = validate(value, spec, where + ".", source)
        elif isinstance(spec, Required):
            if key not in given:
                raise SceneError(f"missing key '{where}'" + (f" in {source}" if source else ""))
            result[key] = _check_type(given[key], spec.kind, where)
        else:
            value = given.get(key, spec)
            kind = float if isinstance(spec, float) else type(spec)
            if isinstance(spec, list):
                kind = list
            result[key] = _check_type(value, kind, where)
    return result
