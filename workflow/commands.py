"""The subcommands of studies over many runs, ``cosim sweep``, ``cosim stability`` and ``cosim campaign``
(registered in pyproject.toml under ``cosim.commands``), and their scheduler options."""

from __future__ import annotations

import argparse

from cosim.command import Command


def scheduler_arguments(parser: argparse.ArgumentParser) -> None:
    """``--scheduler`` and ``--insecure-scheduler``: where a study's runs go."""
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="an existing Dask scheduler instead of a local cluster: tls://HOST:PORT (Dask's TLS "
                             "settings), or tcp:// on loopback")
    parser.add_argument("--insecure-scheduler", action="store_true",
                        help="accept a tcp:// scheduler off this host (unencrypted, unauthenticated, pickles)")


def scheduler_address(args: argparse.Namespace) -> str | None:
    """The scheduler ``--scheduler`` names, checked (``--insecure-scheduler``), or None for a local cluster."""
    from workflow.sweep import check_scheduler
    check_scheduler(args.scheduler, args.insecure_scheduler)
    return args.scheduler


def _sweep_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                        help="values of one key; the sweep runs the Cartesian product of all --grid options")
    parser.add_argument("--runs", metavar="FILE", help="one run per line: KEY=VALUE items separated by spaces")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene value in every run")
    parser.add_argument("--out", required=True, help="sweep directory: sweep.csv and runs/<name>/")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    scheduler_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _sweep(args: argparse.Namespace) -> int:
    from collections import Counter

    from cosim.errors import SceneError
    from workflow.sweep import file_runs, grid_runs, read_rows, run_sweep

    if bool(args.grid) == bool(args.runs):
        raise SceneError("give --grid options or a --runs file (one of them)")
    if args.workers < 1:
        raise SceneError(f"--workers is {args.workers}; allowed: an integer >= 1")
    common = args.set or []
    runs = grid_runs(args.grid, common) if args.grid else file_runs(args.runs, common)
    table = run_sweep(args.scene, runs, args.out, args.workers, scheduler_address(args), progress=not args.quiet)
    failures = Counter(row["failure"] for row in read_rows(table, runs) if row["failure"])
    failed = f"{sum(failures.values())} failed ({', '.join(f'{k} {n}' for k, n in failures.items())})" \
        if failures else "none failed"
    print(f"{len(runs)} runs, {failed}; table in {table}")
    return 1 if failures else 0


sweep = Command(
    "run many variants of a scene on Dask (a local cluster or a scheduler)", _sweep_arguments, _sweep,
    "Run every variant (the Cartesian product of the --grid options, or one line of a --runs file each) as an "
    "ordinary run in DIR/runs/<name>/, and add a row per run to DIR/sweep.csv as it finishes. A rerun skips "
    "the runs already done. Exit code 1 if any run failed.",
    "cosim sweep scenes/tube_fom.toml --grid inlet.h=4,6,8 --set time.end=10 --out runs/sweep")


def _stability_arguments(parser: argparse.ArgumentParser) -> None:
    from workflow.stability_matrix import METHODS
    parser.add_argument("scene", help="scene file (TOML)")
    parser.add_argument("--out", required=True, help="directory: sweep.csv, matrix.md, stability.png, runs/ (and the "
                                                     "case's theory files)")
    parser.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                        help="a swept parameter (one or two; default: the scene's stability.grid)")
    parser.add_argument("--methods", help=f"accelerations, comma-separated: each the registered acceleration of its "
                                          f"name with the matrix's settings, iqn-ils-no-reuse being iqn-ils that reuses "
                                          f"no past window (default: the scene's stability.methods, else all: "
                                          f"{','.join(METHODS)})")
    parser.add_argument("--windows", type=int, help="windows per run (default: the scene's stability.windows)")
    parser.add_argument("--set", action="append", metavar="KEY=VALUE",
                        help="override a scene value in every run (after the scene's stability.settings)")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    scheduler_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _stability(args: argparse.Namespace) -> int:
    import csv
    from pathlib import Path

    from cosim.errors import SceneError
    from cosim.scene import load_scene
    from workflow.stability_matrix import (
        ACCELERATION,
        METHODS,
        accelerated_data,
        load_theory,
        matrix_markdown,
        matrix_runs,
        parse_axes,
        plot_matrix,
    )
    from workflow.sweep import run_sweep

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
    table = run_sweep(args.scene, runs, out, args.workers, scheduler_address(args), progress=not args.quiet,
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


def _campaign_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign", help="campaign file (TOML), e.g. campaigns/double_flap_campaign.toml")
    parser.add_argument("--out", required=True, help="campaign directory: fom/, models/, rom/, report/")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    scheduler_arguments(parser)
    parser.add_argument("--retry-failed", action="store_true",
                        help="run the ROM-FOM runs that failed once more (after a change to the scene, say)")
    parser.add_argument("--status", action="store_true",
                        help="say where each run and model of the campaign in --out stands, and run nothing")


def _campaign(args: argparse.Namespace) -> int:
    from cosim.errors import SceneError
    from workflow.campaign import run_campaign

    if args.status:
        from workflow.campaign_status import campaign_status
        print("\n".join(campaign_status(args.campaign, args.out)))
        return 0
    if args.workers < 1:
        raise SceneError(f"--workers is {args.workers}; allowed: an integer >= 1")
    report = run_campaign(args.campaign, args.out, args.workers, scheduler_address(args), retry_failed=args.retry_failed)
    print(f"report written to {report}")
    return 0


campaign = Command(
    "run a ROM evaluation campaign (FOM runs, training, ROM-FOM runs, report) on Dask",
    _campaign_arguments, _campaign,
    "Run a protocol written as a campaign file: its FOM-FOM runs, the models trained on them, the ROM-FOM runs "
    "against their references (optionally through the exported FMU), and the report. A rerun resumes: what is "
    "done is kept, what changed is run again.",
    "cosim campaign campaigns/double_flap_short.toml --out runs/flap_demo")
