"""A JSON file whose values know their line: a Kratos case's errors name the file, the line and the key path."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from cosim.errors import CosimError, SceneError
from cosim.input_file import read_input

MAX_BYTES = 16 << 20
_WHITESPACE = " \t\n\r"
_DECODER = json.JSONDecoder()

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
        try:
            self.data, end = self._value(self._skip(0), ())
        except (json.JSONDecodeError, _Syntax) as exc:
            position = exc.pos if isinstance(exc, json.JSONDecodeError) else exc.args[1]
            raise SceneError(f"{self.path}, line {self.line_at(position)}: not valid JSON "
                             f"({exc.msg if isinstance(exc, json.JSONDecodeError) else exc.args[0]})") from None
        if self._skip(end) != len(text):
            raise SceneError(f"{self.path}, line {self.line_at(end)}: text after the JSON value")
        if not isinstance(self.data, dict):
            raise SceneError(f"{self.path}: the file holds no JSON object")

    def line_at(self, offset: int) -> int:
        return self.text.count("\n", 0, offset) + 1

    def where(self, path: Path_) -> str:
        """``FILE, line N: 'a.b.0.c'``: the file, the line of the deepest part of ``path`` given, the key path."""
        for cut in range(len(path), -1, -1):
            if path[:cut] in self.offsets:
                return f"{self.path}, line {self.line_at(self.offsets[path[:cut]])}: '{dotted(path)}'"
        return f"{self.path}: '{dotted(path)}'"

    def _skip(self, i: int) -> int:
        while i < len(self.text) and self.text[i] in _WHITESPACE:
            i += 1
        return i

    def _value(self, i: int, path: Path_) -> tuple[Any, int]:
        self.offsets[path] = i
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


class _Syntax(Exception):
    """(message, offset)."""


def dotted(path: Path_) -> str:
    return ".".join(str(p) for p in path)
