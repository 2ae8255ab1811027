"""Write a Kratos ``.mdpa`` model part file from arrays (no Kratos needed).

A model part is its nodes, one block of elements and of conditions per Kratos type name, and
sub-model parts listing node, element and condition ids. Ids are 1-based, as Kratos wants them;
every entity has property 0 (the materials file assigns the real properties by sub-model part).
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class Block:
    """Entities of one Kratos type: ``connectivity`` (m, k) holds 1-based node ids; ids run from ``first_id``."""

    kind: str
    connectivity: np.ndarray
    first_id: int = 1

    @property
    def ids(self) -> np.ndarray:
        return np.arange(self.first_id, self.first_id + len(self.connectivity))


@dataclass
class SubModelPart:
    """Ids of the nodes, elements and conditions of one sub-model part."""

    nodes: np.ndarray
    elements: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    conditions: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


def _ids(out: io.StringIO, values: np.ndarray) -> None:
    if len(values):
        np.savetxt(out, np.asarray(values, dtype=np.int64).reshape(-1, 1), fmt="        %d")


def write_mdpa(path: str | Path, nodes: np.ndarray, elements: Sequence[Block], conditions: Sequence[Block],
               parts: Mapping[str, SubModelPart]) -> Path:
    """Write nodes ((n, 2) or (n, 3), ids 1..n), element and condition blocks and sub-model parts to ``path``."""
    nodes = np.asarray(nodes, dtype=np.float64)
    coordinates = np.zeros((len(nodes), 3))
    coordinates[:, :nodes.shape[1]] = nodes
    out = io.StringIO()
    out.write("Begin ModelPartData\nEnd ModelPartData\n\nBegin Properties 0\nEnd Properties\n\nBegin Nodes\n")
    np.savetxt(out, np.column_stack([np.arange(1, len(nodes) + 1), coordinates]), fmt=["    %d", "%.17g", "%.17g", "%.17g"])
    out.write("End Nodes\n\n")
    for keyword, blocks in (("Elements", elements), ("Conditions", conditions)):
        for block in blocks:
            out.write(f"Begin {keyword} {block.kind}\n")
            table = np.column_stack([block.ids, np.zeros(len(block.ids), dtype=np.int64), block.connectivity])
            np.savetxt(out, table.astype(np.int64), fmt="    %d")
            out.write(f"End {keyword}\n\n")
    for name, part in parts.items():
        out.write(f"Begin SubModelPart {name}\n")
        for keyword, values in (("Nodes", part.nodes), ("Elements", part.elements), ("Conditions", part.conditions)):
            out.write(f"    Begin SubModelPart{keyword}\n")
            _ids(out, np.unique(values))
            out.write(f"    End SubModelPart{keyword}\n")
        out.write("End SubModelPart\n\n")
    path = Path(path)
    path.write_text(out.getvalue())
    return path


@dataclass
class ModelPartFile:
    """What ``read_mdpa`` finds: node coordinates (n, 3) by id (row i is id i + 1), blocks, sub-model parts."""

    nodes: np.ndarray
    elements: list[Block]
    conditions: list[Block]
    parts: dict[str, SubModelPart]

    def coordinates(self, ids: np.ndarray) -> np.ndarray:
        """(x, y) of the nodes ``ids``."""
        return self.nodes[np.asarray(ids, dtype=np.int64) - 1, :2]


def read_mdpa(path: str | Path) -> ModelPartFile:
    """Read a file ``write_mdpa`` wrote (nodes numbered 1..n, ids of each block consecutive)."""
    lines = Path(path).read_text().splitlines()
    nodes = np.zeros((0, 3))
    blocks: dict[str, list[Block]] = {"Elements": [], "Conditions": []}
    parts: dict[str, SubModelPart] = {}
    i = 0
    while i < len(lines):
        words = lines[i].split()
        if words[:1] == ["Begin"] and words[1] in ("Nodes", "Elements", "Conditions"):
            end = lines.index(f"End {words[1]}", i)
            table = np.array([line.split() for line in lines[i + 1:end]], dtype=float).reshape(end - i - 1, -1)
            if words[1] == "Nodes":
                nodes = table[:, 1:]
            else:
                blocks[words[1]].append(Block(words[2], table[:, 2:].astype(np.int64), int(table[0, 0])))
            i = end
        elif words[:2] == ["Begin", "SubModelPart"]:
            name, found = words[2], {}
            i += 1
            while lines[i] != "End SubModelPart":
                keyword = lines[i].split()[1].removeprefix("SubModelPart")
                end = lines.index(f"    End SubModelPart{keyword}", i)
                found[keyword.lower()] = np.array([int(v) for v in lines[i + 1:end]], dtype=np.int64)
                i = end + 1
            parts[name] = SubModelPart(found["nodes"], found["elements"], found["conditions"])
        i += 1
    return ModelPartFile(nodes, blocks["Elements"], blocks["Conditions"], parts)
