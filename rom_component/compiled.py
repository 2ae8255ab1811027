"""The ROM's online path run by the exported FMU's own C code, in-process (``arithmetic = "compiled"``).

The FMU's source (``fmu/solid_rom.c``) is compiled once per source and compiler into a cache
folder (``$COSIM_CACHE``, else ``~/.cache/cosim``) and called through ctypes on the caller's arrays,
without the FMI state machine. Its sums run in the order of ``OnlineRom(arithmetic="reproducible")``,
so the results are bit-identical to it and to the FMU, at the FMU's speed.
"""

from __future__ import annotations

import ctypes
import hashlib
import math
import os
import tempfile
import weakref
from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from cosim.errors import CosimError
from rom_component.model_check import check_arrays
from rom_component.native import SOURCE, compile_binary, model_guid, resource_bytes, write_sources
from rom_component.online import OnlineRom


def cache_dir() -> Path:
    return Path(os.environ.get("COSIM_CACHE") or Path.home() / ".cache" / "cosim")


def library_path(defines: tuple[str, ...] = (), source: Path = SOURCE) -> Path:
    """The compiled library of ``source`` (the static ROM's by default) for its present text, the compiler and
    ``defines``, built if missing."""
    compiler = os.environ.get("CC", "cc")
    digest = hashlib.sha256(source.read_bytes() + compiler.encode() + " ".join(defines).encode()).hexdigest()[:16]
    target = cache_dir() / f"{source.stem}-{digest}.so"
    if target.is_file():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        sources = Path(tmp)
        write_sources(sources, source)
        built = sources / target.name
        compile_binary(sources, built, defines, source)
        os.replace(built, target)    # atomic: processes building at once all end with a whole library
    return target


def _library(defines: tuple[str, ...] = ()) -> ctypes.CDLL:
    lib = ctypes.CDLL(str(library_path(defines)))
    lib.solid_rom_open.restype = ctypes.c_void_p
    lib.solid_rom_open.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
    lib.solid_rom_last_error.restype = ctypes.c_char_p
    lib.solid_rom_evaluate.restype = None
    lib.solid_rom_evaluate.argtypes = [ctypes.c_void_p] * 5
    lib.solid_rom_evaluate_trust.restype = None
    lib.solid_rom_evaluate_trust.argtypes = [ctypes.c_void_p] * 10
    lib.solid_rom_bind.restype = ctypes.c_void_p
    lib.solid_rom_bind.argtypes = [ctypes.c_void_p] * 9 + [ctypes.c_double, ctypes.c_void_p]
    lib.solid_rom_serve.restype = ctypes.c_int
    lib.solid_rom_serve.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_char_p]
    lib.solid_rom_unbind.argtypes = [ctypes.c_void_p]
    lib.solid_rom_close.argtypes = [ctypes.c_void_p]
    return lib


class Served(NamedTuple):
    """The ROM's served call, bound once to fixed buffers: ``call(margin, f)`` (f: the input's float64
    bytes, or None for the input already in ``force``) copies f into ``force``, evaluates, fills
    ``displacement``, ``reduced`` and ``trust`` = (excess, distance, out of range as 0.0 or 1.0; NaN,
    NaN, 0.0 without an envelope) and returns 1 if out of range. One C call and no NumPy call: in a
    coupled run the ROM wakes with cold caches, where each NumPy call costs microseconds."""
    call: Callable[[float, bytes | None], int]
    force: np.ndarray
    displacement: np.ndarray
    reduced: np.ndarray
    trust: np.ndarray


class CompiledRom(OnlineRom):
    """``OnlineRom`` whose calls run the FMU's C code (bit-identical to ``arithmetic="reproducible"``)."""

    def __init__(self, arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], defines: tuple[str, ...] = ()):
        """``defines``: preprocessor names for the build (``SOLID_ROM_SCALAR``: no vector types, same results)."""
        check_arrays(arrays, metadata)     # the C code reads every array by the sizes it derives: whatever their source
        super().__init__(arrays, metadata, "reproducible")
        self.arithmetic = "compiled"
        self._lib = _library(defines)
        guid = model_guid(self, 1)
        with tempfile.TemporaryDirectory() as tmp:   # the C code reads the whole file at open
            (Path(tmp) / "rom.bin").write_bytes(resource_bytes(self, guid, 1))
            handle = self._lib.solid_rom_open(Path(tmp).as_uri().encode(), guid.encode())
        if not handle:
            raise CosimError(f"the compiled ROM did not open: {self._lib.solid_rom_last_error().decode()}")
        self._handle = handle
        self._finalizer = weakref.finalize(self, self._lib.solid_rom_close, handle)
        # fixed buffers, their addresses taken once; the C code writes the reduced forces where trust() reads
        self._f, self._u, self._reduced = np.empty(self.n_inputs), np.empty(self.n_outputs), np.empty(len(self.reduced))
        buffers = (handle, self._f.ctypes.data, self._u.ctypes.data, self._x_slot.ctypes.data, self._reduced.ctypes.data)
        self._call: tuple = (self._lib.solid_rom_evaluate, *buffers)
        self._evaluate = self._compiled
        envelope: tuple[int, ...] = (0, 0, 0, 0)    # NULL pointers: no envelope, no trust
        self._max_distance = 1.0
        if self.envelope is not None:      # with an envelope, each call computes its trust too (one ctypes call)
            env = {k: np.ascontiguousarray(v, dtype=np.float64) for k, v in self.envelope.items()}
            envelope = tuple(env[k].ctypes.data for k in ("envelope_low", "envelope_high", "envelope_mean",
                                                          "envelope_precision"))
            self._trust_out = np.full(2, np.nan)
            self._call = (self._lib.solid_rom_evaluate_trust, *buffers, *envelope, self._trust_out.ctypes.data)
            self._envelope_arrays, self._max_distance = env, float(env["envelope_max_distance"][0])
        self.served = self._bind(buffers, envelope)

    def _bind(self, buffers: tuple, envelope: tuple) -> Served:
        trust = np.array([np.nan, np.nan, 0.0])
        served = self._lib.solid_rom_bind(*buffers, *envelope, self._max_distance, trust.ctypes.data)
        if not served:
            raise CosimError("the compiled ROM could not bind its served call (out of memory)")
        weakref.finalize(self, self._lib.solid_rom_unbind, served)
        return Served(partial(self._lib.solid_rom_serve, served), self._f, self._u, self._reduced, trust)

    def _compiled(self, f: np.ndarray) -> np.ndarray:
        if np.shape(f) != self._f.shape:
            raise ValueError(f"ROM input has shape {np.shape(f)}, expected {self._f.shape}")
        self._f[:] = f
        self._call[0](*self._call[1:])
        self.reduced = self._reduced.copy()
        return self._u.copy()   # fresh arrays, as OnlineRom returns

    def trust(self) -> tuple[float, float]:
        """As ``OnlineRom.trust``, summed in C with the call (the distance may differ in its last bits)."""
        if self.envelope is None:
            return math.nan, math.nan
        excess, quadratic = self._trust_out.tolist()
        return excess, math.sqrt(quadratic) / self._max_distance
