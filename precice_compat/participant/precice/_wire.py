"""Messages to and from cosim's coupler: a msgpack header and one raw frame per array (cosim's wire, version 1).

This package stands alone (a participant's own Python may have nothing but numpy, pyzmq and msgpack), so it
carries its own copy of the few lines that encode and decode a message; the coupler's tests check both ways
against ``cosim.protocol``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import msgpack
import numpy as np

VERSION = 1
DTYPES: dict[str, np.dtype] = {name: np.dtype(name) for name in ("float64", "int64", "int32")}


def encode(header: dict[str, Any], arrays: Mapping[str, np.ndarray] | None = None) -> list[Any]:
    """The frames of ``header`` and ``arrays`` (each a C-ordered float64 or integer array)."""
    specs, buffers = [], []
    for name, value in (arrays or {}).items():
        array = np.ascontiguousarray(value)
        if array.dtype.str.lstrip("<=|") not in ("f8", "i8", "i4"):
            array = np.ascontiguousarray(array, dtype=np.float64)
        specs.append({"name": name, "dtype": array.dtype.name, "shape": list(array.shape)})
        buffers.append(array.tobytes() if array.size else b"")
    head = dict(header, v=VERSION, arrays=specs)
    return [msgpack.packb(head, use_bin_type=True)] + buffers


def decode(frames: Sequence[bytes]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The header and arrays of a message from the coupler (arrays are copies the caller may change)."""
    header = msgpack.unpackb(frames[0], raw=False)
    if not isinstance(header, dict) or header.get("v") != VERSION:
        version = header.get("v") if isinstance(header, dict) else None
        raise ValueError(f"a message that is not cosim's (wire version {version!r})")
    arrays = {}
    specs = header.get("arrays") or []
    if len(specs) != len(frames) - 1:
        raise ValueError(f"a message declaring {len(specs)} arrays with {len(frames) - 1} frames")
    for spec, frame in zip(specs, frames[1:]):
        dtype = DTYPES.get(spec.get("dtype"))
        shape = [int(n) for n in spec.get("shape", [])]
        if dtype is None or math.prod(shape) * dtype.itemsize != len(frame):
            raise ValueError(f"array {spec.get('name')!r} does not match its frame")
        arrays[spec["name"]] = np.frombuffer(frame, dtype=dtype).reshape(shape).copy()
    return header, arrays
