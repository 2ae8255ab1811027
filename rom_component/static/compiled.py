"""The ROM's online path run by its C code in-process (``arithmetic = "compiled"``), the code the exported FMU runs.

The ROM's source (``native/solid_rom.c``) is compiled once per source and compiler into a cache
folder (``$COSIM_CACHE``, else ``~/.cache/cosim``) and called through ctypes on the caller's arrays,
without the FMI state machine. Its sums run in the order of ``OnlineRom(arithmetic="reproducible")``,
so the results are bit-identical to it and to the FMU, at the FMU's speed.
"""

from __future__ import annotations

import ctypes
import hashlib
import math
import struct
import tempfile
import uuid
import weakref
from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from cosim.errors import CosimError
from rom_component.model_check import check_arrays
from rom_component.native.build import C_SOURCES, NAME_BYTES, library_path
from rom_component.static.online import OnlineRom

SOURCE = C_SOURCES / "solid_rom.c"




def resource_bytes(rom: OnlineRom, guid: str, components: int) -> bytes:
    """The binary resource the C code reads (little-endian; format in ``solid_rom.c``)."""
    a = rom.arrays
    rbf = rom.regressor == "rbf"
    r_f, n_in = rom.E.shape
    n_out, r_u = rom.A.shape
    m = len(a["centres"]) if rbf else len(rom.qi) + len(rom.ci)
    names = [rom.metadata.get("input_variable", "force"), rom.metadata.get("output_variable", "displacement")]
    for name in names:
        if len(name.encode()) > NAME_BYTES:
            raise CosimError(f"variable name '{name}' is longer than {NAME_BYTES} bytes")
    header = b"CSROM04\0" + guid.encode().ljust(40, b"\0")[:40] + b"".join(n.encode().ljust(NAME_BYTES, b"\0")
                                                                        for n in names)
    header += struct.pack("<8i", n_in, n_out, r_f, r_u, m, 0 if rbf else 1, 1 if rom.quadratic_decoder else 0,
                          components)
    parts = [rom.E, rom.e]
    parts += [a["centres"]] if rbf else []
    body = b"".join(np.ascontiguousarray(p, dtype="<f8").tobytes() for p in parts)
    if not rbf:
        body += np.concatenate([rom.qi, rom.ci]).astype("<i4").tobytes()
        body += np.concatenate([rom.qj, rom.cj]).astype("<i4").tobytes()
        body += np.concatenate([np.full(len(rom.qi), -1), rom.ck]).astype("<i4").tobytes()   # -1: no third factor
    tail = [rom.H, rom.A.T, rom.base] + ([rom.B.T] if rom.quadratic_decoder else [])   # decoders transposed
    body += b"".join(np.ascontiguousarray(p, dtype="<f8").tobytes() for p in tail)
    return header + body


def model_guid(rom: OnlineRom, components: int) -> str:
    """A GUID derived from the model's content: the same model exports the same FMU."""
    digest = hashlib.sha256(resource_bytes(rom, "", components)).digest()
    return "{" + str(uuid.UUID(bytes=digest[:16], version=4)) + "}"


def _library(defines: tuple[str, ...] = ()) -> ctypes.CDLL:
    lib = ctypes.CDLL(str(library_path(SOURCE, defines)))
    lib.rom_open.restype = ctypes.c_void_p
    lib.rom_open.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
    lib.rom_last_error.restype = ctypes.c_char_p
    lib.solid_rom_evaluate.restype = None
    lib.solid_rom_evaluate.argtypes = [ctypes.c_void_p] * 5
    lib.solid_rom_evaluate_trust.restype = None
    lib.solid_rom_evaluate_trust.argtypes = [ctypes.c_void_p] * 10
    lib.solid_rom_bind.restype = ctypes.c_void_p
    lib.solid_rom_bind.argtypes = [ctypes.c_void_p] * 9 + [ctypes.c_double, ctypes.c_void_p]
    lib.solid_rom_serve.restype = ctypes.c_int
    lib.solid_rom_serve.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_char_p]
    lib.solid_rom_unbind.argtypes = [ctypes.c_void_p]
    lib.rom_close.argtypes = [ctypes.c_void_p]
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
    """``OnlineRom`` whose calls run the ROM's C code (bit-identical to ``arithmetic="reproducible"``)."""

    def __init__(self, arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], defines: tuple[str, ...] = ()):
        """``defines``: preprocessor names for the build (``SOLID_ROM_SCALAR``: no vector types, same results)."""
        check_arrays(arrays, metadata)     # the C code reads every array by the sizes it derives: whatever their source
        super().__init__(arrays, metadata, "reproducible")
        self.arithmetic = "compiled"
        self._lib = _library(defines)
        guid = model_guid(self, 1)
        with tempfile.TemporaryDirectory() as tmp:   # the C code reads the whole file at open
            (Path(tmp) / "rom.bin").write_bytes(resource_bytes(self, guid, 1))
            handle = self._lib.rom_open(Path(tmp).as_uri().encode(), guid.encode())
        if not handle:
            raise CosimError(f"the compiled ROM did not open: {self._lib.rom_last_error().decode()}")
        self._handle = handle
        self._finalizer = weakref.finalize(self, self._lib.rom_close, handle)
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
