"""Wire protocol: a msgpack header frame followed by one raw frame per array.

A message is ``[header, buf_1, ..., buf_k]``. The header is a msgpack map
``{v, op, id, args, arrays: [{name, dtype, shape}]}`` for a request and
``{v, id, ok, result, arrays, error, compute_seconds}`` for a reply. Arrays travel
as their raw bytes (C order), never pickled. ``decode`` validates everything
before use and raises ``ProtocolError`` naming what was wrong.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping, Sequence
from typing import Any

import msgpack
import numpy as np

from cosim.errors import ProtocolError

VERSION = 1
MAX_MESSAGE_BYTES = 512 * 1024 * 1024
DTYPES = frozenset({"float64", "float32", "int64", "int32", "uint8", "bool"})
OPS = frozenset({
    "describe", "instantiate", "enter_initialization_mode", "exit_initialization_mode",
    "set_values", "get_values", "do_step", "step", "end_window", "get_state", "set_state",
    "free_state", "checkpoint", "restore_checkpoint", "take_over", "terminate", "ping", "shutdown",
})


_NAMES = {np.dtype(name): name for name in DTYPES}           # a dtype's wire name, without numpy's slow .name
_DTYPES = {name: np.dtype(name) for name in DTYPES}           # a wire name's dtype, without parsing it


def encode(header: dict[str, Any], arrays: Mapping[str, np.ndarray] | None = None) -> list:
    """Frames for ``header`` plus ``arrays`` (each array one raw frame)."""
    specs, buffers = [], []
    if arrays:
        for name, value in arrays.items():
            array = np.ascontiguousarray(value)
            dtype = _NAMES.get(array.dtype)
            if dtype is None:
                raise ProtocolError(f"array '{name}': dtype {array.dtype} is not sent (allowed: {sorted(DTYPES)})")
            specs.append({"name": name, "dtype": dtype, "shape": list(array.shape)})
            buffers.append(array.data if array.size else b"")
    head = dict(header, v=VERSION, arrays=specs)
    return [msgpack.packb(head, use_bin_type=True), *buffers]


def _frame_bytes(frame: Any) -> memoryview:
    buffer = getattr(frame, "buffer", frame)
    return memoryview(buffer).cast("B")


def decode(frames: Sequence[Any], *, max_bytes: int = MAX_MESSAGE_BYTES) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Validated header and arrays of a message (arrays are read-only views of the frames)."""
    if not frames:
        raise ProtocolError("empty message")
    views = [_frame_bytes(f) for f in frames]
    total = sum(v.nbytes for v in views)
    if total > max_bytes:
        raise ProtocolError(f"message of {total} bytes exceeds the limit of {max_bytes}")
    try:
        header = msgpack.unpackb(views[0], raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises several types
        raise ProtocolError(f"header is not valid msgpack: {exc}") from None
    if not isinstance(header, dict):
        raise ProtocolError("header is not a map")
    if header.get("v") != VERSION:
        raise ProtocolError(f"protocol version {header.get('v')!r} is not supported (expected {VERSION})")
    specs = header.get("arrays", [])
    if not isinstance(specs, list):
        raise ProtocolError("header field 'arrays' is not a list")
    if len(specs) != len(views) - 1:
        raise ProtocolError(f"header declares {len(specs)} arrays but {len(views) - 1} data frames arrived")
    arrays: dict[str, np.ndarray] = {}
    for spec, view in zip(specs, views[1:]):
        array_name, array = _array_from(spec, view)
        if array_name in arrays:
            raise ProtocolError(f"array '{array_name}' appears twice in one message")
        arrays[array_name] = array
    return header, arrays


def _array_from(spec: Any, view: memoryview) -> tuple[str, np.ndarray]:
    if not isinstance(spec, dict) or not isinstance(spec.get("name"), str):
        raise ProtocolError(f"array spec {spec!r} lacks a name")
    name = spec["name"]
    dtype, shape = spec.get("dtype"), spec.get("shape")
    kind = _DTYPES.get(dtype) if isinstance(dtype, str) else None
    if kind is None:
        raise ProtocolError(f"array '{name}': dtype {dtype!r} is not allowed (allowed: {sorted(DTYPES)})")
    if not isinstance(shape, list) or not all(isinstance(n, int) and n >= 0 for n in shape):
        raise ProtocolError(f"array '{name}': shape {shape!r} is not a list of non-negative integers")
    expected = math.prod(shape) * kind.itemsize   # Python integers: no overflow
    if expected != view.nbytes:
        raise ProtocolError(
            f"array '{name}': shape {tuple(shape)} of {dtype} needs {expected} bytes but its frame has {view.nbytes}")
    if not expected:
        return name, np.empty(shape, kind)
    array = np.frombuffer(view, dtype=kind)
    return name, array if len(shape) == 1 else array.reshape(shape)


def number(args: Mapping[str, Any], key: str) -> float:
    """The finite real number ``args[key]`` of a request."""
    value = args.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ProtocolError(f"argument '{key}' must be a finite number, got {value!r}")
    return float(value)


def error_reply(request_id: Any, kind: str, message: str, component: str, logged: bool = False) -> list:
    """Frames of an error reply (``logged``: the component's log holds its traceback)."""
    return encode({"id": request_id, "ok": False,
                   "error": {"type": kind, "message": message, "component": component, "logged": logged}})


# --- the same messages over a byte stream (a pipe between two processes of one run) -------------------------------
_COUNT = struct.Struct("<I")


def to_stream(frames: Sequence[Any]) -> bytes:
    """One message's bytes on a stream: its frame count, each frame's length, then the frames."""
    views = [_frame_bytes(f) for f in frames]
    return b"".join([struct.pack(f"<I{len(views)}Q", len(views), *(v.nbytes for v in views)), *views])


class StreamReader:
    """Cuts the bytes read from a stream into messages (``to_stream``'s), whatever pieces they arrive in."""

    def __init__(self, max_bytes: int = MAX_MESSAGE_BYTES):
        self.buffer = bytearray()
        self.max_bytes = max_bytes

    def feed(self, data: bytes) -> list[list[bytes]]:
        """Every message completed by ``data``, as its frames."""
        self.buffer += data
        messages, start, size = [], 0, len(self.buffer)
        while size - start >= _COUNT.size:
            (count,) = _COUNT.unpack_from(self.buffer, start)
            head = _COUNT.size + 8 * count
            if size - start < head:
                break
            lengths = struct.unpack_from(f"<{count}Q", self.buffer, start + _COUNT.size)
            if sum(lengths) > self.max_bytes:
                raise ProtocolError(f"message of {sum(lengths)} bytes exceeds the limit of {self.max_bytes}")
            if size - start < head + sum(lengths):
                break
            frames, offset = [], start + head
            for length in lengths:
                frames.append(bytes(self.buffer[offset:offset + length]))
                offset += length
            messages.append(frames)
            start = offset
        del self.buffer[:start]
        return messages
