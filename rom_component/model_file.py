"""A trained ROM on disk: one ``.npz`` of arrays plus JSON metadata, no pickle.

The metadata (variable names, hyper-parameters, training summary) is stored as the
UTF-8 bytes of a JSON document in the array ``metadata_json``; the file is read with
``allow_pickle=False``, and a file carrying object arrays is refused.
"""

from __future__ import annotations

import json
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import CosimError
from rom_component.model_check import ModelContentError, check_arrays, check_members

FORMAT = "cosim-solid-rom/1"


class ModelFileError(CosimError, ValueError):
    """A model file is missing, corrupt, or not a ROM file."""


def save(path: str | Path, arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any]) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for name, value in arrays.items():
        if np.asarray(value).dtype == object:
            raise ModelFileError(f"array '{name}' has dtype object, which cannot be saved without pickle")
    try:
        check_arrays({k: np.asarray(v) for k, v in arrays.items()}, metadata)
    except ModelContentError as exc:
        raise ModelFileError(f"model '{path}' is not saved: {exc}") from None
    document = json.dumps({"format": FORMAT, **metadata}, sort_keys=True)
    payload = {name: np.asarray(value) for name, value in arrays.items()}
    payload["metadata_json"] = np.frombuffer(document.encode(), dtype=np.uint8)
    partial = path.with_name(path.name + ".partial")
    with open(partial, "wb") as f:
        np.savez(f, **payload)  # type: ignore[arg-type]  # numpy's stub takes allow_pickle for a keyword
    partial.replace(path)        # a model file is complete or absent, never half written
    return path


def load_arrays(path: str | Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Arrays and metadata of a model file; clear errors for anything else."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file '{path}' does not exist")
    with open(path, "rb") as f:
        if f.read(4) != b"PK\x03\x04":
            raise ModelFileError(f"model file '{path}' is not a valid .npz (not a zip archive)")
    try:
        with zipfile.ZipFile(path) as archive:
            check_members(archive)
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except ModelContentError as exc:
        raise ModelFileError(f"model file '{path}': {exc}") from None
    except ValueError as exc:
        if "pickle" in str(exc).lower():
            raise ModelFileError(f"model file '{path}' carries pickled objects; refusing to load it") from None
        raise ModelFileError(f"model file '{path}' is not a valid .npz: {exc}") from None
    except (OSError, zipfile.BadZipFile, EOFError) as exc:
        raise ModelFileError(f"model file '{path}' is not a valid .npz: {exc}") from None
    if "metadata_json" not in arrays:
        raise ModelFileError(f"model file '{path}' has no 'metadata_json': not a ROM file")
    try:
        metadata = json.loads(arrays.pop("metadata_json").tobytes().decode())
    except (UnicodeDecodeError, ValueError) as exc:
        raise ModelFileError(f"model file '{path}': metadata is not valid JSON ({exc})") from None
    if not isinstance(metadata, dict) or metadata.get("format") != FORMAT:
        found = metadata.get("format") if isinstance(metadata, dict) else metadata
        raise ModelFileError(f"model file '{path}' has format {found!r}, expected {FORMAT!r}")
    try:
        check_arrays(arrays, metadata)
    except ModelContentError as exc:
        raise ModelFileError(f"model file '{path}': {exc}") from None
    return arrays, metadata
