"""The table of the ROM with memory of Mok's wall, from a report of ``make demo-mok-rom``.

Usage: python -m scripts.mok_rom_table runs/mok_rom_demo/report/report.json [--docs]
(--docs: rewrite the block in docs/mok.md)
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from benchmarks.common import rewrite_readme

ROWS = (
    ("point A, max |ROM-FOM - FOM-FOM| over served windows / deflection", lambda r: _pct(r["point_a"]["max_over_deflection"])),
    ("point A, RMS difference over served windows / deflection", lambda r: _pct(r["point_a"]["l2_over_deflection"])),
    ("point A max, cm (ROM-FOM / FOM-FOM)",
     lambda r: f"{r['point_a']['rom_fom']['max_cm']:.3f} / {r['point_a']['fom_fom']['max_cm']:.3f}"),
    ("point A at 25 s, cm (ROM-FOM / FOM-FOM)",
     lambda r: f"{r['point_a']['rom_fom']['final_cm']:.3f} / {r['point_a']['fom_fom']['final_cm']:.3f}"),
    ("e(t) on the wall's field, mean / max", lambda r: f"{_pct(r['displacement_error']['mean'])} / "
                                                      f"{_pct(r['displacement_error']['max'])}"),
    ("coupling iterations over served windows, vs FOM-FOM", lambda r: f"{r['predicted_iterations_ratio'] - 1:+.2%}"),
    ("  90 % interval", lambda r: "[{:+.1%}, {:+.1%}]".format(*(v - 1 for v in r["predicted_iterations_interval"]))),
    ("solid sigma (FOM / ROM compute per call)", lambda r: f"{r['solid']['speedup_compute']:.0f}"),
    ("total speed-up, measured / its bound", lambda r: f"{r['total_speedup']:.2f} / {r['total_speedup_bound']:.2f}"),
)


def _pct(value: float) -> str:
    return f"{100 * value:.2f} %"


def table(report: dict[str, Any]) -> list[str]:
    runs = report["runs"]
    width = max(len(name) for name, _ in ROWS) + 2
    lines = [" " * width + "".join(f"{run['label']:>16}" for run in runs),
             " " * width + "".join(f"{'from ' + format(run['switch_time'], 'g') + ' s':>16}" for run in runs)]
    for name, cell in ROWS:
        values = []
        for run in runs:
            try:
                values.append(cell(run))
            except (KeyError, TypeError):
                values.append("-")
        lines.append(f"{name:<{width}}" + "".join(f"{value:>16}" for value in values))
    return lines


def main(argv: list[str] | None = None) -> list[str]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("report", help="report.json of make demo-mok-rom")
    parser.add_argument("--docs", action="store_true", help="rewrite the block in docs/mok.md")
    args = parser.parse_args(argv)
    lines = table(json.loads(Path(args.report).read_text()))
    print("\n".join(lines))
    if args.docs:
        rewrite_readme("mok-rom", lines, "python -m scripts.mok_rom_table REPORT --docs, after make demo-mok-rom")
    return lines


if __name__ == "__main__":
    main()
