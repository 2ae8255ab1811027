"""What bounds the coupling iterations per window: an oracle start and a repeated iterate.

Two measurements on any serial-implicit scene, each against the plain run in the same invocation:

- ``oracle``: every window starts from the plain run's converged value of the accelerated data,
  displaced by ``eps`` times that window's change (x0 = x*_n+1 - eps (x*_n+1 - x*_n)); with
  ``--both`` the first participant's data start from its converged value too, so that the first
  iteration's convergence check sees full-order values of the converged state. The iterations per
  window against eps show how exact a predictor must be before the criterion lets a window end sooner.
- ``predictability``: how well the plain run's converged accelerated data follow from earlier windows by
  polynomial extrapolation (orders 0 to 4), as a fraction of the window's change (printed with ``oracle``).
- ``forced``: with ``--input CSV``, a signal known ahead of time (time, value: e.g. the tube's inlet table) joins the
  predictor: each window's change of the accelerated data is regressed, by least squares on the ``--history`` windows
  before it, on the last ``--lags`` changes (in the POD basis of the recent changes, ``--modes``) and the signal's last
  two changes. It is printed as a fraction of the window's change, and a run that starts every window from its own
  last converged value plus that prediction gives the iterations per window of a predictor that good.
- ``plain``: the plain run's data sizes, their change per window and the residual's median per iteration (also
  printed with ``oracle``).
- ``repeat``: in every window the second iteration repeats the first's iterate (x1 = x0): the
  change between the two full-order answers to the same input is the solvers' own noise (a solver
  that restarts its step from its last iterate, not from the window's start, answers an input with
  what its nonlinear solver left last time). It is given against the first residual and the
  criterion's limit; the rest of the window is the plain acceleration's.

Usage: python -m benchmarks.coupling_floor SCENE [--out DIR] [--set KEY=VALUE ...] [--eps 0 1e-3 ...]
       [--both] [--repeat] [--plain] [--input CSV [--history N] [--modes N] [--lags N]]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from benchmarks.common import fresh_directory, machine
from cosim.results import RunResults
from cosim.scene import load_scene
from coupler.accelerations import ACCELERATIONS
from coupler.accelerations.quasi_newton import IQNILS
from coupler.run import run_scene
from coupler.schemes import CouplingScheme


def run(scene_path: str, out: Path, overrides: list[str]) -> RunResults:
    run_scene(load_scene(scene_path, overrides), out, progress=False)
    return RunResults(out / "results.h5")


def per_window(results: RunResults, skip: int) -> float:
    return float(results.windows.iterations[skip:].mean())


def predictability(results: RunResults, names: list[str], skip: int) -> list[tuple[int, float, float]]:
    """How well each window's converged accelerated data follow from the earlier windows' by polynomial
    extrapolation: (order, median, 90th percentile) of |prediction - x*_n| / |x*_n - x*_(n-1)|."""
    from math import comb
    X = stacked(results, names)[1:]
    change = np.linalg.norm(np.diff(X, axis=0), axis=1)
    rows = []
    for order in range(5):
        coefficients = [(-1) ** j * comb(order + 1, j + 1) for j in range(order + 1)]
        n = np.arange(max(skip, order + 1), len(X))
        prediction = sum(c * X[n - 1 - j] for j, c in enumerate(coefficients))
        error = np.linalg.norm(prediction - X[n], axis=1) / np.maximum(change[n - 1], np.finfo(float).tiny)
        rows.append((order, float(np.median(error)), float(np.quantile(error, 0.9))))
    return rows


def stacked(results: RunResults, names: list[str]) -> np.ndarray:
    """The converged values of ``names`` per window, the initial ones first: row k is after window k."""
    fields, initial = results.fields(), results.initial()
    return np.vstack([np.concatenate([initial[name].ravel() for name in names])] +
                     [np.hstack([fields[name].reshape(len(fields[name]), -1) for name in names])])


def signal_at_windows(path: str, results: RunResults) -> np.ndarray:
    """A (time, value) table's value at the start and the end of every window (the inlet table's reader)."""
    from fluid_component.inlet import TableInlet
    time = results.windows.time
    start = time[0] - (time[1] - time[0])
    table = TableInlet(path, start, time[-1])
    return np.interp(np.r_[start, time], table.time, table.velocity)


class ForcedPredictor:
    """Each window's change of the accelerated data from the last changes and a known input's changes."""

    def __init__(self, X: np.ndarray, u: np.ndarray, history: int, modes: int, lags: int) -> None:
        self.D, self.du = np.diff(X, axis=0), np.diff(u)   # D[k - 1] = X[k] - X[k - 1]: window k's change
        self.history, self.modes, self.lags = history, modes, lags

    def first_window(self) -> int:
        return self.history + self.lags + 2

    def change(self, n: int) -> np.ndarray:
        """The predicted change of window n (1-based), fitted on the windows before it."""
        D, du, lags = self.D, self.du, self.lags
        U, sigma = np.linalg.svd(D[n - 1 - self.history - lags:n - 1].T, full_matrices=False)[:2]
        basis = U[:, :min(self.modes, int((sigma > 1e-9 * sigma[0]).sum()))]   # modes above round-off

        def features(m: int) -> np.ndarray:
            return np.concatenate([basis.T @ D[m - 1 - k] for k in range(1, lags + 1)] + [du[m - 1:m - 3:-1]])
        fitted = np.arange(n - self.history, n)
        X = np.array([features(int(m)) for m in fitted])
        Y = D[fitted - 1] @ basis
        coefficients = np.linalg.lstsq(X, Y, rcond=1e-12)[0]
        return basis @ (features(n) @ coefficients)

    def errors(self, skip: int) -> np.ndarray:
        """|predicted - actual change| / |actual change| of every window after ``skip``."""
        windows = range(max(skip + 1, self.first_window()), len(self.D) + 1)
        return np.array([np.linalg.norm(self.change(n) - self.D[n - 1]) / np.linalg.norm(self.D[n - 1])
                         for n in windows])


def forced(scene_path: str, out: Path, overrides: list[str], signal: str, skip: int, history: int, modes: int,
           lags: int) -> list[tuple[str, float]]:
    """The plain run, the forced predictor's error, and a run whose windows start from it."""
    plain = run(scene_path, out / "plain", overrides)
    names = plain.scene["coupling"]["acceleration"]["data"] or sorted(plain.fields())
    predictor = ForcedPredictor(stacked(plain, names), signal_at_windows(signal, plain), history, modes, lags)
    skip = max(skip, predictor.first_window())
    error = predictor.errors(skip)
    print(f"forced predictor (history {history}, at most {modes} modes, {lags} lags): error / the window's change, "
          f"median {np.median(error):.2e}, 75th percentile {np.quantile(error, 0.75):.2e}, "
          f"90th {np.quantile(error, 0.9):.2e}")
    original = CouplingScheme._predicted

    def predicted(self: CouplingScheme) -> dict[str, np.ndarray]:
        values = original(self)
        if self.window > skip:      # a change over twice the last window's is the regression's failure: not taken
            last, change = self._stack(self.values, names), predictor.change(self.window)
            if np.linalg.norm(change) <= 2 * np.linalg.norm(predictor.D[self.window - 2]):
                values.update(self._split(last + change, names))
        return values
    CouplingScheme._predicted = predicted      # type: ignore[method-assign]
    try:
        result = run(scene_path, out / "forced", overrides)
    finally:
        CouplingScheme._predicted = original    # type: ignore[method-assign]
    return [("plain", per_window(plain, skip)), ("forced predictor", per_window(result, skip))]


