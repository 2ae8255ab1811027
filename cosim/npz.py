"""The members of an ``.npz`` archive read from their ``.npy`` headers alone, before any array is loaded: what a
reader of model files and checkpoints checks first, so that a damaged or hostile file costs no memory."""

from __future__ import annotations

import zipfile
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MemberHeader:
    """What one member's ``.npy`` header declares."""

    shape: tuple[int, ...]
    dtype: np.dtype
    header_bytes: int        # the header's length: the data follow it

    @property
    def data_bytes(self) -> int:
        return int(np.prod(self.shape, dtype=object)) * self.dtype.itemsize


def member_header(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> MemberHeader:
    """The header of member ``info``; ``ValueError`` naming the format for one that is not a .npy 1.0 or 2.0."""
    with archive.open(info) as member:
        version = np.lib.format.read_magic(member)
        readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
        if version not in readers:
            raise ValueError(f"it is in .npy format {version}; known: 1.0, 2.0")
        shape, _, dtype = readers[version](member)
        return MemberHeader(tuple(shape), dtype, member.tell())
