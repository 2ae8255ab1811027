"""A parallel participant's ranks as one participant: their requests gathered, the answers split.

A participant started as N ranks (``Participant(name, config, rank, size)`` in each, under ``mpirun`` say) connects
N times. The coupler sees one participant: ``RankGroup`` waits until every rank has made the same request, joins
their vertices and data in rank order (each rank's vertex ids stay its own, from 0), and splits the answer back, each
rank its part of the read data. The setup, the window and the end go to every rank alike.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

ELEMENT_KINDS = ("edges", "triangles", "tetrahedra")


class RankError(Exception):
    """A rank's request that does not fit the others' (another operation, another size, a repeated rank)."""


class RankGroup:
    """The ranks of one participant: ``add`` each request, a whole request comes out once all ranks have sent one."""

    def __init__(self, name: str, size: int):
        self.name = name
        self.size = size
        self.identities: list[bytes | None] = [None] * size
        self.pids: list[int] = [0] * size
        self.waiting: dict[int, tuple[dict[str, Any], dict[str, np.ndarray]]] = {}
        self.ids: list[Any] = [None] * size          # each rank's id of the request being answered
        self.counts: dict[str, list[int]] = {}       # mesh -> each rank's vertex count
        self.mesh_of: dict[str, str] = {}            # data -> the mesh it lives on (from the setup)

    def join(self, rank: int, identity: bytes, pid: int) -> None:
        if self.identities[rank] is not None:
            raise RankError(f"rank {rank} of participant '{self.name}' is connected already")
        self.identities[rank] = identity
        self.pids[rank] = pid

    def rank_of(self, identity: bytes) -> int | None:
        return next((r for r, known in enumerate(self.identities) if known == identity), None)

    def add(self, rank: int, header: dict[str, Any], arrays: dict[str, np.ndarray]
            ) -> tuple[dict[str, Any], dict[str, np.ndarray]] | None:
        """Keep rank ``rank``'s request; once every rank sent one, the participant's whole request."""
        if rank in self.waiting:
            raise RankError(f"rank {rank} of participant '{self.name}' called '{header.get('op')}' while its "
                            f"'{self.waiting[rank][0].get('op')}' waits")
        self.waiting[rank] = (header, arrays)
        if len(self.waiting) < self.size:
            return None
        requests = [self.waiting.pop(r) for r in range(self.size)]
        ops = {h.get("op") for h, _ in requests}
        if len(ops) != 1:
            raise RankError(f"the ranks of participant '{self.name}' called different operations at once: "
                            + ", ".join(f"rank {r} {h.get('op')}" for r, (h, _) in enumerate(requests)))
        self.ids = [h.get("id") for h, _ in requests]
        first = dict(requests[0][0])
        if first.get("op") == "initialize":
            return first, self._initialize([a for _, a in requests])
        if first.get("op") == "advance":
            args = [h.get("args") or {} for h, _ in requests]
            first["args"] = {**args[0], "compute_seconds": max(float(a.get("compute_seconds", 0.0)) for a in args),
                             "cpu_seconds": sum(float(a.get("cpu_seconds", 0.0)) for a in args)}
            return first, self._joined([a for _, a in requests])
        return first, {}

    def _initialize(self, arrays: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
        """The ranks' vertices joined mesh by mesh, their elements renumbered, their initial data joined."""
        joined: dict[str, np.ndarray] = {}
        meshes = sorted({key[len("mesh:"):] for a in arrays for key in a if key.startswith("mesh:")})
        for mesh in meshes:
            blocks = [a[f"mesh:{mesh}"] for a in arrays if f"mesh:{mesh}" in a]
            if len(blocks) != self.size:
                raise RankError(f"not every rank of participant '{self.name}' gave vertices of mesh '{mesh}'")
            self.counts[mesh] = [len(b) for b in blocks]
            joined[f"mesh:{mesh}"] = np.concatenate(blocks)
            offsets = np.cumsum([0, *self.counts[mesh][:-1]])
            for kind in ELEMENT_KINDS:
                parts = [a[f"{kind}:{mesh}"] + offset for a, offset in zip(arrays, offsets) if f"{kind}:{mesh}" in a]
                if parts:
                    joined[f"{kind}:{mesh}"] = np.concatenate(parts)
        joined.update(self._joined(arrays))
        return joined

    def _joined(self, arrays: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
        """Data (and gradients) written by every rank, joined along the vertices (a substep's samples: along their
        second axis)."""
        joined = {}
        for key in arrays[0]:
            prefix, _, data = key.partition(":")
            if prefix in ("data", "substeps") or (prefix == "gradient" and all(key in a for a in arrays)):
                joined[key] = np.concatenate([a[key] for a in arrays], axis=1 if prefix == "substeps" else 0)
        return joined

    def split(self, result: Mapping[str, Any], arrays: Mapping[str, np.ndarray] | None
              ) -> list[tuple[bytes, Any, dict[str, Any], dict[str, np.ndarray]]]:
        """The answer to every rank: its identity, its request's id, the result, its part of the read data."""
        if "meshes" in result and "read" in result:        # the setup: which mesh each data item lives on
            self.mesh_of = {spec["data"]: spec["mesh"] for spec in [*result["write"], *result["read"]]}
        parts: list[dict[str, np.ndarray]] = [{} for _ in range(self.size)]
        for key, value in (arrays or {}).items():
            prefix, _, data = key.partition(":")
            counts = self.counts.get(self.mesh_of.get(data, ""))
            if prefix in ("data", "start", "coefficients") and counts is not None:
                axis = 1 if prefix == "coefficients" else 0
                bounds = np.cumsum([0, *counts])
                for rank in range(self.size):
                    parts[rank][key] = np.take(value, np.arange(bounds[rank], bounds[rank + 1]), axis=axis)
            else:
                for part in parts:
                    part[key] = value
        return [(identity, self.ids[rank], dict(result), parts[rank])
                for rank, identity in enumerate(self.identities) if identity is not None]
