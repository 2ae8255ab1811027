"""The two-mass oscillator's convergence in time under waveform iteration: the tables of docs/time.md.

The example ``examples/oscillator`` (as two preCICE participants, ``case.toml``, and as two cosim components,
``scene.toml``; 4 substeps per window each) is run for every integrator
(Newmark's average acceleration, classical Runge-Kutta), waveform degree 0 to 3, with and without substeps, over
windows of 0.04, 0.02, 0.01 and 0.005 s to t = 1 s. The error is the largest distance of either mass from the
analytic solution at the window ends; the order is the least-squares slope of log(error) against log(window).
Newmark's energy is the coupled system's (both masses, three springs): its largest relative change over the run.

Each run's result is kept in ``--out``/results.json as it comes, and a rerun skips what is there.

    python -m scripts.oscillator_order [--out runs/oscillator_order] [--small] [--via participants|components] [--docs]

``--docs`` writes the tables into docs/time.md, between its markers.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
from pathlib import Path

import numpy as np

from benchmarks.common import machine

ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = "<!-- oscillator:begin (scripts/oscillator_order.py writes this part) -->", "<!-- oscillator:end -->"
EXAMPLE = ROOT / "examples" / "oscillator"
MASS, K_WALL, K_MIDDLE = 1.0, 4.0 * np.pi ** 2, 16.0 * np.pi ** 2
WINDOWS = (0.04, 0.02, 0.01, 0.005)
INTEGRATORS = {"newmark": ("Newmark (average acceleration)", 2), "rk4": ("classical Runge-Kutta", 4)}


def exact(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """u1, u2, v1, v2 from u1 = 1, u2 = 0 at rest: the modes at 2 pi (in phase) and 6 pi (against)."""
    slow, fast = 2 * np.pi, np.sqrt((K_WALL + 2 * K_MIDDLE) / MASS)
    u1 = 0.5 * np.cos(slow * t) + 0.5 * np.cos(fast * t)
    u2 = 0.5 * np.cos(slow * t) - 0.5 * np.cos(fast * t)
    v1 = -0.5 * slow * np.sin(slow * t) - 0.5 * fast * np.sin(fast * t)
    v2 = -0.5 * slow * np.sin(slow * t) + 0.5 * fast * np.sin(fast * t)
    return u1, u2, v1, v2


def energy(u1: np.ndarray, u2: np.ndarray, v1: np.ndarray, v2: np.ndarray) -> np.ndarray:
    return 0.5 * MASS * (v1 ** 2 + v2 ** 2) + 0.5 * K_WALL * (u1 ** 2 + u2 ** 2) + 0.5 * K_MIDDLE * (u1 - u2) ** 2


def case(folder: Path, integrator: str, degree: int, substeps: bool, window: float, via: str) -> Path:
    """The example's case (participants) or scene (components) with this integrator, degree, substeps and window,
    written into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("mass.py", "mass_component.py", "integrators.py"):
        shutil.copy(EXAMPLE / name, folder / name)
    if via == "components":
        text = (EXAMPLE / "scene.toml").read_text().replace('integrator = "rk4"', f'integrator = "{integrator}"')
        text = text.replace("waveform_degree = 3", f"waveform_degree = {degree}")
        text = text.replace("substeps = true", f"substeps = {str(substeps).lower()}")
        text = text.replace("dt = 0.01", f"dt = {window}")
        (folder / "scene.toml").write_text(text)
        return folder / "scene.toml"
    config = (EXAMPLE / "precice-config.xml").read_text()
    config = config.replace('waveform-degree="3"', f'waveform-degree="{degree}"')
    config = config.replace('substeps="true"', f'substeps="{str(substeps).lower()}"')
    config = re.sub(r'<time-window-size value="[^"]+" />', f'<time-window-size value="{window}" />', config)
    (folder / "precice-config.xml").write_text(config)
    text = (EXAMPLE / "case.toml").read_text().replace("--integrator rk4", f"--integrator {integrator}")
    (folder / "case.toml").write_text(text)
    return folder / "case.toml"


def run_one(folder: Path, integrator: str, degree: int, substeps: bool, window: float, via: str) -> dict:
    from cosim.scene import load_scene
    from coupler.run import run_scene
    if folder.exists():
        shutil.rmtree(folder)        # an interrupted run of this point: its own folder, started again
    path = case(folder, integrator, degree, substeps, window, via)
    summary = run_scene(load_scene(path), folder / "out", progress=False)
    left, right = trajectories(folder, via)
    t = left[:, 0]
    u1, u2, v1, v2 = exact(t)
    error = float(max(np.abs(left[:, 1] - u1).max(), np.abs(right[:, 1] - u2).max()))
    e = energy(left[:, 1], right[:, 1], left[:, 2], right[:, 2])
    return {"via": via, "integrator": integrator, "degree": degree, "substeps": substeps, "window": window, "error": error,
            "energy_change": float(np.abs(e - e[0]).max() / e[0]), "final_energy_change": float((e[-1] - e[0]) / e[0]),
            "iterations": summary.iterations, "windows": summary.windows}


