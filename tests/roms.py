"""Solid ROMs of named parts, as the tests build them."""

from typing import Any

from rom_component.static.estimator import SolidRom


def solid_rom(r_f: int = 3, r_u: int = 9, regressor: str | dict[str, Any] = "rbf",
              decoder: str | dict[str, Any] = "linear", scaling: str = "global") -> SolidRom:
    """A POD encoder of ``r_f`` modes, the ``regressor`` (a name or a table with ``type``) and the ``decoder``
    (likewise) of ``r_u`` modes."""
    table = lambda part: {"type": part} if isinstance(part, str) else dict(part)
    return SolidRom.from_settings({"encoder": {"type": "pod", "modes": r_f, "scaling": scaling},
                                   "regressor": table(regressor), "decoder": {**table(decoder), "modes": r_u}})
