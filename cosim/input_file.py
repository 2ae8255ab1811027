"""An input file read whole, safely: a regular file of at most a given size. A FIFO, a device or a socket named as
a scene, a configuration or a status file would block the read or never end (``/dev/zero``); those are refused."""

from __future__ import annotations

import os
import stat
from pathlib import Path

from cosim.errors import CosimError


def read_input(path: str | Path, what: str, limit: int) -> bytes:
    """The bytes of ``path`` (a ``what``: "scene", "preCICE configuration", ...); a ``CosimError`` of one line if it
    is missing, not a regular file, or larger than ``limit`` bytes."""
    path = Path(path)
    try:
        mode = path.stat().st_mode
        if not stat.S_ISREG(mode):
            kind = "a FIFO" if stat.S_ISFIFO(mode) else "a directory" if stat.S_ISDIR(mode) else "a device or socket"
            raise CosimError(f"cannot read {what} '{path}': it is {kind}, not a regular file")
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)    # replaced by a FIFO since the check: no wait
        try:
            data = os.read(fd, limit + 1)
            while len(data) <= limit:
                more = os.read(fd, limit + 1 - len(data))
                if not more:
                    break
                data += more
        finally:
            os.close(fd)
    except OSError as exc:
        raise CosimError(f"cannot read {what} '{path}': {exc.strerror or exc}") from None
    if len(data) > limit:
        raise CosimError(f"{path}: more than {limit:,} bytes; a {what} file has at most {limit:,}")
    return data
