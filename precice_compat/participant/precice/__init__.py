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


def get_version_information() -> str:
    """The version this package stands for (preCICE's API), and whose coupler serves it."""
    return "preCICE API 3.0.0 and 2.5 (v2 Interface), served by cosim 0.1.0"


__all__ = ["Participant", "Interface", "Error", "action_write_initial_data", "action_write_iteration_checkpoint",
           "action_read_iteration_checkpoint", "get_version_information"]
