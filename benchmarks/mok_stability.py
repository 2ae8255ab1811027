"""Mok's stability matrix for the docs: ``cosim stability scenes/mok.toml`` (its [stability] section: structure
density x time step x accelerations), then the matrix and the failure classes into docs/mok.md.

Usage: python -m benchmarks.mok_stability [--out DIR] [--docs]
(a rerun into the same DIR skips the runs already done, as every sweep does)
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

from benchmarks.common import ROOT, machine, rewrite_readme
from cosim.cli import main as cosim


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "runs" / "mok_stability"))
    parser.add_argument("--docs", action="store_true", help="rewrite the matrix in docs/mok.md")
    args = parser.parse_args(argv)
    out = Path(args.out)
    code = cosim(["stability", str(ROOT / "scenes" / "mok.toml"), "--out", str(out), "--quiet"])
    if code:
        return code
    with open(out / "sweep.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    failures: dict[str, int] = {}
    for row in rows:
        if row["failure"]:
            failures[row["failure"]] = failures.get(row["failure"], 0) + 1
    lines = [f"machine: {machine()}", f"{len(rows)} runs; failed: "
             + (", ".join(f"{n} {kind}" for kind, n in sorted(failures.items())) or "none"),
             "cells: mean coupling iterations per window, or the failure's class", "",
             *(out / "matrix.md").read_text().splitlines()]
    print("\n".join(lines))
    if args.docs:
        rewrite_readme("mok-stability", lines, "python -m benchmarks.mok_stability --docs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
