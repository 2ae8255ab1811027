"""Regenerate the pictures of docs/getting-started.md from the run it walks through.

Runs ``cosim run scenes/tube_fom.toml --out DIR --set time.end=10`` (DIR: a new temporary folder unless --out),
then writes into docs/img/: ``getting-started-run.png`` (the run's own run.png), ``getting-started-convergence.png``
(``cosim plot DIR --convergence``) and ``getting-started-vtk.png`` (``scripts/render_xdmf.py`` on the run's
run.xdmf: the inlet pressure along the tube at t = 4). Usage: python -m scripts.getting_started_figures [--out DIR]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
IMAGES = ROOT / "docs" / "img"


def main(argv: list[str] | None = None) -> int:
    from cosim.cli import main as cosim
    from scripts.render_xdmf import render

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="the run's folder (default: a new temporary one)")
    parser.add_argument("--images", type=Path, default=IMAGES, help="where the pictures go (default: docs/img)")
    args = parser.parse_args(argv)
    scratch = None if args.out else Path(tempfile.mkdtemp(prefix="cosim-getting-started-"))
    run = args.out or scratch / "getting-started"        # type: ignore[operator]
    try:
        if cosim(["run", str(ROOT / "scenes" / "tube_fom.toml"), "--out", str(run), "--set", "time.end=10",
                  "--quiet"]) != 0:
            return 2
        args.images.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(run / "run.png", args.images / "getting-started-run.png")
        if cosim(["plot", str(run), "--convergence", "--out", str(args.images / "getting-started-convergence.png")]):
            return 2
        render(run, args.images / "getting-started-vtk.png", "pressure", time=4.0)
        print(f"wrote {args.images}/getting-started-{{run,convergence,vtk}}.png")
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
