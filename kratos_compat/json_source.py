"""A JSON file whose values know their line: a Kratos case's errors name the file, the line and the key path."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from cosim.errors import CosimError, SceneError
from cosim.input_file import read_input

MAX_BYTES = 16 << 20
MAX_DEPTH = 64          # objects and arrays nested deeper are no parameters (and would exhaust the stack)
_WHITESPACE = " \t\n\r\ufeff"     # a UTF-8 byte order mark at the start, as Kratos's parser takes it


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not JSON (Kratos refuses it)")


_DECODER = json.JSONDecoder(parse_constant=_refuse_constant)      # NaN and Infinity refused, as by Kratos

Path_ = tuple[str | int, ...]


class JsonSource:
    """The parsed JSON of ``path`` and where each value starts (by its key path: ``("solver_settings", "type")``)."""

    def __init__(self, path: Path, text: str | None = None):
        self.path = Path(path)
        if text is None:
            if not self.path.exists():
                raise SceneError(f"'{self.path}' does not exist")
            try:
                text = read_input(self.path, "Kratos parameters", MAX_BYTES).decode("utf-8")
            except CosimError as exc:
                raise SceneError(str(exc)) from None
            except UnicodeDecodeError as exc:
                raise SceneError(f"cannot read '{self.path}': {exc}") from None
        self.text = text
        self.offsets: dict[Path_, int] = {}
        self._last = 0          # where the value being read starts (for an error the decoder gives no place of)
        try:
            self.data, end = self._value(self._skip(0), ())
        except (json.JSONDecodeError, _Syntax) as exc:
            position = exc.pos if isinstance(exc, json.JSONDecodeError) else exc.args[1]
            raise SceneError(f"{self.path}, line {self.line_at(position)}: not valid JSON "
                             f"({exc.msg if isinstance(exc, json.JSONDecodeError) else exc.args[0]})") from None
        except ValueError as exc:            # a number of thousands of digits, NaN or Infinity
            why = "a number of more digits than Python reads" if "digits" in str(exc) else str(exc)
            raise SceneError(f"{self.path}, line {self.line_at(self._last)}: not valid JSON ({why})") from None
        if self._skip(end) != len(text):
            raise SceneError(f"{self.path}, line {self.line_at(end)}: text after the JSON value")
        if not isinstance(self.data, dict):
            raise SceneError(f"{self.path}: the file holds no JSON object")

    def typed(self, path: Path_, kind: type, default: Any) -> Any:
        """The value at ``path`` (``default`` where a key on the way is missing); a one-line ``SceneError`` naming
        the key if it, or a table on the way, is not of the kind the path needs."""
        node: Any = self.data
        for depth, key in enumerate(path):
            if not isinstance(node, dict):
                raise SceneError(f"{self.where(path[:depth])}: must be an object, got {_shown(node)}")
            if key not in node:
                return default
            node = node[key]
        if not isinstance(node, kind) or (isinstance(node, bool) and kind is not bool):
            raise SceneError(f"{self.where(path)}: must be {_KINDS.get(kind, kind.__name__)}, got {_shown(node)}")
        return node

    def line_at(self, offset: int) -> int:
        return self.text.count("\n", 0, offset) + 1

    def where(self, path: Path_) -> str:
        """``FILE, line N: 'a.b.0.c'``: the file, the line of the deepest part of ``path`` given, the key path."""
        for cut in range(len(path), -1, -1):
            if path[:cut] in self.offsets:
                return f"{self.path}, line {self.line_at(self.offsets[path[:cut]])}: '{dotted(path)}'"
        return f"{self.path}: '{dotted(path)}'"

    def _skip(self, i: int) -> int:
        """Past white space and comments (``//`` to the line's end, ``/* ... */``), which Kratos's parser skips."""
        text = self.text
        while i < len(text):
            if text[i] in _WHITESPACE:
                i += 1
            elif text.startswith("//", i):
                end = text.find("\n", i)
                i = len(text) if end < 0 else end + 1
            elif text.startswith("/*", i):
                end = text.find("*/", i + 2)
                if end < 0:
                    raise _Syntax("a comment that never ends", i)
                i = end + 2
            else:
                break
        return i

    def _value(self, i: int, path: Path_) -> tuple[Any, int]:
        self.offsets[path] = self._last = i
        if len(path) > MAX_DEPTH:
            raise _Syntax(f"objects and arrays nested more than {MAX_DEPTH} deep", i)
        char = self.text[i:i + 1]
        if char == "{":
            result: dict[str, Any] = {}
            i = self._skip(i + 1)
            if self.text[i:i + 1] == "}":
                return result, i + 1
            while True:
                if self.text[i:i + 1] != '"':
                    raise _Syntax("expected a key in double quotes", i)
                key, i = _DECODER.raw_decode(self.text, i)
                i = self._skip(i)
                if self.text[i:i + 1] != ":":
                    raise _Syntax("expected ':'", i)
                self.offsets[(*path, key)] = i
                result[key], i = self._value(self._skip(i + 1), (*path, key))
                i = self._skip(i)
                if self.text[i:i + 1] == "}":
                    return result, i + 1
                if self.text[i:i + 1] != ",":
                    raise _Syntax("expected ',' or '}'", i)
                i = self._skip(i + 1)
        if char == "[":
            items: list[Any] = []
            i = self._skip(i + 1)
            if self.text[i:i + 1] == "]":
                return items, i + 1
            while True:
                item, i = self._value(i, (*path, len(items)))
                items.append(item)
                i = self._skip(i)
                if self.text[i:i + 1] == "]":
                    return items, i + 1
                if self.text[i:i + 1] != ",":
                    raise _Syntax("expected ',' or ']'", i)
                i = self._skip(i + 1)
        if not char:
            raise _Syntax("unexpected end of file", i)
        return _DECODER.raw_decode(self.text, i)


_KINDS = {dict: "an object", list: "an array", str: "a string", bool: "true or false"}


def _shown(value: Any) -> str:
    """A value as an error shows it: short, on one line."""
    text = json.dumps(value) if not isinstance(value, float) or value == value else repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


class _Syntax(Exception):
    """(message, offset)."""


def dotted(path: Path_) -> str:
    return ".".join(str(p) for p in path)
