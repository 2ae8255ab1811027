"""Checkpoints of a run, without pickle: state trees as a JSON document plus NumPy arrays.

A *state tree* is made of dicts with string keys, lists, tuples, deques, sets, NumPy arrays and scalars, strings,
booleans and None. ``pack`` turns it into a JSON document, in which every array is a reference into a dict of
arrays, and ``unpack`` reverses it exactly (floats through JSON keep their bits: Python writes the shortest repr
that reads back to the same double). ``object_state`` and ``restore_object`` carry an object's attributes (and
those of the plug-in objects it holds) through such a tree.

The checkpoint file (``checkpoint.npz`` next to ``results.h5``) holds one such document and its arrays; it is
written whole to a temporary name and renamed, so that it is always complete: the last one, or none.
"""

from __future__ import annotations

import json
import os
import zipfile
from collections import deque
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import CosimError
from cosim.npz import member_header

FORMAT = "cosim-checkpoint/1"
FILE = "checkpoint.npz"
DOCUMENT = "document_json"
MAX_DOCUMENT_BYTES = 64 << 20     # the JSON document: counts, settings, the scheme's tree


class CheckpointError(CosimError):
    """A state that cannot be checkpointed, or a checkpoint that cannot be read or does not fit the run."""


def pack(tree: Any, prefix: str = "") -> tuple[Any, dict[str, np.ndarray]]:
    """The JSON-ready document of ``tree`` and its arrays (keys start with ``prefix``)."""
    arrays: dict[str, np.ndarray] = {}

    def encode(node: Any, path: str) -> Any:
        if isinstance(node, np.ndarray):
            if node.dtype == object:
                raise CheckpointError(f"state '{path}' is an array of Python objects")
            key = f"{prefix}{len(arrays)}"
            arrays[key] = node
            return {"__array__": key}
        if isinstance(node, (bool, np.bool_)):
            return bool(node)
        if isinstance(node, (int, np.integer)):
            return int(node)
        if isinstance(node, (float, np.floating)):
            return float(node)
        if node is None or isinstance(node, str):
            return node
        if isinstance(node, Mapping):
            if not all(isinstance(k, str) for k in node):
                raise CheckpointError(f"state '{path}' is a dict with keys that are not strings")
            if any(k.startswith("__") and k.endswith("__") for k in node):
                return {"__dict__": {k: encode(v, f"{path}.{k}") for k, v in node.items()}}
            return {k: encode(v, f"{path}.{k}") for k, v in node.items()}
        for kind, name in ((tuple, "tuple"), (deque, "deque"), (set, "set"), (frozenset, "set")):
            if isinstance(node, kind):
                items = sorted(node) if name == "set" else list(node)
                extra = {"maxlen": node.maxlen} if isinstance(node, deque) else {}
                return {"__" + name + "__": [encode(v, f"{path}.{i}") for i, v in enumerate(items)], **extra}
        if isinstance(node, list):
            return [encode(v, f"{path}.{i}") for i, v in enumerate(node)]
        raise CheckpointError(f"state '{path}' is of type {type(node).__name__}, which a checkpoint cannot hold")

    return encode(tree, "state"), arrays


def unpack(document: Any, arrays: Mapping[str, np.ndarray]) -> Any:
    """The state tree ``pack`` made ``document`` and ``arrays`` of."""
    def decode(node: Any) -> Any:
        if isinstance(node, list):
            return [decode(v) for v in node]
        if not isinstance(node, dict):
            return node
        if "__array__" in node:
            key = node["__array__"]
            if key not in arrays:
                raise CheckpointError(f"checkpoint lacks array '{key}'")
            return np.array(arrays[key])
        if "__tuple__" in node:
            return tuple(decode(v) for v in node["__tuple__"])
        if "__deque__" in node:
            return deque((decode(v) for v in node["__deque__"]), maxlen=node.get("maxlen"))
        if "__set__" in node:
            return {decode(v) for v in node["__set__"]}
        if "__dict__" in node:
            return {k: decode(v) for k, v in node["__dict__"].items()}
        return {k: decode(v) for k, v in node.items()}

    return decode(document)


