"""The coupler's subcommands ``cosim run``, ``cosim check`` and ``cosim sweep``
(registered in pyproject.toml under ``cosim.commands``)."""

from __future__ import annotations

import argparse
import sys

from cosim.command import Command


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--out", default="runs/latest", help="output directory (default: runs/latest)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace a finished run in --out (never one in progress)")


def _scheduler_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="an existing Dask scheduler instead of a local cluster: tls://HOST:PORT (Dask's TLS "
                             "settings), or tcp:// on loopback")
    parser.add_argument("--insecure-scheduler", action="store_true",
                        help="accept a tcp:// scheduler off this host (unencrypted, unauthenticated, pickles)")


def _scheduler(args: argparse.Namespace) -> str | None:
    from coupler.sweep import check_scheduler
    check_scheduler(args.scheduler, args.insecure_scheduler)
    return args.scheduler


def _run(args: argparse.Namespace) -> int:
    from cosim.scene import load_scene
    from coupler.run import run_scene

    scene = load_scene(args.scene, args.set or [])
    summary = run_scene(scene, args.out, progress=not args.quiet, overwrite=args.overwrite,
                        resume=getattr(args, "resume", False))
    unconverged = f" ({summary.unconverged} did not converge)" if summary.unconverged else ""
    print(f"{summary.windows} windows{unconverged}, {summary.iterations} coupling iterations "
          f"(mean {summary.mean_iterations:.3f} per window), wall {summary.wall_seconds:.2f} s; "
          f"results in {summary.out_dir / 'results.h5'}")
    return 0


def _sweep_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                        help="values of one key; the sweep runs the Cartesian product of all --grid options")
    parser.add_argument("--runs", metavar="FILE", help="one run per line: KEY=VALUE items separated by spaces")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value in every run")
    parser.add_argument("--out", required=True, help="sweep directory: sweep.csv and runs/<name>/")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    _scheduler_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _sweep(args: argparse.Namespace) -> int:
    from collections import Counter

    from cosim.errors import SceneError
    from coupler.sweep import file_runs, grid_runs, read_rows, run_sweep

    if bool(args.grid) == bool(args.runs):
        raise SceneError("give --grid options or a --runs file (one of them)")
    if args.workers < 1:
        raise SceneError(f"--workers is {args.workers}; allowed: an integer >= 1")
    common = args.set or []
    runs = grid_runs(args.grid, common) if args.grid else file_runs(args.runs, common)
    table = run_sweep(args.scene, runs, args.out, args.workers, _scheduler(args), progress=not args.quiet)
    failures = Counter(row["failure"] for row in read_rows(table, runs) if row["failure"])
    failed = f"{sum(failures.values())} failed ({', '.join(f'{k} {n}' for k, n in failures.items())})" \
        if failures else "none failed"
    print(f"{len(runs)} runs, {failed}; table in {table}")
    return 1 if failures else 0


def _numbers(text: str, option: str) -> list[float]:
    from cosim.errors import SceneError
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise SceneError(f"{option} '{text}' is not a comma-separated list of numbers") from None
    if not values or any(not v > 0 for v in values):
        raise SceneError(f"{option} '{text}': every value must be a number > 0")
    return values


def _check_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value (repeatable)")
    parser.add_argument("--static", action="store_true",
                        help="check the scene without starting its components (their variables are not checked)")


