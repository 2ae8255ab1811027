"""preCICE's Python participant API, served by cosim's coupler instead of libprecice.

``precice.Participant`` is pyprecice 3's API, ``precice.Interface`` (with the ``action_*`` functions) pyprecice
2.5's. A participant written against either runs unmodified under ``cosim run``, which starts it with this package
first on its import path, or by hand once a coupler runs for its configuration (``cosim run CONFIG.xml``).
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
    """As pyprecice: bytes that start with the version of preCICE's API this package stands for, then, after ``;``,
    whose coupler serves it."""
    return b"3.0.0;served by cosim 0.1.0 (preCICE's v3 Participant and v2 Interface)"


__all__ = ["Participant", "Interface", "Error", "action_write_initial_data", "action_write_iteration_checkpoint",
           "action_read_iteration_checkpoint", "get_version_information"]
