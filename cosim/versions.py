"""The versions a run records and a resumed run checks: this package's, Python's and its numerical libraries'.

Read from the installed distributions' metadata, not by importing them: the coupler records them before it imports
SciPy or h5py (which it may never need).
"""

from __future__ import annotations

import platform
from importlib.metadata import PackageNotFoundError, version

DISTRIBUTIONS = {"numpy": "numpy", "scipy": "scipy", "h5py": "h5py", "pyzmq": "pyzmq", "msgpack": "msgpack"}


def versions() -> dict[str, str]:
    """{"cosim", "python", "numpy", "scipy", "h5py", "pyzmq", "msgpack"}: each its version string."""
    import cosim
    found = {"cosim": cosim.__version__, "python": platform.python_version()}
    for key, distribution in DISTRIBUTIONS.items():
        try:
            found[key] = version(distribution)
        except PackageNotFoundError:
            found[key] = "not installed"
    return found
