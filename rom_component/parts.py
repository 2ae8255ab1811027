"""The ROM's parts: encoders, regressors and decoders, registered by name, each owning its settings.

A part is a scikit-learn estimator whose constructor parameters are exactly the keys of its class's
``SETTINGS`` (a ``cosim.schema`` schema with defaults and ranges) and are explained by ``HELP``. A ROM
configuration names each part by a table with ``type`` and its settings::

    [model]
    encoder = {type = "pod", modes = 45}
    regressor = {type = "poly", method = "ridge", cross_modes = 5}
    decoder = {type = "quadratic", modes = 9}

``ENCODERS``, ``REGRESSORS`` and ``DECODERS`` check such a table against the chosen class's own settings
(``Registry.settings``) and build the part (``Registry.create``); ``SolidRom`` composes the three. The modules ``encoders``, ``regression`` and
``decoders`` hold the registered classes.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from sklearn.base import BaseEstimator

from cosim.errors import SceneError
from cosim.registry import Registry
from cosim.schema import validate


class Part(BaseEstimator):
    """A ROM part: its settings are its parameters, validated by its own schema."""

    SETTINGS: ClassVar[dict[str, Any]] = {}
    HELP: ClassVar[dict[str, str]] = {}
    type_name: ClassVar[str]         # set by the registry: the name a configuration chooses it by

    def check_params(self, where: str) -> None:
        """Raise ValueError naming the first parameter outside its schema (``where``: the part's key)."""
        try:
            validate(self.get_params(), self.SETTINGS, f"{where}.")
        except SceneError as exc:
            raise ValueError(str(exc)) from None

    def settings(self) -> dict[str, Any]:
        """The part as a configuration names it: ``type`` and its settings."""
        return {"type": self.type_name, **self.get_params()}


class Encoder(Part):
    """Forces (m, N) to the regressor's inputs (m, r_f)."""

    modes: int          # r_f asked for
    modes_: int         # r_f used (capped by the data)

    def fit(self, F: np.ndarray) -> Encoder:
        raise NotImplementedError

    def transform(self, F: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def online_arrays(self) -> dict[str, np.ndarray]:
        """The online path's arrays E, e of x = E f - e (``rom_component.static.online``), and what plots need."""
        raise NotImplementedError

    def jacobian(self) -> np.ndarray:
        """d transform / d f, (r_f, N_f): an encoder is affine."""
        raise NotImplementedError


class Regressor(Part):
    """The encoder's coordinates (m, r_f) to the decoder's (m, r_u)."""

    @property
    def windows_group_fit(self) -> bool:
        """Whether fit cross-validates over the windows it is given as groups."""
        return False

    def fit(self, X: np.ndarray, Y: np.ndarray, groups: np.ndarray | None = None) -> Regressor:
        raise NotImplementedError

    def predict(self, X: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def online_arrays(self) -> dict[str, np.ndarray]:
        """The online path's H (and centres or term indices)."""
        raise NotImplementedError

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """d predict / d x at one input ``x`` (r_f,), in closed form: (r_u, r_f)."""
        raise NotImplementedError


class Decoder(Part):
    """Reduced displacements (m, r_u) to the field (m, N_u)."""

    modes: int          # r_u asked for
    modes_: int         # r_u used (capped by the data)

    def fit_transform(self, U: np.ndarray) -> np.ndarray:
        """Fit on the displacement rows ``U``; their reduced coordinates, the regressor's targets."""
        raise NotImplementedError

    def inverse_transform(self, Z: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def online_arrays(self, K: slice | np.ndarray = slice(None)) -> dict[str, np.ndarray]:
        """The online path's A, base (and B) on the field's rows ``K``, and the full field's modes."""
        raise NotImplementedError

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """d inverse_transform / d z at one reduced displacement ``z`` (r_u,): (N_u, r_u)."""
        raise NotImplementedError


ENCODERS: Registry[Encoder] = Registry("encoder")
REGRESSORS: Registry[Regressor] = Registry("regressor")
DECODERS: Registry[Decoder] = Registry("decoder")
PARTS: dict[str, Registry[Any]] = {"encoder": ENCODERS, "regressor": REGRESSORS, "decoder": DECODERS}



def describe_parts(params: dict[str, dict[str, Any]]) -> str:
    """A model's parts in one line: ``r_f=45 r_u=9 pod(scaling=global) poly(method=ridge, ...) quadratic(...)``; a
    step map's settings: ``r_f=12 r_u=8 step-map(history=4, ...)``."""
    if "step_map" in params:
        step = dict(params["step_map"])
        modes = f"r_f={step.pop('force_modes', None)} r_u={step.pop('disp_modes', None)}"
        return f"{modes} step-map({', '.join(f'{k}={v}' for k, v in step.items())})"
    def settings(kind: str) -> str:
        part = params.get(kind, {})
        inner = ", ".join(f"{k}={v}" for k, v in part.items() if k not in ("type", "modes"))
        return f"{part.get('type', '?')}({inner})"
    modes = f"r_f={params.get('encoder', {}).get('modes')} r_u={params.get('decoder', {}).get('modes')}"
    return " ".join([modes, *(settings(kind) for kind in ("encoder", "regressor", "decoder"))])