def scales(results: RunResults, skip: int) -> list[str]:
    """Each field's size and change per window, and the coupling residual's median over the iterations of a window."""
    lines = ["| data | norm: mean | change per window: mean |", "| --- | --- | --- |"]
    for name, values in results.fields().items():
        flat = values[skip:].reshape(len(values[skip:]), -1)
        lines.append(f"| {name} | {np.linalg.norm(flat, axis=1).mean():.4g} | "
                     f"{np.linalg.norm(np.diff(flat, axis=0), axis=1).mean():.4g} |")
    window, norm = results.residuals()
    norm = norm[window > skip]
    window = window[window > skip]
    starts = np.r_[0, np.flatnonzero(np.diff(window)) + 1]
    iteration = np.arange(len(window)) - np.repeat(starts, np.diff(np.r_[starts, len(window)]))
    medians = [f"{np.median(norm[iteration == k]):.3g}" for k in range(4) if (iteration == k).any()]
    lines += ["", f"coupling residual, median over the windows, iterations 1 to {len(medians)}: {', '.join(medians)}"]
    return lines


def oracle(scene_path: str, out: Path, overrides: list[str], eps_values: list[float], both: bool,
           skip: int) -> list[tuple[str, float]]:
    """Iterations per window with an oracle start at each eps (and the plain run's)."""
    plain = run(scene_path, out / "plain", overrides)
    converged = plain.fields()
    rows = [("plain", per_window(plain, skip))]
    print("\n".join(scales(plain, skip)))
    accelerated = plain.scene["coupling"]["acceleration"]["data"] or sorted(converged)
    print("| extrapolation order | error / the window's change: median | 90th percentile |")
    print("| --- | --- | --- |")
    for order, median, high in predictability(plain, accelerated, skip):
        print(f"| {order} | {median:.3f} | {high:.3f} |")
    original = CouplingScheme._predicted
    for eps in eps_values:
        def predicted(self, eps=eps):
            values = original(self)
            n = self.window       # this window's number (1-based): its converged values are row n - 1
            if n <= skip:
                return values
            for name in converged:
                if name in self.accelerated or both:
                    target, before = converged[name][n - 1], converged[name][n - 2] if n >= 2 else converged[name][0]
                    values[name] = target - eps * (target - before)
            return values
        CouplingScheme._predicted = predicted      # type: ignore[method-assign]
        try:
            rows.append((f"oracle eps={eps:g}" + (" (both)" if both else ""),
                         per_window(run(scene_path, out / f"oracle_{eps:g}", overrides), skip)))
        finally:
            CouplingScheme._predicted = original    # type: ignore[method-assign]
    return rows


