"""The step-map ROM's C code (``native/step_map_rom.c``): the binary resource of a model's arrays it reads, and the
in-process path that calls it (``CompiledStepMap``). The FMU (``rom_component.fmu.step_map_rom``) runs the same
C code, so a run served in-process with
``arithmetic = "compiled"`` or by the FMU gives the same bits; the C sums follow the component's
``reproducible`` NumPy arithmetic, which gives them too.
"""

from __future__ import annotations

import ctypes
import hashlib
import struct
import tempfile
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import CosimError
from rom_component.native.build import C_SOURCES, NAME_BYTES, library_path

SOURCE = C_SOURCES / "step_map_rom.c"

def rest_history(arrays: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The reduced displacement and force of the structure at rest (zero field, zero force)."""
    return -(arrays["u_mean"] @ arrays["Phi_u"]), -arrays["e"]


def resource_bytes(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], guid: str, components: int) -> bytes:
    """What ``step_map_rom.c`` reads from ``resources/rom.bin`` (little-endian; the format in its header)."""
    names = [metadata["input_variable"], metadata["output_variable"]]
    for name in names:
        if len(name.encode()) > NAME_BYTES:
            raise CosimError(f"variable name '{name}' is longer than {NAME_BYTES} bytes")
    E, A = arrays["E"], arrays["A"]
    (r_f, n_in), (n_out, r_u) = E.shape, A.shape
    z_rest, x_rest = rest_history(arrays)
    header = b"CSSTEP1\0" + guid.encode().ljust(40, b"\0")[:40] + b"".join(n.encode().ljust(NAME_BYTES, b"\0")
                                                                        for n in names)
    header += struct.pack("<8i", n_in, n_out, arrays["p0"].size, r_f, r_u, int(metadata["history"]),
                          int(metadata["quadratic_modes"]), components)
    parts = [E, arrays["e"], arrays["W_f"], arrays["W_z"], arrays["W_q"], arrays["c"], A.T, arrays["base"],
             arrays["P"].T, arrays["p0"], np.linalg.pinv(A), z_rest, x_rest]
    return header + b"".join(np.ascontiguousarray(p, dtype="<f8").tobytes() for p in parts)


def model_guid(arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any], components: int) -> str:
    digest = hashlib.sha256(resource_bytes(arrays, metadata, "", components)).digest()
    return "{" + str(uuid.UUID(bytes=digest[:16], version=4)) + "}"


def bind(lib: ctypes.CDLL) -> ctypes.CDLL:
    """Argument and result types of the C functions outside FMI."""
    pointer = ctypes.c_void_p
    lib.rom_open.restype = pointer
    lib.rom_open.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
    lib.rom_last_error.restype = ctypes.c_char_p
    lib.step_map_evaluate.restype = None
    lib.step_map_evaluate.argtypes = [pointer] * 6
    lib.step_map_commit.argtypes = [pointer]
    lib.step_map_history.argtypes = [pointer, pointer, pointer, ctypes.c_int]
    lib.step_map_take_over.restype = ctypes.c_int
    lib.step_map_take_over.argtypes = [pointer, ctypes.c_int32, pointer, pointer]
    lib.rom_close.argtypes = [pointer]
    lib.step_map_bind.restype = None
    lib.step_map_bind.argtypes = [pointer] * 5 + [ctypes.c_double, pointer]
    lib.step_map_serve.restype = ctypes.c_int
    lib.step_map_serve.argtypes = [pointer, ctypes.c_char_p, ctypes.c_double]
    lib.step_map_view.restype = ctypes.POINTER(ctypes.c_double)
    lib.step_map_view.argtypes = [pointer, ctypes.c_int]
    return lib


def address(array: np.ndarray) -> int:
    return array.ctypes.data


class CompiledStepMap:
    """The step map's C code in-process: ``evaluate(f)`` a window's call (the history stays), ``commit()`` the
    window's last call into the history, ``history`` / ``set_history``, ``take_over``."""

    def __init__(self, arrays: Mapping[str, np.ndarray], metadata: Mapping[str, Any]):
        self.lib = bind(ctypes.CDLL(str(library_path(SOURCE))))
        self.folder = tempfile.TemporaryDirectory(prefix="cosim-step-map-")
        guid = model_guid(arrays, metadata, 1)
        Path(self.folder.name, "rom.bin").write_bytes(resource_bytes(arrays, metadata, guid, 1))
        self.handle = self.lib.rom_open(Path(self.folder.name).as_uri().encode(), guid.encode())
        if not self.handle:
            raise CosimError(f"the step-map ROM's C code refused the model: {self.lib.rom_last_error().decode()}")
        (r_f, _), (n_out, r_u) = arrays["E"].shape, arrays["A"].shape
        self.p = int(metadata["history"])
        self.u, self.probes = np.zeros(n_out), np.zeros(arrays["p0"].size)
        self.x, self.z = np.zeros(r_f), np.zeros(r_u)

    def bind(self, envelope: Mapping[str, np.ndarray]) -> None:
        """The served path: the envelope's arrays and a trust buffer bound once; ``serve(margin, f_bytes)`` is then one
        C call whose results are in the views ``outputs`` (interface displacement then probes), ``x``, ``z`` and
        ``trust``."""
        self._envelope = {k: np.ascontiguousarray(v, dtype=np.float64) for k, v in envelope.items()}
        self.trust = np.zeros(3)
        e = self._envelope
        self.lib.step_map_bind(self.handle, address(e["envelope_low"]), address(e["envelope_high"]),
                               address(e["envelope_mean"]), address(e["envelope_precision"]),
                               float(e["envelope_max_distance"][0]), address(self.trust))
        n_out, n_probe = len(self.u), len(self.probes)
        view = lambda which, size: np.ctypeslib.as_array(self.lib.step_map_view(self.handle, which), shape=(size,))
        self.outputs = view(0, n_out + n_probe)
        # from here on every result is a view of the instance's own buffers, served or evaluated
        self.u, self.probes, self.x, self.z = self.outputs[:n_out], self.outputs[n_out:], view(1, len(self.x)), \
            view(2, len(self.z))
        self.serve = lambda margin, f: self.lib.step_map_serve(self.handle, f, margin)

    def evaluate(self, f: np.ndarray) -> None:
        f = np.ascontiguousarray(f, dtype=np.float64)
        self.lib.step_map_evaluate(self.handle, address(f), address(self.u), address(self.probes), address(self.x),
                                   address(self.z))

    def commit(self) -> None:
        self.lib.step_map_commit(self.handle)

    def history(self) -> tuple[np.ndarray, np.ndarray]:
        zh, xh = np.zeros((self.p, len(self.z))), np.zeros((2, len(self.x)))
        self.lib.step_map_history(self.handle, address(zh), address(xh), 0)
        return zh, xh

    def set_history(self, zh: np.ndarray, xh: np.ndarray) -> None:
        zh, xh = (np.ascontiguousarray(a, dtype=np.float64) for a in (zh, xh))
        self.lib.step_map_history(self.handle, address(zh), address(xh), 1)

    def take_over(self, forces: np.ndarray, displacements: np.ndarray) -> None:
        forces, displacements = (np.ascontiguousarray(a, dtype=np.float64) for a in (forces, displacements))
        self.lib.step_map_take_over(self.handle, len(forces), address(forces), address(displacements))

    def close(self) -> None:
        if self.handle:
            self.lib.rom_close(self.handle)
            self.handle = None
        self.folder.cleanup()

