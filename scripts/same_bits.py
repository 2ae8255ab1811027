"""Whether two checkouts give the same bits: the tube runs a change must not move, run with each checkout's code,
every dataset of their results files compared but the timings.

The runs: the tube's FOM-FOM, the paper's mu1 inlet table, ROM-FOM and FMU-FOM from the start (a ROM trained once,
on a FOM run to 18 s, with the first checkout), and 30 s each of IQN-IMVJ, Aitken, Jacobi with IQN-ILS on both
fields, linear extrapolation, and 20 s with the online surrogate (its predictor and its IQN). With ``--all``: a second of Mok's wall, five windows of the double flap, the tube
as a preCICE case, and a Kratos CoSimulation case (``cases.kratos_wall.write``, written once by the first checkout).

Usage: python -m scripts.same_bits TREE_A TREE_B --out DIR   (e.g. a worktree of the commit before a change, and .; a
rerun into DIR goes on with the runs it lacks). Each tree runs with its own ``.venv`` where it has one (a layout
change moves entry points, which only the tree's own installation names).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import h5py

SCENE = "scenes/tube_fom.toml"
RUNS = {
    "fom": [],
    "table": ["inlet.table=scenes/inlet/tube-inlet-mu1.csv"],
    "rom": ["components.solid.backend=rom", "components.solid.rom.model={model}", "components.solid.rom.switch_time=0"],
    "fmu": ["components.solid.backend=fmu", "components.solid.fmu.path={fmu}", "components.solid.fmu.switch_time=0"],
    "imvj": ["time.end=30", 'coupling.acceleration={type="iqn-imvj", data=["section"]}'],
    "aitken": ["time.end=30", 'coupling.acceleration={type="aitken", data=["section"], initial_relaxation=0.01}'],
    "jacobi": ["time.end=30", "coupling.scheme=parallel-implicit",
               'coupling.acceleration={type="iqn-ils", data=["pressure","section"], initial_relaxation=0.1}'],
    "extrapolation": ["time.end=30", "coupling.extrapolation_order=1"],
    "surrogate": ["time.end=20", "coupling.surrogate.start_window=10", "coupling.surrogate.retrain_every=10"],
}
OTHER_SCENES = {      # the other cases, short: Mok's wall (its structure with inertia) and the double flap (Kratos)
    "mok": ("scenes/mok.toml", ["time.end=1.0", "mesh.wall_cells=[2,40]"]),
    "double_flap": ("scenes/double_flap.toml", ["time.end=0.04"]),
    "precice_tube": ("examples/precice_tube/case.toml", []),         # two preCICE participants
    "kratos_case": ("{kratos}/case.toml", []),     # a Kratos CoSimulation case (Mok's wall, written once)
}


def python_of(tree: Path) -> str:
    """The checkout's own environment (``TREE/.venv``, so that each runs its own entry points), else this one."""
    own = tree / ".venv" / "bin" / "python"
    return str(own) if own.is_file() else sys.executable


def cosim(tree: Path, *args: str) -> None:
    subprocess.run([python_of(tree), "-m", "cosim", *args], cwd=tree, check=True, capture_output=True)


def datasets(path: Path) -> dict[str, bytes]:
    found: dict[str, bytes] = {}
    with h5py.File(path, "r") as results:
        results.visititems(lambda name, item: found.__setitem__(name, item[()].tobytes())
                           if isinstance(item, h5py.Dataset) and "seconds" not in name else None)
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trees", nargs=2, type=Path, help="the two checkouts")
    parser.add_argument("--out", type=Path, required=True, help="a new directory for the runs")
    parser.add_argument("--all", action="store_true", help="Mok's wall and the double flap too (short runs)")
    args = parser.parse_args(argv)
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    trees = [tree.resolve() for tree in args.trees]
    model, fmu = out / "model.npz", out / "rom.fmu"
    if not fmu.exists():          # a rerun into the same directory goes on with the runs not done
        cosim(trees[0], "run", SCENE, "--out", str(out / "train"), "--quiet", "--set", "time.end=18", "--overwrite")
        cosim(trees[0], "train", str(out / "train" / "results.h5"), "--config", "rom_configs/tube_rom.toml",
              "--set", "snapshots.t_max=18", "--out", str(model))
        cosim(trees[0], "export-fmu", str(model), "--out", str(fmu))
    different = 0
    runs = {name: (SCENE, overrides) for name, overrides in RUNS.items()}
    if args.all:
        runs.update(OTHER_SCENES)
        if not (out / "kratos" / "case.toml").is_file():
            subprocess.run([python_of(trees[0]), "-m", "cases.kratos_wall.write", str(out / "kratos"), "--kind",
                            "dynamic"], cwd=trees[0], check=True, capture_output=True)
    for name, (scene, overrides) in runs.items():
        sets = [f"--set={item.replace('{model}', str(model)).replace('{fmu}', str(fmu))}" for item in overrides]
        for i, tree in enumerate(trees):
            if not (out / f"{name}-{i}" / "status.json").is_file():
                cosim(tree, "run", scene.replace("{kratos}", str(out / "kratos")), "--out", str(out / f"{name}-{i}"),
                      "--quiet", *sets)
        a, b = (datasets(out / f"{name}-{i}" / "results.h5") for i in (0, 1))
        moved = sorted(key for key in set(a) | set(b) if a.get(key) != b.get(key))
        different += bool(moved)
        print(f"{name:14s} {len(a)} datasets: " + ("the same bits" if not moved else f"DIFFERENT: {', '.join(moved[:6])}"))
    return 1 if different else 0


if __name__ == "__main__":
    sys.exit(main())
