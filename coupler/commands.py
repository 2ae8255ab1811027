"""The coupler's subcommands on one run, ``cosim run``, ``cosim check``, ``cosim status`` and ``cosim plot``
(registered in pyproject.toml under ``cosim.commands``)."""

from __future__ import annotations

import argparse
import sys

from cosim.command import Command

INPUT_KINDS = ("what to couple: a scene (TOML, as in scenes/), a case file (case.toml) of a preCICE or Kratos case, "
               "a preCICE precice-config.xml, or a Kratos ProjectParametersCoSim.json")


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help=INPUT_KINDS)
    parser.add_argument("--out", default="runs/latest", help="output directory (default: runs/latest)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace a finished run in --out (never one in progress)")


# the coupler's own linear algebra (its accelerations, its mappings) is small: one BLAS thread, unless the
# environment says otherwise, so that no idle BLAS thread spins on the cores its components compute on (each
# component's thread count is its own, components.NAME.threads)
COUPLER_THREADS = {name: "1" for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}


def _run(args: argparse.Namespace) -> int:
    import os
    for name, value in COUPLER_THREADS.items():       # before NumPy loads its BLAS
        os.environ.setdefault(name, value)
    from cosim.scene import load_scene
    from coupler.run import run_scene

    scene = load_scene(args.scene, args.set or [])
    summary = run_scene(scene, args.out, progress=not args.quiet, overwrite=args.overwrite,
                        resume=getattr(args, "resume", False))
    unconverged = f" ({summary.unconverged} did not converge)" if summary.unconverged else ""
    print(f"{summary.windows} windows{unconverged}, {summary.iterations} coupling iterations "
          f"(mean {summary.mean_iterations:.3f} per window); coupling {summary.coupling_seconds:.2f} s "
          f"({summary.windows_per_second:.3g} windows/s), elapsed {summary.wall_seconds:.2f} s; "
          f"results in {summary.out_dir / 'results.h5'}")
    return 0


def _check_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help=INPUT_KINDS)
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    parser.add_argument("--static", action="store_true",
                        help="check the scene without starting its components (their variables are not checked)")
    parser.add_argument("--print", action="store_true",
                        help="print the resolved scene (every default filled in) as JSON on stdout, after the verdict")


def _check(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from cosim.scene import load_scene
    from coupler.probe import probe
    from coupler.run import prepare

    scene = load_scene(args.scene, args.set or [])
    windows = prepare(scene)
    described = [] if args.static else probe(scene, windows)
    how = "without starting components" if args.static else "every component started and instantiated"
    print(f"{scene.source}: valid ({how}); {windows} windows, components {', '.join(scene['components'])}",
          file=sys.stderr)
    for note in filter(None, scene.notes.splitlines()):
        print(f"  note: {note}", file=sys.stderr)
    for key in sorted(scene.translated):
        print(f"  note: '{key}' comes from --set, which wins over what {Path(scene.source).name} gave", file=sys.stderr)
    for line in described:
        print(f"  {line}", file=sys.stderr)
    if args.print:
        print(json.dumps(scene.data, indent=2))
    return 0


def _run_arguments(parser: argparse.ArgumentParser) -> None:
    _arguments(parser)
    parser.add_argument("--resume", action="store_true",
                        help="go on with the run in --out from its last checkpoint (output.checkpoint_every), with the "
                             "same scene and --set overrides; results.h5 keeps the windows before it")


run = Command(
    "run a scene, or a preCICE or Kratos case", _run_arguments, _run,
    "Couple the scene's components over its time windows and write DIR/results.h5 (every window, every "
    "coupling iteration's residual, the recorded calls), DIR/run.xdmf (the run in ParaView), DIR/status.json and "
    "DIR/run.png. A directory that "
    "holds another run is refused unless --overwrite (never one in progress). With output.checkpoint_every set, "
    "the run writes DIR/checkpoint.npz as it goes, and --resume goes on from it.",
    "cosim run scenes/tube_fom.toml --out runs/fom_mu1 --set inlet.f=0.9 --set inlet.h=4")
check = Command(
    "validate a scene without running it", _check_arguments, _check,
    "Check the scene as a run would before it starts a process (schema and ranges, every plug-in's settings, "
    "every component's parameters, input files, run plots, the time grid); then start every component as a run "
    "would, reach those served by hand within 5 s, instantiate each and check the exchanged variables against "
    "what they declare (--static: not this part). The verdict comes first, then the notes and each component's "
    "variables; --print adds the resolved scene, every default filled in, as JSON on stdout. "
    "Exit code 0 if valid, 2 with a one-line error otherwise.",
    "cosim check scenes/double_flap.toml --set flow.reynolds=300")
def _status_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", help="a run's directory (--out of cosim run)")


def _status(args: argparse.Namespace) -> int:
    from coupler.monitor import status_lines
    print("\n".join(status_lines(args.dir)))
    return 0


def _plot_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", help="a run's directory (--out of cosim run)")
    kind = parser.add_mutually_exclusive_group()
    kind.add_argument("--convergence", action="store_true", help="the convergence history (the default)")
    kind.add_argument("--run", action="store_true", help="run.png of a run that has ended: the plotted field over "
                                                         "time and the iterations of each window, from results.h5")
    parser.add_argument("--out", help="the PNG to write (default: DIR/convergence.png, with --run DIR/run.png)")


def _plot(args: argparse.Namespace) -> int:
    if args.run:
        from cosim.plots import plot_finished_run
        print(f"wrote {plot_finished_run(args.dir, args.out)}")
        return 0
    from coupler.monitor import plot_convergence
    print(f"wrote {plot_convergence(args.dir, args.out)}")
    return 0


status = Command(
    "where a run stands, while it runs or after", _status_arguments, _status,
    "Read DIR/status.json, which the run rewrites as it goes, and print its state, the windows done, the time, "
    "the rate and the time left, the coupling iterations and the last window's convergence measures (a run whose "
    "process is gone while its status says running reads as died).",
    "cosim status runs/fom_mu1")
plot = Command(
    "plot a run's convergence history, or its run.png", _plot_arguments, _plot,
    "Draw every convergence measure and the residual norm at every coupling iteration, and the iterations of "
    "each window, from DIR/logs/convergence.log and DIR/logs/iterations.log (written as the run goes, so a "
    "running run can be plotted too). With --run, draw run.png from DIR/results.h5 once the run has ended "
    "(a preCICE case draws none itself: output.run_plot).",
    "cosim plot runs/fom_mu1 --convergence")
