"""Choice of the numbers of modes: hold-out cross-validation over a grid, or the energy criterion.

The error of one ROM on the held-out snapshots is the paper's
    eps = mean_i ||U_test,i - ROM(F_test,i)||_2
reported together with its relative form eps / mean_i ||U_test,i - u_mean||.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from sklearn.base import clone
from sklearn.model_selection import GroupShuffleSplit, train_test_split

from rom_component.reduction.pod import centred_pod, energy_rank


@dataclass
class SelectionTable:
    force_modes: list[int]
    disp_modes: list[int]
    errors: np.ndarray          # (len(disp_modes), len(force_modes)): mean L2 error on the hold-out set
    relative: np.ndarray        # the same over the mean norm of the centred hold-out fields
    best: tuple[int, int]       # (r_f, r_u) of the smallest error
    energy_choice: tuple[int, int]
    n_train: int
    n_test: int
    split: str = "snapshots"
    tolerance: float = 0.0      # chosen: the fewest modes whose error is within (1 + tolerance) of the best

    @property
    def chosen(self) -> tuple[int, int]:
        """(r_f, r_u) with the fewest force modes, then displacement modes, within the tolerance of the best."""
        limit = np.nanmin(self.errors) * (1.0 + self.tolerance)
        for j, r_f in sorted(enumerate(self.force_modes), key=lambda item: item[1]):
            for i, r_u in sorted(enumerate(self.disp_modes), key=lambda item: item[1]):
                if self.errors[i, j] <= limit:
                    return r_f, r_u
        return self.best

    def error_at(self, r_f: int, r_u: int) -> float:
        return float(self.errors[self.disp_modes.index(r_u), self.force_modes.index(r_f)])

    def format(self) -> str:
        head = "r_u \\ r_f" + "".join(f"{r:>10d}" for r in self.force_modes)
        lines = [f"hold-out error eps = mean ||U - ROM(F)||_2 over {self.n_test} test snapshots "
                 f"({self.n_train} for training), split by {self.split}", head]
        for i, r_u in enumerate(self.disp_modes):
            lines.append(f"{r_u:>9d}" + "".join(f"{e:>10.2e}" for e in self.errors[i]))
        r_f, r_u = self.best
        e_f, e_u = self.energy_choice
        lines.append(f"best: r_f = {r_f}, r_u = {r_u}, eps = {self.error_at(r_f, r_u):.3e} "
                     f"({self.relative[self.disp_modes.index(r_u), self.force_modes.index(r_f)]:.2%})")
        if self.tolerance > 0:
            c_f, c_u = self.chosen
            lines.append(f"chosen (fewest modes within {self.tolerance:.0%} of the best): r_f = {c_f}, r_u = {c_u}, "
                         f"eps = {self.error_at(c_f, c_u):.3e} "
                         f"({self.relative[self.disp_modes.index(c_u), self.force_modes.index(c_f)]:.2%})")
        if e_f in self.force_modes and e_u in self.disp_modes:
            lines.append(f"energy criterion: r_f = {e_f}, r_u = {e_u}, eps = {self.error_at(e_f, e_u):.3e} "
                         f"({self.error_at(e_f, e_u) / self.error_at(r_f, r_u):.1f} x the best)")
        else:
            lines.append(f"energy criterion: r_f = {e_f}, r_u = {e_u} (outside the grid)")
        return "\n".join(lines)


def energy_choice(F: np.ndarray, U: np.ndarray, energy: float = 0.9999) -> tuple[int, int]:
    """(r_f, r_u) holding ``energy`` of the snapshot energy."""
    return energy_rank(centred_pod(F)[2], energy), energy_rank(centred_pod(U)[2], energy)


def holdout_table(estimator, F: np.ndarray, U: np.ndarray, force_modes: Sequence[int],
                  disp_modes: Sequence[int], test_fraction: float = 0.2, seed: int = 0,
                  energy: float = 0.9999, groups: np.ndarray | None = None, tolerance: float = 0.0,
                  windows: np.ndarray | None = None) -> SelectionTable:
    """Hold-out error of ``estimator`` for every (r_f, r_u) of the grid.

    Without ``groups`` the test set is a random ``test_fraction`` of the snapshots; with them (the
    window of each snapshot) it is a random ``test_fraction`` of whole windows, so that no sub-iteration
    of a test window, nearly equal to its converged call, is in the training set. The table's ``chosen``
    pair has the fewest modes whose error is within ``tolerance`` (relative) of the best. ``windows`` (the
    window of each snapshot, for an estimator that fits sub-iteration steps) go to ``fit`` with the training
    snapshots, which then keep their order.
    """
    if groups is None:
        train, test = train_test_split(np.arange(len(F)), test_size=test_fraction, random_state=seed)
    else:
        train, test = next(GroupShuffleSplit(1, test_size=test_fraction, random_state=seed).split(F, U, groups))
    if windows is not None:
        train = np.sort(train)
    F_train, F_test, U_train, U_test = F[train], F[test], U[train], U[test]
    fit_params = {} if windows is None else {"windows": windows[train]}
    errors = np.full((len(disp_modes), len(force_modes)), np.nan)
    for j, r_f in enumerate(force_modes):
        for i, r_u in enumerate(disp_modes):
            model = clone(estimator).set_params(encoder__modes=r_f, decoder__modes=r_u).fit(F_train, U_train,
                                                                                          **fit_params)
            errors[i, j] = np.linalg.norm(U_test - model.predict(F_test), axis=1).mean()
    scale = np.linalg.norm(U_test - U_train.mean(axis=0), axis=1).mean()
    best_i, best_j = (int(k) for k in np.unravel_index(np.nanargmin(errors), errors.shape))
    return SelectionTable(list(force_modes), list(disp_modes), errors, errors / scale,
                          (force_modes[best_j], disp_modes[best_i]), energy_choice(F_train, U_train, energy),
                          len(F_train), len(F_test), "snapshots" if groups is None else "windows", tolerance)
