"""A subcommand of ``cosim``: each package registers its own under the entry-point group
``cosim.commands`` (see ``pyproject.toml``), so the bottom layer imports no package above it.

A command module should stay light: heavy imports belong inside ``run``, so that
``cosim --help`` only reads the argument definitions.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

GROUP = "cosim.commands"


@dataclass(frozen=True)
class Command:
    """``help`` for the listing, ``arguments`` to define its options, ``run`` to carry it out (exit code);
    ``description`` and ``example`` for its own ``--help``."""

    help: str
    arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    description: str = ""
    example: str = ""
