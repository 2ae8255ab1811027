"""Summarise a finished ``cosim campaign`` (its report, models and FOM runs) as a text table, optionally into
the README block ``<!-- MARKER:begin ... -->`` ... ``<!-- MARKER:end -->``.

With ``--calls`` (the ``calls.json`` that ``benchmarks/flap_rom_call.py`` writes), the table adds the solid
speed-up against the authors' linear solver (sparse_qr) and the total speed-up bound it would give:
the reference's solid calls priced at the benchmark's sparse_qr median per call, the fluid as measured.

Usage: python -m scripts.campaign_readme runs/campaign [--calls runs/bench/flap_rom_call-.../calls.json]
       [--readme MARKER]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
from pathlib import Path

from benchmarks.common import rewrite_readme

ROOT = Path(__file__).resolve().parent.parent

PAPER = {"e_time": "< 4 %", "e_re300": "< 10 %", "iterations": "+7 %", "speedup": 1.81, "sigma": 260,
         "fit_s": 53, "cv_s": 1349}


def _pct(value: float, digits: int = 2) -> str:
    return f"{100 * value:.{digits}f} %"


def _until_failure(campaign: Path, row: dict[str, str], fom: list[dict[str, str]]) -> str:
    """A failed ROM-FOM run over the windows it served before failing: interface displacement error and
    coupling iterations against the FOM-FOM run of the same Reynolds number."""
    import numpy as np

    from cosim.results import RunResults
    path = campaign / "rom" / "runs" / row["name"] / "results.h5"
    if not path.is_file():
        return "  (no results recorded)"
    with RunResults(path) as run:
        reynolds = float(run.scene["flow"]["reynolds"])
        reference = next((f for f in fom if f.get("flow.reynolds") and float(f["flow.reynolds"]) == reynolds), None)
        if reference is None:
            return "  (no FOM-FOM run at its Reynolds number)"
        with RunResults(campaign / "fom" / "runs" / reference["name"] / "results.h5") as ref:
            n = len(run.windows.time)
            served = run.windows.time[:n] > float(row["switch_time"]) + 1e-9
            u, u_ref = run.fields()["displacement"], ref.fields()["displacement"]
            u, u_ref_all = u.reshape(len(u), -1), u_ref.reshape(len(u_ref), -1)
            e = np.linalg.norm(u - u_ref_all[:n], axis=1)[served] / np.linalg.norm(u_ref_all, axis=1).mean()
            iterations = run.windows.iterations[served].sum() / ref.windows.iterations[:n][served].sum() - 1
            fallback = int(run.attributes.get("rom_fallback_windows", 0))
    return (f"  before failing it served {int(served.sum())} windows: interface displacement error {_pct(e.mean())} "
            f"on average ({_pct(e.max())} at most) of the FOM-FOM mean norm, iterations {100 * iterations:+.1f} %, "
            f"{fallback} windows fell back")


def _first_words(message: str, limit: int = 200) -> str:
    """A failure message cut to its first ``limit`` characters (Kratos appends its whole C++ call stack)."""
    return message if len(message) <= limit else message[:limit].rstrip() + " ..."


def summary(campaign: Path, calls: Path | None) -> list[str]:
    report_file = campaign / "report" / "report.json"
    report = json.loads(report_file.read_text())["runs"] if report_file.is_file() else []
    lines = []
    with open(campaign / "fom" / "sweep.csv", newline="") as stream:
        fom = list(csv.DictReader(stream))
    lines.append("FOM-FOM runs: " + "; ".join(
        f"Re {float(r['flow.reynolds']):.1f}: {int(r['windows_converged'])} windows, "
        f"{float(r['mean_iterations']):.3f} iterations/window, {float(r['wall_seconds']) / 60:.0f} min"
        for r in fom if r.get("flow.reynolds")))
    for log in sorted((campaign / "models").glob("*.log")):
        text = log.read_text()
        snapshots = re.search(r"^(\d+) snapshots", text, re.M)
        fitted = re.search(r"fitted r_f = (\d+), r_u = (\d+), (\w+) regression, (\w+) decoder in ([\d.]+) s", text)
        terms = re.search(r"sparse polynomial: (\d+) of (\d+) terms kept \((\d+)-(\d+) of (\d+)", text)
        ridge = re.search(r"polynomial of (\d+) terms per reduced displacement, ridge penalty ([\d.e+-]+)", text)
        cv = re.findall(r"cross-validation time \(split by (\w+)\): ([\d.]+) s", text)
        total = re.search(r"training with cross-validation: ([\d.]+) s", text)
        holdout = re.findall(r"best: r_f = (\d+), r_u = (\d+), eps = ([\d.e+-]+) \(([\d.]+%)\)", text)
        if not fitted:
            continue
        parts = [f"model {log.stem}: {snapshots.group(1) if snapshots else '?'} snapshots, r_f = {fitted.group(1)} "
                 f", r_u = {fitted.group(2)}, {fitted.group(3)}, {fitted.group(4)} decoder"]
        if terms:
            parts.append(f"terms kept per output {terms.group(3)}-{terms.group(4)} of {terms.group(5)}")
        if ridge:
            parts.append(f"all {ridge.group(1)} terms per output, ridge penalty {ridge.group(2)}")
        parts.append(f"fit {float(fitted.group(5)):.1f} s" + "".join(
            f", hold-out by {split} {float(s):.0f} s (best r_f {best[0]}, error {best[3]})"
            for (split, s), best in zip(cv, holdout)))
        if total:
            parts.append(f"total {float(total.group(1)):.0f} s (paper: fit {PAPER['fit_s']} s, with "
                         f"cross-validation {PAPER['cv_s']} s, 8-core laptop)")
        lines.append("; ".join(parts))
    rom_table = campaign / "rom" / "sweep.csv"
    names_file = campaign / "rom" / "predictions.json"
    names = json.loads(names_file.read_text()) if names_file.is_file() else {}
    if rom_table.is_file():
        with open(rom_table, newline="") as stream:
            for r in csv.DictReader(stream):
                state = f"failed ({r['failure']}): {r['failure_message'][:110]}" if r["failure"] else "finished"
                name = names.get(r["name"], r["model"])
                lines.append(f"ROM-FOM {name} against {r['reference']} from {float(r['switch_time']):g} s: "
                             f"{r['windows_converged']} windows converged, {float(r['mean_iterations']):.3f} "
                             f"iterations/window, {float(r['wall_seconds']) / 60:.0f} min; {state}")
                if r["failure"]:
                    lines.append(_until_failure(campaign, r, fom))
    qr = lu = None
    if calls:
        medians = json.loads(calls.read_text())["median_seconds"]
        qr = medians["solid FOM, Kratos, sparse_qr (the authors)"]
        lu = medians["solid FOM, Kratos, sparse_lu"]
        lines.append(f"solid FOM per call (benchmark, median): sparse_qr {qr * 1e3:.0f} ms, sparse_lu {lu * 1e3:.1f} ms")
    if not report:
        return lines + ["(no ROM-FOM run has finished: no report yet)"]
    head = (f"{'prediction':<16}{'T_i s':>6}{'e(t) mean':>10}{'e(t) max':>10}{'tip L':>8}{'tip R':>8}"
            f"{'iter +%':>9}{'iter all':>9}{'ROM us':>8}{'sigma':>8}{'sigma rt':>9}{'speed-up':>9}{'bound':>7}"
            f"{'ratio':>7}")
    if qr:
        head += f"{'sigma qr':>9}{'bound qr':>9}"
    lines += ["", head]
    for r in report:
        solid = r.get("solid", {})
        tips = r.get("tips", {})
        row = (f"{r['label']:<16}{r['switch_time']:>6.1f}{_pct(r['displacement_error']['mean']):>10}"
               f"{_pct(r['displacement_error']['max']):>10}"
               f"{_pct(tips.get('left', {}).get('max_over_amplitude', float('nan')), 1):>8}"
               f"{_pct(tips.get('right', {}).get('max_over_amplitude', float('nan')), 1):>8}"
               f"{100 * (r['predicted_iterations_ratio'] - 1):>+8.2f}%{100 * (r['iterations_ratio'] - 1):>+8.2f}%"
               f"{solid['rom_compute_median_s'] * 1e6:>8.0f}"
               f"{solid['speedup_compute']:>8.0f}{solid['speedup_roundtrip']:>9.1f}{r['total_speedup']:>9.3f}"
               f"{r['total_speedup_bound']:>7.3f}{r['total_speedup'] / r['total_speedup_bound']:>7.3f}")
        if qr:
            sigma_qr = qr / solid["rom_compute_median_s"]
            t_f = r["reference_fluid_compute_s"]
            t_s = r["reference_solid_calls"] * qr
            t_sp = t_s * r["predicted_range"]["solid_compute_s"] / r["reference_solid_compute_s"]
            bound = (t_f + t_s) / (t_f + t_s - t_sp + t_sp / sigma_qr)
            row += f"{sigma_qr:>9.0f}{bound:>9.3f}"
        lines.append(row)
    lines += ["", "e(t) = ||U - U_rom|| / mean_t ||U|| on the full displacement field (3610 values), mean over the whole "
                  "run, over the windows the ROM served; tip L/R: largest |ROM-FOM - FOM-FOM| tip x-displacement over "
                  "the FOM-FOM amplitude there; iter +%: accumulated coupling iterations over the served windows "
                  "against FOM-FOM (iter all: whole run); ROM us: the ROM's compute per call in the run, median; sigma: "
                  "solid FOM over ROM compute per call (rt: round "
                  "trips; the FOM with sparse_lu); speed-up: FOM-FOM wall over ROM-FOM wall; bound: "
                  "(T_f + T_s) / (T_f + T_s,FOM part + T_s,ROM part / sigma) for this run's schedule; ratio: "
                  "speed-up / bound" + ("; qr: with the authors' sparse_qr priced in" if qr else ""),
              f"paper: e(t) {PAPER['e_time']} (ROM 1-3), {PAPER['e_re300']} (Re 300), iterations "
              f"{PAPER['iterations']}, sigma about {PAPER['sigma']}, total speed-up {PAPER['speedup']}"]
    for row in report:
        if "predicted_range" in row:
            p = row["predicted_range"]
            lines.append(f"  {row['label']}: over the served windows alone, speed-up {p['speedup']:.3f} "
                         f"against the bound {p['bound']:.3f} ({p['speedup'] / p['bound']:.1%})")
        low, high = row.get("predicted_iterations_interval", [float("nan")] * 2)
        if math.isfinite(low):
            lines.append(f"  {row['label']}: iterations over the served windows {row['predicted_iterations_ratio'] - 1:+.2%}, "
                         f"90 % interval {low - 1:+.2%} .. {high - 1:+.2%} (moving-block bootstrap of the "
                         f"per-window difference, blocks of 10 windows)")
        if row.get("rom_fallback_windows"):
            lines.append(f"  {row['label']}: {row['rom_fallback_windows']} windows fell back to the solid FOM "
                         f"(a call beyond one range width of the training data)")
    check = campaign / "report" / "fmu_check.txt"
    if check.is_file() and check.read_text().strip():
        lines += ["FMU in the solid's place:"] + ["  " + line for line in check.read_text().splitlines()]
    failed = (campaign / "report" / "failed.txt")
    if failed.is_file() and failed.read_text().strip():
        lines += ["failed:"] + ["  " + _first_words(line) for line in failed.read_text().splitlines()]
    pngs = sorted(p.name for p in (campaign / "report").glob("*.png"))
    where = campaign.absolute()      # as given (a link under runs/ stays the link), relative to the checkout if inside
    lines.append(f"PNGs in {where.relative_to(ROOT) if where.is_relative_to(ROOT) else where}/report: "
                 + ", ".join(pngs))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path)
    parser.add_argument("--calls", type=Path, help="calls.json of benchmarks/flap_rom_call.py")
    parser.add_argument("--readme", metavar="MARKER", help="rewrite this README block")
    args = parser.parse_args()
    lines = summary(args.campaign, args.calls)
    print("\n".join(lines))
    if args.readme:
        command = f"python -m scripts.campaign_readme {args.campaign}" + (" --calls ..." if args.calls else "")
        rewrite_readme(args.readme, lines, command + f" --readme {args.readme}")


if __name__ == "__main__":
    main()
