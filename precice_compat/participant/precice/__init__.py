"""preCICE's Python participant API, served by cosim's coupler instead of libprecice.

``precice.Participant`` is pyprecice 3's API, ``precice.Interface`` (with the ``action_*`` functions) pyprecice
2.5's. A participant written against either runs unmodified under ``cosim run``, which starts it with this package
first on its import path, or by hand once a coupler runs for its configuration (``cosim run CONFIG.xml``).

Every method documents its parameters, what it returns, the calls that must come before it, and where cosim
differs from preCICE: ``help(precice.Participant.write_data)``, say. A misuse raises ``precice.Error``, a
``RuntimeError`` whose one line names the call and why. A participant that lets it go uncaught ends as preCICE ends
one on its errors: the line on stderr (``precice: error: ...``, no traceback) and exit code 2.
"""

import os
import sys

from precice._connection import OPEN, Error
from precice._interface import (
    Interface,
    action_read_iteration_checkpoint,
    action_write_initial_data,
    action_write_iteration_checkpoint,
)
from precice._participant import Participant

__version__ = "3.0.0+cosim.0.1.0"
_previous_hook = sys.excepthook


def _error_in_one_line(kind, value, traceback):  # type: ignore[no-untyped-def]
    """An uncaught ``precice.Error``: its line and exit code 2; any other exception as Python shows it."""
    if not issubclass(kind, Error):
        _previous_hook(kind, value, traceback)
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    sys.stderr.write(f"precice: error: {value}\n")
    sys.stderr.flush()
    for connection in list(OPEN):        # the error told to the coupler leaves before the process does
        try:
            connection.close()
        except Exception:
            pass
    os._exit(2)


sys.excepthook = _error_in_one_line


def get_version_information() -> bytes:
    """The version of preCICE's API this package stands for, and what serves it.

    Returns
    -------
    bytes
        As pyprecice's: starting with the version (``3.0.0``), then, after ``;``, that cosim's coupler serves it.

    Notes
    -----
    Any time; no coupler is needed.
    """
    return b"3.0.0;served by cosim 0.1.0 (preCICE's v3 Participant and v2 Interface)"


__all__ = ["Participant", "Interface", "Error", "action_write_initial_data", "action_write_iteration_checkpoint",
           "action_read_iteration_checkpoint", "get_version_information"]