def trajectories(folder: Path, via: str) -> tuple[np.ndarray, np.ndarray]:
    """Each mass's (t, u, v) at the window ends: the participants' own files, or the components' recorded calls
    (the last step of each window's converged iteration)."""
    if via == "participants":
        return np.loadtxt(folder / "left.txt"), np.loadtxt(folder / "right.txt")
    from cosim.results import RunResults
    with RunResults(folder / "out") as results:
        t = np.concatenate([[0.0], results.windows.time])
        rows = []
        for side in ("Left", "Right"):
            calls = results.calls(f"Mass-{side}", converged_only=True)
            last = np.flatnonzero(np.diff(np.append(calls.window, -1)) != 0)      # each window's last step
            u = np.concatenate([[1.0 if side == "Left" else 0.0], calls.outputs[f"Displacement-{side}"][last, 0]])
            v = np.concatenate([[0.0], calls.outputs["velocity"][last, 0]])
            rows.append(np.stack([t, u, v], axis=1))
    return rows[0], rows[1]


def fitted_order(windows: list[float], errors: list[float]) -> float:
    return float(np.polyfit(np.log(windows), np.log(errors), 1)[0])


def markdown(results: list[dict], windows: tuple[float, ...], via: str) -> str:
    header = ("| integrator | degree | substeps | " + " | ".join(f"error, window {w:g}" for w in windows)
              + " | order | iterations per window | energy change (largest) |")
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for integrator in INTEGRATORS:
        for substeps in (True, False):
            for degree in range(4):
                rows = {r["window"]: r for r in results if (r["via"], r["integrator"], r["degree"], r["substeps"]) ==
                        (via, integrator, degree, substeps)}
                if not all(w in rows for w in windows):
                    continue
                errors = [rows[w]["error"] for w in windows]
                iterations = sum(rows[w]["iterations"] for w in windows) / sum(rows[w]["windows"] for w in windows)
                drift = max(rows[w]["energy_change"] for w in windows)
                lines.append(f"| {INTEGRATORS[integrator][0]} | {degree} | {'yes' if substeps else 'no'} | "
                             + " | ".join(f"{e:.2e}" for e in errors)
                             + f" | {fitted_order(list(windows), errors):.2f} | {iterations:.2f} | {drift:.1e} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/oscillator_order")
    parser.add_argument("--small", action="store_true", help="two windows, degrees 0 and 3 (tests)")
    parser.add_argument("--via", choices=("participants", "components", "both"), default="both")
    parser.add_argument("--docs", action="store_true", help="write the tables into docs/time.md")
    args = parser.parse_args(argv)
    ways = ("participants", "components") if args.via == "both" else (args.via,)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    store = out / "results.json"
    results: list[dict] = json.loads(store.read_text()) if store.exists() else []
    windows = (0.02, 0.01) if args.small else WINDOWS
    if args.small:      # degrees 0 and 3 with substeps, and RK4's degree 3 with the window's end alone
        points = [(v, i, d, s, w) for v in ways for i, d, s in [(i, d, True) for i in INTEGRATORS for d in (0, 3)]
                  + [("rk4", 3, False)] for w in windows]
    else:
        points = [(v, i, d, s, w) for v in ways for i in INTEGRATORS for s in (True, False) for d in range(4)
                  for w in windows]
    for point in points:
        if any((r["via"], r["integrator"], r["degree"], r["substeps"], r["window"]) == point for r in results):
            continue
        via, integrator, degree, substeps, window = point
        name = f"{via}-{integrator}-degree{degree}-{'substeps' if substeps else 'end'}-window{window:g}"
        results.append(run_one(out / name, integrator, degree, substeps, window, via))
        store.write_text(json.dumps(results, indent=1))
        print(f"{name}: error {results[-1]['error']:.3e}", file=sys.stderr)
    text = "\n\n".join(f"As two {'preCICE participants' if via == 'participants' else 'cosim components'} "
                       f"(`{'case.toml' if via == 'participants' else 'scene.toml'}`), machine: {machine()}:\n\n"
                       + markdown(results, windows, via) for via in ways)
    print(text)
    if args.docs:
        page = ROOT / "docs" / "time.md"
        before, rest = page.read_text().split(BEGIN, 1)
        page.write_text(before + BEGIN + "\n" + text + "\n" + END + rest.split(END, 1)[1])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
