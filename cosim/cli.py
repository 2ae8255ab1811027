"""The ``cosim`` command line: run, train, report, export-fmu, serve."""

from __future__ import annotations

import argparse
import sys

from cosim.errors import CosimError


def _run(args: argparse.Namespace) -> int:
    from coupler.run import run_scene  # the application layer; cosim itself does not depend on it
    from cosim.scene import load_scene

    scene = load_scene(args.scene, args.set or [])
    summary = run_scene(scene, args.out, progress=not args.quiet, overwrite=args.overwrite)
    unconverged = f" ({summary.unconverged} did not converge)" if summary.unconverged else ""
    print(f"{summary.windows} windows{unconverged}, {summary.iterations} coupling iterations "
          f"(mean {summary.mean_iterations:.3f} per window), wall {summary.wall_seconds:.2f} s; "
          f"results in {summary.out_dir / 'results.h5'}")
    return 0


def _train(args: argparse.Namespace) -> int:
    from rom_component.train import load_config, train
    train(args.results, args.out, load_config(args.config, args.set or []))
    return 0


def _report(args: argparse.Namespace) -> int:
    from pathlib import Path

    from rom_component.report import Run, write_report
    if not args.runs:
        raise SystemExit("cosim report: name at least one run directory")
    pairs = []
    for item in args.runs:
        run_dir, _, ref_dir = item.partition("=")
        ref_dir = ref_dir or args.reference
        if not ref_dir:
            from cosim.errors import SceneError
            raise SceneError(f"run '{run_dir}' has no reference: write RUN=REFERENCE or pass --reference")
        pairs.append((Run.read(run_dir), Run.read(ref_dir)))
    write_report(pairs, Path(args.out))
    print(f"report written to {args.out}")
    return 0


def _export_fmu(args: argparse.Namespace) -> int:
    from rom_component.fmu_export import export_fmu
    path = export_fmu(args.model, args.out, args.components_per_node)
    print(f"wrote {path}")
    return 0


def _serve(args: argparse.Namespace) -> int:
    from cosim.server import serve
    return serve(args.entry, args.bind, args.name, args.parent_pid)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="cosim", description="Partitioned co-simulation with black-box components.")
    sub = p.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene")
    run.add_argument("scene", help="scene file (TOML)")
    run.add_argument("--out", default="runs/latest", help="output directory (default: runs/latest)")
    run.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.add_argument("--overwrite", action="store_true",
                     help="replace a finished run in --out (never one in progress)")
    run.set_defaults(func=_run)
    train = sub.add_parser("train", help="train a solid ROM from the snapshots of a run")
    train.add_argument("results", help="results.h5 of a run that recorded the solid")
    train.add_argument("--out", required=True, help="model file to write (.npz)")
    train.add_argument("--config", help="ROM configuration (TOML), e.g. scenes/tube_rom.toml")
    train.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a configuration value")
    train.set_defaults(func=_train)
    report = sub.add_parser("report", help="compare ROM-FOM runs with FOM-FOM references")
    report.add_argument("runs", nargs="+", metavar="RUN[=REFERENCE]", help="run directory, optionally with its reference")
    report.add_argument("--reference", help="FOM-FOM run directory for runs given without one")
    report.add_argument("--out", default="runs/report", help="report directory (default: runs/report)")
    report.set_defaults(func=_report)
    export = sub.add_parser("export-fmu", help="export a trained ROM as an FMI 2.0 Co-Simulation FMU")
    export.add_argument("model", help="model file (.npz) written by cosim train")
    export.add_argument("--out", required=True, help="FMU to write")
    export.add_argument("--components-per-node", type=int, help="values per interface node (default: 1)")
    export.set_defaults(func=_export_fmu)
    serve = sub.add_parser("serve", help="serve one component over ZeroMQ")
    serve.add_argument("entry", help="package.module:Class")
    serve.add_argument("--bind", default="tcp://127.0.0.1:*", help="address to bind (default: loopback, any port)")
    serve.add_argument("--name", help="component name used in messages")
    serve.add_argument("--parent-pid", type=int, help="exit when this process is no longer the parent")
    serve.set_defaults(func=_serve)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        return args.func(args)
    except CosimError as exc:
        print(f"cosim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"cosim {args.command}: interrupted; components stopped", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