class RepeatProbe(IQNILS):
    """IQN-ILS whose second iterate repeats the first: the change of the answers is the solvers' noise."""

    noise: list[tuple[float, float]] = []    # (||H(x0) again - H(x0)||, ||H(x0) - x0||) per window

    def start_window(self) -> None:
        super().start_window()
        self._first: tuple[np.ndarray, np.ndarray] | None = None

    def observe(self, x: np.ndarray, x_tilde: np.ndarray) -> None:
        if self.iteration == 1 and self._first is not None and np.array_equal(x, self._first[0]):
            RepeatProbe.noise.append((float(np.linalg.norm(x_tilde - self._first[1])),
                                      float(np.linalg.norm(self._first[1] - self._first[0]))))
            self._r_previous = None         # the repeat's difference (noise alone) is no secant column
        super().observe(x, x_tilde)

    def next_iterate(self) -> np.ndarray:
        if self.iteration == 1:
            self._first = (self.x.copy(), self.x_tilde.copy())
            return self.x.copy()
        return super().next_iterate()


def repeat(scene_path: str, out: Path, overrides: list[str]) -> np.ndarray:
    """(noise, first residual) per window of a run whose second iterate repeats the first."""
    if "probe-repeat" not in ACCELERATIONS.classes:
        ACCELERATIONS.register("probe-repeat")(RepeatProbe)
    RepeatProbe.noise = []
    run(scene_path, out / "repeat", [*overrides, "coupling.acceleration.type=probe-repeat"])
    return np.array(RepeatProbe.noise)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--out", help="a new directory for the runs (default: a fresh one under runs/bench/)")
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    parser.add_argument("--eps", type=float, nargs="*", default=[0.0, 1e-4, 1e-3, 1e-2, 1e-1])
    parser.add_argument("--both", action="store_true", help="the first participant's data start converged too")
    parser.add_argument("--repeat", action="store_true", help="measure the solvers' noise instead")
    parser.add_argument("--plain", action="store_true", help="the plain run's scales and residuals only")
    parser.add_argument("--skip", type=int, default=10, help="windows left out of the means (the start-up)")
    parser.add_argument("--input", help="a (time, value) CSV known ahead of time: the forced predictor")
    parser.add_argument("--history", type=int, default=40, help="forced predictor: windows fitted")
    parser.add_argument("--modes", type=int, default=10, help="forced predictor: POD modes of the changes")
    parser.add_argument("--lags", type=int, default=2, help="forced predictor: earlier changes as features")
    args = parser.parse_args(argv)
    out = Path(args.out) if args.out else fresh_directory("coupling_floor")
    print(f"machine: {machine()}")
    if args.plain:
        plain = run(args.scene, out / "plain", args.overrides)
        print("\n".join(scales(plain, args.skip)))
        return
    if args.repeat:
        noise = repeat(args.scene, out, args.overrides)
        noise = noise[args.skip:]
        ratio = noise[:, 0] / noise[:, 1]
        print("| windows | noise ||H(x0) again - H(x0)||: median (min, max) | first residual: median | ratio: median (max) |")
        print("| --- | --- | --- | --- |")
        print(f"| {len(noise)} | {np.median(noise[:, 0]):.3e} ({noise[:, 0].min():.2e}, {noise[:, 0].max():.2e}) | "
              f"{np.median(noise[:, 1]):.3e} | {np.median(ratio):.2e} ({ratio.max():.2e}) |")
        return
    if args.input:
        rows = forced(args.scene, out, args.overrides, args.input, args.skip, args.history, args.modes, args.lags)
    else:
        rows = oracle(args.scene, out, args.overrides, args.eps, args.both, args.skip)
    print("| start | iterations per window |")
    print("| --- | --- |")
    for name, value in rows:
        print(f"| {name} | {value:.3f} |")


if __name__ == "__main__":
    main()
