"""The solid ROM as a scikit-learn estimator composed of three registered parts: ``fit(F, U)``, ``predict(F)``.

Snapshots are rows (scikit-learn convention): F (m, N) interface forces, U (m, N_u) displacements.
The encoder maps forces to reduced, scaled coordinates (``pod``: a centred POD); the decoder maps
reduced displacements to the field (``linear``: a centred POD; ``quadratic``: with a quadratic manifold);
the regressor maps the one to the other (``rbf``: a thin-plate spline; ``poly``: a sparse or ridge
polynomial). ``rom_component.parts`` describes how a configuration names them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted, validate_data

from rom_component.envelope import fit_envelope
from rom_component.parts import PARTS, Decoder, Encoder, Part, Regressor
from rom_component.reduction.decoders import PodDecoder
from rom_component.reduction.encoders import PodEncoder
from rom_component.static.online import OnlineRom
from rom_component.static.regression import PolynomialRegression, RbfRegression


class SolidRom(RegressorMixin, BaseEstimator):
    """Encoder - regressor - decoder reduced model of a solid.

    ``fit(X, y)``: X the force snapshots (m, N), y the displacements (m, N_u) or (m,). The parts are
    cloned at fit (``encoder_``, ``regressor_``, ``decoder_``); ``None`` is the part's default: a POD encoder
    of 3 modes, the thin-plate spline, a POD decoder of 9 modes. The numbers of modes are capped by what the
    data hold (``modes`` gives the ones used).
    """

    def __init__(self, encoder: Encoder | None = None, regressor: Regressor | None = None,
                 decoder: Decoder | None = None):
        self.encoder = encoder
        self.regressor = regressor
        self.decoder = decoder

    @classmethod
    def from_settings(cls, model: Mapping[str, Mapping[str, Any]]) -> SolidRom:
        """The ROM whose parts ``model`` names (tables with ``type``, as ``resolve_parts`` returns them)."""
        return cls(**{kind: PARTS[kind].create(model[kind]) for kind in PARTS})

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True     # displacement fields: many outputs per snapshot
        tags.target_tags.single_output = True
        tags.input_tags.sparse = False
        # the sparse polynomial is a least-squares fit through r_f <= n_features reduced forces, not an
        # interpolant: on check_estimator's 10-feature linear data projected to 3 modes it scores below 0.5
        tags.regressor_tags.poor_score = isinstance(self.regressor, PolynomialRegression)
        return tags

    def parts(self) -> dict[str, Part]:
        """The three parts, defaults for those not given (unfitted)."""
        defaults = {"encoder": PodEncoder(), "regressor": RbfRegression(), "decoder": PodDecoder()}
        return {kind: defaults[kind] if getattr(self, kind) is None else getattr(self, kind) for kind in PARTS}

    def check_params(self) -> None:
        """Raise ValueError naming the first part or setting out of its range (fit calls it)."""
        for kind, part in self.parts().items():
            if part.__class__ not in PARTS[kind].classes.values():
                raise ValueError(f"{kind} must be one of the registered {kind}s "
                                 f"({', '.join(PARTS[kind].names())}), got {part!r}")
            part.check_params(kind)

    def settings(self) -> dict[str, dict[str, Any]]:
        """The parts as a configuration names them (the model file's ``params``)."""
        return {kind: part.settings() for kind, part in self.parts().items()}

    def fit(self, X: np.ndarray, y: np.ndarray, windows: np.ndarray | None = None) -> SolidRom:
        """Fit on force rows ``X`` and displacement rows ``y``; ``windows``: the window of each row, which group
        the regressor's cross-validation if it has one (without them it cross-validates over snapshots)."""
        self.check_params()
        F, U = validate_data(self, X, y, multi_output=True, y_numeric=True, dtype=np.float64,
                             ensure_min_samples=2)
        self.single_output_ = U.ndim == 1
        U = U[:, None] if self.single_output_ else U
        parts = self.parts()
        self.encoder_: Encoder = clone(parts["encoder"])
        self.regressor_: Regressor = clone(parts["regressor"])
        self.decoder_: Decoder = clone(parts["decoder"])
        self.encoder_.fit(F)
        Zu = self.decoder_.fit_transform(U)
        X = self.encoder_.transform(F)
        groups = None if windows is None or not self.regressor_.windows_group_fit else np.asarray(windows)
        self.regressor_.fit(X, Zu, groups=groups)
        self.envelope_ = fit_envelope(X)   # where the ROM has seen data (its trust range)
        return self

    def reduced_predict(self, F: np.ndarray) -> np.ndarray:
        return self.regressor_.predict(self.encoder_.transform(F))

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Displacement rows for force rows ``X``."""
        check_is_fitted(self)
        F = validate_data(self, X, reset=False, dtype=np.float64)
        U = self.decoder_.inverse_transform(self.reduced_predict(F))
        return U[:, 0] if self.single_output_ else U

    def jacobian(self, f: np.ndarray) -> np.ndarray:
        """d predict / d f at one force vector ``f``, in closed form (decoder, regressor, encoder): (N_u, N_f)."""
        left, right = self.jacobian_factors(f)
        return left @ right

    def jacobian_factors(self, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The derivative at ``f`` as L (N_u, r_u) @ R (r_u, N_f): the decoder's, and the regressor's times the
        encoder's (its rank is at most r_u)."""
        check_is_fitted(self)
        x = self.encoder_.transform(np.asarray(f, dtype=np.float64)[None, :])[0]
        z = self.regressor_.predict(x[None, :])[0]
        return self.decoder_.jacobian(z), self.regressor_.jacobian(x) @ self.encoder_.jacobian()

    def online_arrays(self, interface_index: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Arrays of the online interface path; ``interface_index`` selects u_G = K u (default: all)."""
        K = slice(None) if interface_index is None else np.asarray(interface_index)
        return {**self.encoder_.online_arrays(), **self.decoder_.online_arrays(K), **self.regressor_.online_arrays(),
                **self.envelope_}

    def to_online(self, interface_index: np.ndarray | None = None) -> OnlineRom:
        return OnlineRom(self.online_arrays(interface_index),
                         {"regressor": self.regressor_.type_name, "params": self.settings()})

    @property
    def modes(self) -> tuple[int, int]:
        """(r_f, r_u) used by the fitted model."""
        check_is_fitted(self)
        return self.encoder_.modes_, self.decoder_.modes_


DEFAULT_PARTS = {"encoder": "pod", "regressor": "rbf", "decoder": "linear"}


def resolve_parts(model: Mapping[str, Any], source: str = "") -> dict[str, dict[str, Any]]:
    """The ``model`` table's parts (a name, or a table with ``type``; without it, the default part) checked
    against their classes' own settings, with defaults filled in."""
    resolved = {}
    for kind, registry in PARTS.items():
        table = model.get(kind, DEFAULT_PARTS[kind])
        if isinstance(table, Mapping) and "type" not in table:
            table = {"type": DEFAULT_PARTS[kind], **table}
        resolved[kind] = registry.settings(table, f"model.{kind}", source)
    return resolved
