"""Where a ROM-FOM run's extra coupling iterations go, window by window, against its FOM-FOM reference.

Over the windows that end after ``--after`` (the ROM's served windows) and that both runs completed:
- the coupling residual ||H(x) - x|| at each iteration over the window's first, median per iteration;
- the accumulated iterations of both, over all those windows and over the "clean" ones (neither a
  fallback window, where the solid FOM took over from the ROM, nor the window after one), the
  histogram of the per-window difference, and at which iteration the fallback windows fell back;
- how far the solid's inputs lie beyond the ROM's training range at each iteration (its trust value
  ``rom_excess``, in range widths): as the ROM-FOM run recorded it, and for the FOM-FOM run's own calls
  put through the same ROM's encoder (the ROM model named in the ROM-FOM run's scene).

Usage: python -m cases.double_flap.iterations ROM_RUN FOM_RUN [--after 3.0] [--last WINDOW]
  ROM_RUN, FOM_RUN: run directories (or their results.h5); --last: only windows up to this one
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from cosim.results import RunResults
from rom_component.envelope import range_excess
from rom_component.static.load import load_rom

ROOT = Path(__file__).resolve().parent.parent


def window_residuals(run: RunResults) -> dict[int, np.ndarray]:
    """Coupling residual norms per window (windows numbered from 1)."""
    window, norm = run.residuals()
    order = np.argsort(window, kind="stable")
    window, norm = window[order], norm[order]
    starts = np.flatnonzero(np.r_[True, window[1:] != window[:-1]])
    return {int(w): part for w, part in zip(window[starts], np.split(norm, starts[1:]))}


def call_excess(run: RunResults, model: str | Path, component: str = "solid") -> tuple[np.ndarray, np.ndarray,
                                                                                      np.ndarray]:
    """(window, iteration, excess) of every recorded call of ``component``: how far its input lies beyond the
    training range of ``model`` (range widths, 0 inside), computed as the ROM's trust does."""
    rom = load_rom(model)
    calls = run.calls(component)
    inputs = calls.inputs[rom.metadata.get("input_variable", "pressure")].reshape(len(calls.window), -1)
    if rom.envelope is None:
        raise SystemExit(f"{model}: the model has no training envelope")
    return calls.window, calls.iteration, range_excess(inputs @ rom.E.T - rom.e, rom.envelope)


def _excess_by_iteration(window: np.ndarray, iteration: np.ndarray, excess: np.ndarray,
                         served: list[int]) -> dict[int, str]:
    keep = np.isin(window, served) & np.isfinite(excess)
    table = {}
    for k in np.unique(iteration[keep]):
        e = excess[keep & (iteration == k)]
        if len(e) >= 3:
            table[int(k)] = (f"{np.median(e):>6.2f} {np.percentile(e, 90):>5.2f} {e.max():>6.2f} "
                             f"{int((e > 1).sum()):>4d} ({len(e):>4d})")
    return table


def fallback_windows(run: RunResults) -> dict[int, int]:
    """Windows in which a call of the ROM was flagged out of range (the solid FOM took the rest), each with the
    iteration of its first flagged call."""
    if "solid" not in run.recorded():
        return {}
    calls = run.calls("solid")
    flag = calls.outputs.get("rom_out_of_range")
    if flag is None:
        return {}
    flagged = flag[:, 0] > 0
    return {int(w): int(calls.iteration[flagged & (calls.window == w)].min()) for w in np.unique(calls.window[flagged])}


def compare(rom_path: Path, fom_path: Path, after: float, last: int | None = None) -> list[str]:
    with RunResults(rom_path) as rom, RunResults(fom_path) as fom:
        ends = fom.windows.time                                   # end time of window k at index k - 1
        rom_res, fom_res = window_residuals(rom), window_residuals(fom)
        served = sorted(w for w in set(rom_res) & set(fom_res)
                        if ends[w - 1] > after + 1e-9 * max(1.0, after) and (last is None or w <= last))
        if not served:
            raise SystemExit(f"no window of both runs ends after t = {after:g} s")
        fell_back = fallback_windows(rom)
        solid = rom.scene.get("components", {}).get("solid", {})
        falls_back = solid.get("backend") != "rom" or solid.get("rom", {}).get("on_out_of_range") == "fallback"
        rom_its = np.array([len(rom_res[w]) for w in served])
        fom_its = np.array([len(fom_res[w]) for w in served])
    clean = np.array([w not in fell_back and w - 1 not in fell_back for w in served])
    lines = [f"{len(served)} windows after t = {after:g} s (windows {served[0]}-{served[-1]}); "
             f"{sum(w in fell_back for w in served)} " + ("fell back" if falls_back else
                                                          "had a call out of range (served by the ROM all the same)")
             + f"; {int(clean.sum())} clean (neither such a window nor the one after)",
             "iteration   residual / first, median: ROM-FOM (windows)   FOM-FOM (windows)"]
    for k in range(int(max(rom_its.max(), fom_its.max()))):
        ratio = [np.median([res[w][k] / res[w][0] for w in served if len(res[w]) > k]) if
                 any(len(res[w]) > k for w in served) else np.nan for res in (rom_res, fom_res)]
        counts = [sum(len(res[w]) > k for w in served) for res in (rom_res, fom_res)]
        if min(counts) < 3:
            break
        lines.append(f"{k + 1:>9d}   {ratio[0]:>27.2e} ({counts[0]:>4d})   {ratio[1]:>10.2e} ({counts[1]:>4d})")
    for label, keep in (("all", np.ones_like(clean)), ("clean", clean)):
        a, b = int(rom_its[keep].sum()), int(fom_its[keep].sum())
        if b:
            lines.append(f"iterations over the {label} windows: ROM-FOM {a}, FOM-FOM {b} ({100 * (a / b - 1):+.2f} %)")
    first = [fell_back[w] for w in served if w in fell_back]
    if first:
        first_at, count = np.unique(first, return_counts=True)
        lines.append("windows with a call out of range, by the iteration of the first such call: "
                     + ", ".join(f"{v}: {c}" for v, c in zip(first_at.tolist(), count.tolist())))
    difference, count = np.unique(rom_its[clean] - fom_its[clean], return_counts=True)
    lines.append("per clean window, ROM-FOM minus FOM-FOM iterations: "
                 + ", ".join(f"{v:+d}: {c}" for v, c in zip(difference.tolist(), count.tolist())))
    model = solid.get("rom", {}).get("model")
    if model and Path(model).is_file():
        with RunResults(rom_path) as rom, RunResults(fom_path) as fom:
            recorded = rom.calls("solid")
            ours = _excess_by_iteration(recorded.window, recorded.iteration,
                                        recorded.outputs["rom_excess"][:, 0], served)
            theirs = _excess_by_iteration(*call_excess(fom, model), served)
        lines += ["inputs beyond the ROM's training range (range widths): median, 90th percentile, largest, "
                  "calls beyond 1 (calls)",
                  f"iteration   {'ROM-FOM (recorded)':<32}FOM-FOM (through the same ROM's encoder)"]
        for k in sorted(set(ours) | set(theirs)):
            lines.append(f"{k:>9d}   {ours.get(k, '-'):<32}{theirs.get(k, '-')}")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rom_run")
    parser.add_argument("fom_run")
    parser.add_argument("--after", type=float, default=3.0, help="windows ending after this time (s)")
    parser.add_argument("--last", type=int, help="windows up to this one only")
    args = parser.parse_args(argv)
    print("\n".join(compare(Path(args.rom_run), Path(args.fom_run), args.after, args.last)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