def _check(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from cosim.scene import load_scene
    from coupler.probe import probe
    from coupler.run import prepare

    scene = load_scene(args.scene, args.set or [])
    windows = prepare(scene)
    described = [] if args.static else probe(scene, windows)
    print(json.dumps(scene.data, indent=2))
    for note in filter(None, scene.notes.splitlines()):
        print(f"  note: {note}", file=sys.stderr)
    for key in sorted(scene.translated):
        print(f"  note: '{key}' comes from --set, which wins over what {Path(scene.source).name} gave", file=sys.stderr)
    for line in described:
        print(f"  {line}", file=sys.stderr)
    how = "without starting components" if args.static else "every component started and instantiated"
    print(f"{scene.source}: valid ({how}); {windows} windows, components {', '.join(scene['components'])}",
          file=sys.stderr)
    return 0


def _run_arguments(parser: argparse.ArgumentParser) -> None:
    _arguments(parser)
    parser.add_argument("--resume", action="store_true",
                        help="go on with the run in --out from its last checkpoint (output.checkpoint_every), with the "
                             "same scene and --set overrides; results.h5 keeps the windows before it")


run = Command(
    "run a scene", _run_arguments, _run,
    "Couple the scene's components over its time windows and write DIR/results.h5 (every window, every "
    "coupling iteration's residual, the recorded calls), DIR/status.json and DIR/run.png. A directory that "
    "holds another run is refused unless --overwrite (never one in progress). With output.checkpoint_every set, "
    "the run writes DIR/checkpoint.npz as it goes, and --resume goes on from it.",
    "cosim run scenes/tube_fom.toml --out runs/fom_mu1 --set inlet.f=0.9 --set inlet.h=4")
check = Command(
    "validate a scene without running it", _check_arguments, _check,
    "Check the scene as a run would before it starts a process (schema and ranges, every plug-in's settings, "
    "every component's parameters, input files, run plots, the time grid); then start every component as a run "
    "would, reach those served by hand within 5 s, instantiate each and check the exchanged variables against "
    "what they declare (--static: not this part). Print the resolved scene, every default filled in, as JSON. "
    "Exit code 0 if valid, 2 with a one-line error otherwise.",
    "cosim check scenes/double_flap.toml --set flow.reynolds=300")
sweep = Command(
    "run many variants of a scene on Dask (a local cluster or a scheduler)", _sweep_arguments, _sweep,
    "Run every variant (the Cartesian product of the --grid options, or one line of a --runs file each) as an "
    "ordinary run in DIR/runs/<name>/, and add a row per run to DIR/sweep.csv as it finishes. A rerun skips "
    "the runs already done. Exit code 1 if any run failed.",
    "cosim sweep scenes/tube_fom.toml --grid inlet.h=4,6,8 --set time.end=10 --out runs/sweep")


def _stability_arguments(parser: argparse.ArgumentParser) -> None:
    from coupler.stability_matrix import METHODS
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--out", required=True, help="directory: sweep.csv, matrix.md, stability.png, runs/ (and the "
                                                     "case's theory files)")
    parser.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                        help="a swept parameter (one or two; default: the scene's stability.grid)")
    parser.add_argument("--methods", help=f"accelerations, comma-separated (default: the scene's stability.methods, "
                                          f"else all: {','.join(METHODS)})")
    parser.add_argument("--windows", type=int, help="windows per run (default: the scene's stability.windows)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE",
                        help="override a scene value in every run (after the scene's stability.settings)")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    _scheduler_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _stability(args: argparse.Namespace) -> int:
    import csv
    from pathlib import Path

    from cosim.errors import SceneError
    from cosim.scene import load_scene
    from coupler.stability_matrix import (
        ACCELERATION,
        METHODS,
        accelerated_data,
        load_theory,
        matrix_markdown,
        matrix_runs,
        parse_axes,
        plot_matrix,
    )
    from coupler.sweep import run_sweep

    scene = load_scene(args.scene, args.set or [])
    section = scene["stability"]
    axes = parse_axes(args.grid or section["grid"])
    methods = [m.strip() for m in (args.methods.split(",") if args.methods else section["methods"] or METHODS)
               if m.strip()]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise SceneError(f"--methods names {', '.join(unknown)}; known: {', '.join(METHODS)}")
    windows = args.windows if args.windows is not None else section["windows"]
    if windows < 1:
        raise SceneError(f"--windows is {windows}; allowed: an integer >= 1")
    common = [*section["settings"], *(args.set or [])]
    data = accelerated_data(scene)
    dt = scene["time"]["dt"]

    def dt_of(point: dict[str, str]) -> float:
        return float(point["time.dt"]) if "time.dt" in point else dt

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    theory = load_theory(scene["case"], args.scene, axes, common)
    written = theory.prepare(out) if theory is not None else []
    runs = matrix_runs(axes, methods, data, windows, dt_of, scene["time"]["start"], common)
    table = run_sweep(args.scene, runs, out, args.workers, _scheduler(args), progress=not args.quiet,
                      keys=[ACCELERATION, *(k for k, _ in axes)])
    with open(table, newline="") as stream:
        names = {run.name for run in runs}
        rows = [row for row in csv.DictReader(stream) if row["name"] in names]
    (out / "matrix.md").write_text(matrix_markdown(rows, axes, methods, data))
    title = f"{scene['name'] or Path(args.scene).stem}: stability matrix, {windows} windows per run"
    written += [out / "matrix.md", plot_matrix(rows, axes, methods, data, out / "stability.png", title, theory)]
    if theory is not None:
        written += theory.finish(rows, out)
    failed = sum(1 for row in rows if row["failure"])
    print(f"{len(rows)} runs ({failed} failed, classed in the table); {table}, "
          + ", ".join(str(p) for p in written))
    return 0


stability = Command(
    "a scene's stability matrix: swept parameters x accelerations, with failure classes",
    _stability_arguments, _stability,
    "Run the scene for every value of one or two parameters (stability.grid or --grid) with each acceleration "
    "method on the data the scene accelerates, as a sweep on Dask, and write the sweep's table (each failed run "
    "classed: diverged, stalled, max-iterations, non-finite, component-error), matrix.md and stability.png (mean "
    "iterations per window per method). The scene's stability.settings apply to every run. A case that registers "
    "a theory (the tube) adds its files and lines.",
    "cosim stability scenes/mok.toml --out runs/mok_stability --grid "
    "components.structure.parameters.density=478,1500,9560 --methods none,aitken,iqn-ils")


def _status_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", help="a run's directory (--out of cosim run)")


def _status(args: argparse.Namespace) -> int:
    from coupler.monitor import status_lines
    print("\n".join(status_lines(args.dir)))
    return 0


def _plot_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", help="a run's directory (--out of cosim run)")
    parser.add_argument("--convergence", action="store_true", help="the convergence history (the default)")
    parser.add_argument("--out", help="the PNG to write (default: DIR/convergence.png)")


def _plot(args: argparse.Namespace) -> int:
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
    "plot a run's convergence history", _plot_arguments, _plot,
    "Draw every convergence measure and the residual norm at every coupling iteration, and the iterations of "
    "each window, from DIR/logs/convergence.log and DIR/logs/iterations.log (written as the run goes, so a "
    "running run can be plotted too).",
    "cosim plot runs/fom_mu1 --convergence")
