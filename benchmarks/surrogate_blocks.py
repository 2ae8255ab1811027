"""How well each block of the online surrogate predicts the secants of later windows, offline.

Reads a plain run whose two participants were both recorded (``--set components.<fluid>.record=true``), fits each
block on the windows before window n, and asks it for the sub-iteration secants of window n:
|J dIn - dOut| / |dOut|, median and 90th percentile over the test windows.

- static block (the participant the surrogate models with the ROM): the ROM's closed-form derivative, for each
  ROM configuration given, and a least-squares fit of its own secants of the last windows;
- dynamic block: a least-squares fit of its secants of the last ``memory`` windows (truncated at ``rcond``), as
  ``coupler.surrogate`` fits it;
- how much of the static participant's input and output secants the leading POD modes of the earlier calls hold.

Usage: python -m benchmarks.surrogate_blocks RUN_DIR --static solid --dynamic fluid [--first 31] [--every 3]
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

from cosim.results import RunResults
from rom_component.static.surrogate_model import DEFAULT_MODEL, RomResponse

MODELS: list[dict[str, Any]] = [DEFAULT_MODEL,
          {"encoder": {"type": "pod", "modes": 8}, "regressor": {"type": "poly", "method": "ridge"},
           "decoder": {"type": "linear", "modes": 8}}]


def calls(run: RunResults, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(input, output, window) of a recorded participant's calls, one flat row per call: the data it exchanges."""
    recorded = run.calls(name)
    exchanges = run.scene["exchange"]
    into = next(e["data"] for e in exchanges if e["to"] == name)
    out = next(e["data"] for e in exchanges if e["from"] == name)
    rows = len(recorded)
    return (recorded.inputs[into].reshape(rows, -1), recorded.outputs[out].reshape(rows, -1),
            np.asarray(recorded.window))


def secants(X: np.ndarray, Y: np.ndarray, window: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Differences between consecutive calls of the same window: (dX, dY, window)."""
    same = window[1:] == window[:-1]
    return np.diff(X, axis=0)[same], np.diff(Y, axis=0)[same], window[1:][same]


def summary(errors: list[float]) -> str:
    return f"{np.median(errors):.3f} ({np.quantile(errors, 0.9):.3f})"


def least_squares_errors(dX, dY, window, windows, memory: int, rcond: float) -> list[float]:
    """Secant errors of a least-squares Jacobian fitted on the last ``memory`` windows' secants."""
    errors: list[float] = []
    for n in windows:
        fit = (window < n) & (window >= n - memory)
        test = window == n
        if not fit.any() or not test.any():
            continue
        U, s, Vt = np.linalg.svd(dX[fit].T, full_matrices=False)
        keep = s > rcond * s[0]
        J = (dY[fit].T @ Vt[keep].T / s[keep]) @ U[:, keep].T
        errors += list(np.linalg.norm(dX[test] @ J.T - dY[test], axis=1) / np.linalg.norm(dY[test], axis=1))
    return errors


def rom_errors(X, Y, window, windows, model: dict[str, Any]) -> list[float]:
    """Secant errors of the ROM's derivative, the ROM fitted on the calls before each test window."""
    errors: list[float] = []
    for n in windows:
        fit = window < n
        rom = RomResponse(model).fit(X[fit], Y[fit], window[fit])
        calls_n = np.flatnonzero(window == n)
        for a, b in zip(calls_n[:-1], calls_n[1:]):
            change = Y[b] - Y[a]
            errors.append(float(np.linalg.norm(rom.jacobian(X[a]) @ (X[b] - X[a]) - change) / np.linalg.norm(change)))
    return errors


def main(argv: list[str] | None = None) -> dict[str, str]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run")
    parser.add_argument("--static", default="solid")
    parser.add_argument("--dynamic", default="fluid")
    parser.add_argument("--first", type=int, default=31, help="the first test window")
    parser.add_argument("--every", type=int, default=3, help="test every this many windows")
    parser.add_argument("--models", help="ROM configurations to try, as JSON (default: the surrogate's and 8 modes)")
    args = parser.parse_args(argv)
    run = RunResults(args.run)
    Xs, Ys, ws = calls(run, args.static)
    Xd, Yd, wd = calls(run, args.dynamic)
    windows = range(args.first, int(ws.max()) + 1, args.every)
    rows: dict[str, str] = {}
    dXd, dYd, pd = secants(Xd, Yd, wd)
    for memory in (5, 10, 50):
        for rcond in (1e-2, 1e-3):
            rows[f"dynamic, least squares, {memory} windows, rcond {rcond:g}"] = summary(
                least_squares_errors(dXd, dYd, pd, windows, memory, rcond))
    dXs, dYs, ps = secants(Xs, Ys, ws)
    rows["static, least squares on its own secants, 100 windows"] = summary(
        least_squares_errors(dXs, dYs, ps, windows, 100, 1e-2))
    for model in json.loads(args.models) if args.models else MODELS:
        rows[f"static, ROM {json.dumps(model)}"] = summary(rom_errors(Xs, Ys, ws, windows, model))
    early = ws < args.first
    later = ps >= args.first
    for name, snapshots, differences in (("output", Ys, dYs), ("input", Xs, dXs)):
        centred = snapshots[early] - snapshots[early].mean(axis=0)
        modes = np.linalg.svd(centred, full_matrices=False)[2]
        for r in (4, 8, 16, 32):
            held = np.linalg.norm(differences[later] @ modes[:r].T, axis=1) / np.linalg.norm(differences[later], axis=1)
            rows[f"static {name} secants held by {r} modes of the windows before {args.first}"] = \
                f"{np.median(held):.3f} (min {held.min():.3f})"
    print(f"secant errors |J dIn - dOut| / |dOut|, median (90th percentile), windows {args.first} on, every "
          f"{args.every}; run {args.run}")
    print("| block | secant error |")
    print("| --- | --- |")
    for key, value in rows.items():
        print(f"| {key} | {value} |")
    return rows


if __name__ == "__main__":
    main()
