"""Validation of nested tables (scene files, component parameters) against defaults.

A schema is a nested dict whose leaves are default values, ``Required(type)`` or
``Value(default, ...)`` with a range. ``validate`` returns a new dict with every default
filled in, and raises ``SceneError`` naming the dotted key of the first unknown,
missing, mistyped or out-of-range entry and saying what is allowed. Every float must be
finite.
"""

from __future__ import annotations

import difflib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from cosim.errors import SceneError

_NO_DEFAULT = object()


@dataclass(frozen=True)
class Value:
    """A number with a range: ``low``/``high`` bounds, open ends by ``low_open``/``high_open``.

    ``default`` is the value when the key is absent (``Required`` if it has none).
    """

    default: Any = _NO_DEFAULT
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    kind: type | tuple[type, ...] | None = None

    @property
    def type(self) -> type | tuple[type, ...]:
        if self.kind is not None:
            return self.kind
        return float if isinstance(self.default, float) or self.default is _NO_DEFAULT else type(self.default)

    def check(self, value: Any, where: str) -> None:
        low_ok = self.low is None or (value > self.low if self.low_open else value >= self.low)
        high_ok = self.high is None or (value < self.high if self.high_open else value <= self.high)
        if not (low_ok and high_ok):
            raise SceneError(f"'{where}' is {value!r}; allowed: {self.describe()}")

    def describe(self) -> str:
        integer = self.type is int
        low, high = (None if b is None else f"{b:,}" if integer else f"{b:g}" for b in (self.low, self.high))
        if self.low is not None and self.high is not None:
            return (f"{'(' if self.low_open else '['}{low}, {high}{')' if self.high_open else ']'}"
                    + (" (an integer)" if integer else ""))
        if self.low is not None:
            sign = ">" if self.low_open else ">="
            return f"{'an integer' if integer else 'a number'} {sign} {low}"
        sign = "<" if self.high_open else "<="
        return f"{'an integer' if integer else 'a number'} {sign} {high}"


def Positive(default: Any = _NO_DEFAULT) -> Value:
    """A number > 0 (an integer >= 1 when the default is an int)."""
    if isinstance(default, int) and not isinstance(default, bool):
        return Value(default, low=1)
    return Value(default, low=0.0, low_open=True)


@dataclass(frozen=True)
class Required:
    """A key with no default; ``kind`` is the expected Python type (or a tuple)."""

    kind: type | tuple[type, ...]


@dataclass(frozen=True)
class AnyTable:
    """A free-form table: any keys (validated later by whoever consumes it)."""


@dataclass(frozen=True)
class OpenTable:
    """A table whose ``fixed`` keys are validated here and whose other keys pass through unchanged (another
    schema, known only to whoever consumes the table, checks them later)."""

    fixed: Mapping[str, Any]


@dataclass(frozen=True)
class FilePath:
    """A file's path, a string ("" for none). In a scene file a relative path is the scene folder's; given
    by ``--set`` it is the working directory's (see ``cosim.scene.Scene.resolve_paths``)."""

    default: str = ""
    required: bool = False


@dataclass(frozen=True)
class Choice:
    """One string of ``options``; ``default`` is the value when the key is absent."""

    default: str
    options: tuple[str, ...]

    def __post_init__(self) -> None:
        if self.default not in self.options:
            raise ValueError(f"default {self.default!r} not in {self.options}")


@dataclass(frozen=True)
class PluginChoice:
    """A plug-in named by a string or by a table with ``type`` (validated by its registry later)."""

    default: Any = _NO_DEFAULT


def _type_name(kind: type | tuple[type, ...]) -> str:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    names = {"float": "a number", "int": "an integer", "str": "a string", "bool": "true or false",
             "list": "a list", "dict": "a table"}
    return " or ".join(names.get(k.__name__, k.__name__) for k in kinds)


