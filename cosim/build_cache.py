"""Build products made on first use and kept by fingerprint (generated meshes, for example).

A product is a folder named by the hash of what it is made from. It is built in a temporary
folder beside its final place and renamed into it, so processes that need it at once (the fluid
and the structure of one run) never see half of it; the first rename wins. The cache lives in
``$COSIM_CACHE`` or else ``~/.cache/cosim``.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

COMPLETE = "spec.json"     # written last: a folder without it is not a product


def cache_root() -> Path:
    """Where build products are kept."""
    return Path(os.environ.get("COSIM_CACHE") or Path.home() / ".cache" / "cosim")


def fingerprint(spec: Mapping[str, Any]) -> str:
    """A short hash of ``spec`` (JSON with sorted keys)."""
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:16]


def cached_build(kind: str, spec: Mapping[str, Any], build: Callable[[Path], None]) -> Path:
    """The folder of the product ``spec`` of ``kind``; ``build(folder)`` makes it when it is not there yet."""
    root = cache_root() / kind
    final = root / fingerprint(spec)
    if (final / COMPLETE).is_file():
        return final
    root.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(dir=root, prefix=f".{final.name}-"))
    try:
        build(scratch)
        (scratch / COMPLETE).write_text(json.dumps(spec, sort_keys=True, indent=1))
        try:
            scratch.rename(final)
        except OSError:                      # another process finished first: its product is the same
            if not (final / COMPLETE).is_file():
                raise
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return final
