"""An XML file as a tree of elements that know their line: a configuration's errors name the file and the line."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from cosim.errors import CosimError, SceneError
from cosim.input_file import read_input

MAX_BYTES = 4 << 20


@dataclass
class Element:
    """One element: its tag (with its namespace prefix, ``mapping:rbf``), attributes, children and line."""

    tag: str
    attributes: dict[str, str]
    line: int
    children: list[Element] = field(default_factory=list)
    used: set[str] = field(default_factory=set)     # the attributes read

    def get(self, name: str, default: str | None = None) -> str | None:
        self.used.add(name)
        return self.attributes.get(name, default)

    def kind(self) -> tuple[str, str]:
        """(``mapping``, ``rbf``) of ``mapping:rbf``; (tag, "") without a prefix."""
        prefix, sep, rest = self.tag.partition(":")
        return (prefix, rest) if sep else (self.tag, "")


def parse(path: Path) -> Element:
    """The root element of ``path``; a file that is no XML is a one-line ``SceneError`` with its line."""
    try:
        data = read_input(path, "preCICE configuration", MAX_BYTES)
    except CosimError as exc:
        raise SceneError(str(exc)) from None
    parser = expat.ParserCreate()
    stack: list[Element] = []
    roots: list[Element] = []

    def start(tag: str, attributes: dict[str, str]) -> None:
        element = Element(tag, dict(attributes), parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    def end(tag: str) -> None:
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise SceneError(f"{path}, line {exc.lineno}: not XML: {expat.ErrorString(exc.code)}") from None
    if not roots:
        raise SceneError(f"{path}: no XML element")
    return roots[0]