def check_type(value: Any, kind: type | tuple[type, ...], where: str) -> Any:
    """``value`` as ``kind`` (an int is accepted as a float); floats must be finite."""
    kinds = kind if isinstance(kind, tuple) else (kind,)
    if float in kinds and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if isinstance(value, bool) and bool not in kinds:
        raise SceneError(f"'{where}' must be {_type_name(kind)}, got {value!r}")
    if not isinstance(value, kinds):
        raise SceneError(f"'{where}' must be {_type_name(kind)}, got {type(value).__name__} {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise SceneError(f"'{where}' must be a finite number, got {value!r}")
    return value


def unknown_key_message(key: str, prefix: str, known: list[str], source: str = "") -> str:
    """'unknown key' message with a did-you-mean hint."""
    where = f"{prefix}{key}"
    hint = difflib.get_close_matches(str(key), [str(k) for k in known], n=1)
    text = f"unknown key '{where}'" + (f" in {source}" if source else "")
    text += f"; did you mean '{prefix}{hint[0]}'?" if hint else f" (known keys: {', '.join(sorted(known)) or 'none'})"
    return text


def validate(given: Any, schema: Mapping[str, Any], prefix: str = "", source: str = "") -> dict[str, Any]:
    """``given`` checked against ``schema`` with defaults filled in."""
    if given is None:
        given = {}
    if not isinstance(given, Mapping):
        where = prefix.rstrip(".") or "the document"
        raise SceneError(f"'{where}' must be a table, got {type(given).__name__} {given!r}"
                         + (f" in {source}" if source else ""))
    given = dict(given)
    for key in given:
        if key not in schema:
            raise SceneError(unknown_key_message(key, prefix, list(schema), source))
    result: dict[str, Any] = {}
    for key, spec in schema.items():
        where = f"{prefix}{key}"
        try:
            result[key] = _leaf(given, key, spec, where, source)
        except SceneError as exc:
            if source and source not in str(exc):
                raise SceneError(f"{exc} in {source}") from None
            raise
    return result


def _leaf(given: dict[str, Any], key: str, spec: Any, where: str, source: str) -> Any:
    """The validated value of one key."""
    if isinstance(spec, AnyTable):
        return dict(check_type(given.get(key, {}), dict, where))
    if isinstance(spec, OpenTable):
        table = dict(check_type(given.get(key, {}), dict, where))
        fixed = validate({k: v for k, v in table.items() if k in spec.fixed}, spec.fixed, where + ".", source)
        return {**fixed, **{k: v for k, v in table.items() if k not in spec.fixed}}
    if isinstance(spec, FilePath):
        if spec.required and key not in given:
            raise SceneError(f"missing key '{where}'")
        return check_type(given.get(key, spec.default), str, where)
    if isinstance(spec, Choice):
        value = check_type(given.get(key, spec.default), str, where)
        if value not in spec.options:
            raise SceneError(f"'{where}' is {value!r}; allowed: {', '.join(spec.options)}")
        return value
    if isinstance(spec, PluginChoice):
        if key not in given and spec.default is _NO_DEFAULT:
            raise SceneError(f"missing key '{where}'")
        value = check_type(given.get(key, spec.default), (str, dict), where)
        return dict(value) if isinstance(value, dict) else value
    if isinstance(spec, Mapping):
        return validate(given.get(key, {}), spec, where + ".", source)
    if isinstance(spec, Required):
        if key not in given:
            raise SceneError(f"missing key '{where}'")
        return check_type(given[key], spec.kind, where)
    if isinstance(spec, Value):
        if key not in given and spec.default is _NO_DEFAULT:
            raise SceneError(f"missing key '{where}'")
        value = check_type(given.get(key, spec.default), spec.type, where)
        spec.check(value, where)
        return value
    kind = list if isinstance(spec, list) else float if isinstance(spec, float) else type(spec)
    return check_type(given.get(key, spec), kind, where)


def describe(spec: Any) -> tuple[str, str, str]:
    """(type, default, allowed values) of a schema leaf, as a reference page states them."""
    if isinstance(spec, Choice):
        return "a string", _toml(spec.default), ", ".join(_toml(o) for o in spec.options)
    if isinstance(spec, FilePath):
        return "file path", "required" if spec.required else _toml(spec.default), ""
    if isinstance(spec, PluginChoice):
        default = "required" if spec.default is _NO_DEFAULT else _toml(spec.default)
        return "plug-in: a name or a table with type", default, ""
    if isinstance(spec, AnyTable):
        return "table", "{}", "any keys"
    if isinstance(spec, Required):
        return _type_name(spec.kind), "required", ""
    if isinstance(spec, Value):
        default = "required" if spec.default is _NO_DEFAULT else _toml(spec.default)
        return _type_name(spec.type), default, spec.describe()
    kind = list if isinstance(spec, list) else float if isinstance(spec, float) else type(spec)
    return _type_name(kind), _toml(spec), ""


def _toml(value: Any) -> str:
    """``value`` as a scene file writes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str | list):
        return json.dumps(value)
    return repr(value)


def leaves(schema: Mapping[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    """(dotted key, leaf) of every leaf of ``schema``, in its order."""
    found: list[tuple[str, Any]] = []
    for key, spec in schema.items():
        if isinstance(spec, Mapping):
            found += leaves(spec, f"{prefix}{key}.")
        elif isinstance(spec, OpenTable):
            found += leaves(spec.fixed, f"{prefix}{key}.")
        else:
            found.append((f"{prefix}{key}", spec))
    return found


def file_paths(schema: Mapping[str, Any], prefix: str = "") -> list[str]:
    """The dotted keys of every ``FilePath`` in ``schema``."""
    found = []
    for key, spec in schema.items():
        if isinstance(spec, FilePath):
            found.append(f"{prefix}{key}")
        elif isinstance(spec, Mapping):
            found += file_paths(spec, f"{prefix}{key}.")
    return found
