"""preCICE's Python participant API, served by cosim's coupler instead of libprecice.

``precice.Participant`` is pyprecice 3's API, ``precice.Interface`` (with the ``action_*`` functions) pyprecice
2.5's. A participant written against either runs unmodified under ``cosim run``, which starts it with this package
first on its import path, or by hand once a coupler runs for its configuration (``cosim run CONFIG.xml``).

Every method documents its parameters, what it returns, the calls that must come before it, and where cosim
differs from preCICE: ``help(precice.Participant.write_data)``, say. A misuse raises ``precice.Error``, a
``RuntimeError`` whose one line names the call and why.
"""

from precice._connection import Error
from precice._interface import (
    Interface,
    action_read_iteration_checkpoint,
    action_write_initial_data,
    action_write_iteration_checkpoint,
)
from precice._participant import Participant

__version__ = "3.0.0+cosim.0.1.0"


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