def object_state(obj: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """The attributes of ``obj`` (but ``skip``) as a state tree; attributes that are objects with attributes of
    their own (plug-ins a plug-in holds) are taken the same way."""
    state: dict[str, Any] = {}
    for name, value in vars(obj).items():
        if name in skip:
            continue
        if _is_object(value):
            state[name] = {"__object__": object_state(value)}
        elif isinstance(value, list) and value and all(_is_object(v) for v in value):
            state[name] = {"__objects__": [object_state(v) for v in value]}
        else:
            state[name] = value
    return state


def restore_object(obj: Any, state: Mapping[str, Any]) -> None:
    """Set the attributes ``object_state`` took, on ``obj`` and the objects it holds."""
    for name, value in state.items():
        if isinstance(value, dict) and "__object__" in value:
            restore_object(getattr(obj, name), value["__object__"])
        elif isinstance(value, dict) and "__objects__" in value:
            for member, member_state in zip(getattr(obj, name), value["__objects__"]):
                restore_object(member, member_state)
        else:
            setattr(obj, name, value)


def _is_object(value: Any) -> bool:
    return hasattr(value, "__dict__") and not isinstance(value, (type, np.ndarray)) and not callable(value)


def write(path: str | Path, document: Mapping[str, Any], arrays: Mapping[str, np.ndarray]) -> Path:
    """Write a checkpoint file whole (temporary name, then rename); a failed write (a full disk) leaves no
    partial file and raises ``CheckpointError`` naming the file."""
    path = Path(path)
    payload = {key: np.asarray(value) for key, value in arrays.items()}
    payload[DOCUMENT] = np.frombuffer(json.dumps({"format": FORMAT, **document}).encode(), dtype=np.uint8)
    partial = path.with_name(path.name + ".partial")
    try:
        with open(partial, "wb") as f:
            np.savez(f, **payload)  # type: ignore[arg-type]  # numpy's stub takes allow_pickle for a keyword
            f.flush()
            os.fsync(f.fileno())
        partial.replace(path)
    except OSError as exc:
        partial.unlink(missing_ok=True)
        raise CheckpointError(f"cannot write the checkpoint '{path}': {exc.strerror or exc}") from None
    return path


def read(path: str | Path, wanted: Callable[[str, dict[str, Any]], bool] = lambda name, document: True,
         check: Callable[[dict[str, Any]], None] = lambda document: None,
         max_document_bytes: int = MAX_DOCUMENT_BYTES) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """A checkpoint file's document and arrays; a one-line error for anything else. Every member is checked from
    its header before anything is loaded: a compressed one (a checkpoint is written uncompressed) is refused, so
    that memory stays within the file's size. The document is read first and handed to ``check``; then an array
    that ``wanted(name, document)`` does not take is refused before it is read."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"no checkpoint '{path}': the run wrote none (output.checkpoint_every) or it is "
                              "not a run directory")
    try:
        with zipfile.ZipFile(path) as archive:
            members = {info.filename.removesuffix(".npy"): info for info in archive.infolist()}
            for name, info in members.items():
                _check_member(path, archive, name, info, max_document_bytes)
            if DOCUMENT not in members:
                raise CheckpointError(f"checkpoint '{path}' is not a {FORMAT} file (no document)")
            with archive.open(members[DOCUMENT]) as member:
                document = json.loads(np.lib.format.read_array(member, allow_pickle=False).tobytes().decode())
            if not isinstance(document, dict) or document.get("format") != FORMAT:
                raise CheckpointError(f"checkpoint '{path}' is not a {FORMAT} file")
            check(document)
            unknown = sorted(name for name in members if name != DOCUMENT and not wanted(name, document))
            if unknown:
                raise CheckpointError(f"checkpoint '{path}' holds an array '{unknown[0]}' that belongs to no part "
                                      f"of this run ({len(unknown)} such arrays): it is not this run's checkpoint")
            arrays = {}
            for name, info in members.items():
                if name != DOCUMENT:
                    with archive.open(info) as member:
                        arrays[name] = np.lib.format.read_array(member, allow_pickle=False)
    except CheckpointError:
        raise
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError, UnicodeDecodeError) as exc:
        raise CheckpointError(f"checkpoint '{path}' cannot be read: {exc}") from None
    return document, arrays


def array_keys(document: Any) -> set[str]:
    """The array names a packed document refers to."""
    found: set[str] = set()
    stack = [document]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            if isinstance(node.get("__array__"), str):
                found.add(node["__array__"])
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
    return found


def _check_member(path: Path, archive: zipfile.ZipFile, name: str, info: zipfile.ZipInfo, max_document: int) -> None:
    """A member must be a stored ``.npy`` array of plain data whose header declares what the member holds."""
    if not info.filename.endswith(".npy") or info.compress_type != zipfile.ZIP_STORED:
        raise CheckpointError(f"checkpoint '{path}': member '{info.filename}' is not an uncompressed .npy array, "
                              "as a checkpoint writes them")
    try:
        declared = member_header(archive, info)
    except ValueError as exc:
        raise CheckpointError(f"checkpoint '{path}': array '{name}': {exc}") from None
    if declared.dtype.hasobject:
        raise CheckpointError(f"checkpoint '{path}': array '{name}' holds Python objects")
    size = declared.data_bytes
    if size + declared.header_bytes != info.file_size or (name == DOCUMENT and size > max_document):
        raise CheckpointError(f"checkpoint '{path}': array '{name}' declares {size:,} bytes in a member of "
                              f"{info.file_size:,}: the file is damaged")
