"""The ROM's subcommands: ``cosim train``, ``cosim report``, ``cosim export-fmu``
(registered in pyproject.toml under ``cosim.commands``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from cosim.command import Command
from cosim.errors import SceneError


def _train_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("results", nargs="+", help="results.h5 of one or more runs that recorded the solid")
    parser.add_argument("--out", required=True, help="model file to write (.npz)")
    parser.add_argument("--config", help="ROM configuration (TOML), e.g. rom_configs/tube_rom.toml")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a configuration value")


def _train(args: argparse.Namespace) -> int:
    from rom_component.static.train import load_config, train
    config = load_config(args.config, args.set or [])
    if config["dynamics"]["memory"]:
        from rom_component.dynamic.train import train_step_map
        if len(args.results) != 1:
            raise SceneError("dynamics.memory: a step-map ROM trains on one run's recorded calls")
        train_step_map(args.results[0], args.out, config)
    else:
        train(args.results, args.out, config)
    return 0


def _report_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("runs", nargs="+", metavar="RUN[=REFERENCE]", help="run directory, optionally with its reference")
    parser.add_argument("--reference", help="FOM-FOM run directory for runs given without one")
    parser.add_argument("--out", default="runs/report", help="report directory (default: runs/report)")
    parser.add_argument("--label", action="append", metavar="DIR=NAME",
                        help="name a run or reference directory in the tables and PNGs (default: its own name)")


def _report(args: argparse.Namespace) -> int:
    from rom_component.report.compare import Run, write_report
    labels = {}
    for item in args.label or []:
        directory, sep, name = item.rpartition("=")
        if not sep or not directory or not name:
            raise SceneError(f"--label '{item}' is not of the form DIR=NAME")
        labels[Path(directory).resolve()] = name
    pairs = []
    for item in args.runs:
        run_dir, _, ref_dir = item.partition("=")
        ref_dir = ref_dir or args.reference
        if not ref_dir:
            raise SceneError(f"run '{run_dir}' has no reference: write RUN=REFERENCE or pass --reference")
        pair = (Run.read(run_dir), Run.read(ref_dir))
        for run, directory in zip(pair, (run_dir, ref_dir)):
            run.label = labels.get(Path(directory).resolve(), run.label)
        pairs.append(pair)
    write_report(pairs, Path(args.out))
    print(f"report written to {args.out}")
    return 0


def _export_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", help="model file (.npz) written by cosim train")
    parser.add_argument("--out", required=True, help="FMU to write")
    parser.add_argument("--components-per-node", type=int, help="values per interface node (default: 1)")
    parser.add_argument("--fmi", type=int, choices=(2, 3), default=2,
                        help="FMI version: 2 (scalar variables) or 3 (array variables); default 2")


def _export_fmu(args: argparse.Namespace) -> int:
    from rom_component.fmu.export import export_fmu
    print(f"wrote {export_fmu(args.model, args.out, args.components_per_node, args.fmi)}")
    return 0


train = Command(
    "train a solid ROM from the snapshots of a run", _train_arguments, _train,
    "Fit the solid ROM (POD of forces, POD or quadratic manifold of displacements, RBF or sparse polynomial "
    "regression) on the calls a run recorded, print the hold-out table over the mode numbers, and save the "
    "model (.npz, no pickle) with its training plots beside it.",
    "cosim train runs/fom_mu1/results.h5 --config rom_configs/tube_rom.toml --set snapshots.t_max=18 --out runs/model.npz")
report = Command(
    "compare ROM-FOM runs with FOM-FOM references", _report_arguments, _report,
    "Compare each ROM-FOM run with its FOM-FOM reference (same scene): errors of the monitored value and of the "
    "displacement e(t), coupling iterations with their 90 % interval, solid cost and speed-up against its "
    "bound; writes report.json, report.txt and the PNGs.",
    "cosim report runs/rom_mu1=runs/fom_mu1 --out runs/report")
export_fmu = Command(
    "export a trained ROM as an FMI 2.0 or 3.0 Co-Simulation FMU", _export_arguments, _export_fmu,
    "Compile the ROM's C code with the model's arrays into an FMI 2.0 (default) or FMI 3.0 (--fmi 3, array "
    "variables) Co-Simulation FMU (no Python inside); the FMU backend then serves the solid bit for bit as the ROM "
    "backend's reproducible arithmetic.",
    "cosim export-fmu runs/model.npz --out runs/solid_rom.fmu [--fmi 3]")
