"""``cosim campaign`` (registered in pyproject.toml under ``cosim.commands``)."""

from __future__ import annotations

import argparse

from cosim.command import Command
from coupler.commands import _scheduler, _scheduler_arguments


def _campaign_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign", help="campaign file (TOML), e.g. scenes/double_flap_campaign.toml")
    parser.add_argument("--out", required=True, help="campaign directory: fom/, models/, rom/, report/")
    parser.add_argument("--workers", type=int, default=2, help="local Dask workers, one run each at a time (default 2)")
    _scheduler_arguments(parser)
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
    report = run_campaign(args.campaign, args.out, args.workers, _scheduler(args), retry_failed=args.retry_failed)
    print(f"report written to {report}")
    return 0


campaign = Command(
    "run a ROM evaluation campaign (FOM runs, training, ROM-FOM runs, report) on Dask",
    _campaign_arguments, _campaign,
    "Run a protocol written as a campaign file: its FOM-FOM runs, the models trained on them, the ROM-FOM runs "
    "against their references (optionally through the exported FMU), and the report. A rerun resumes: what is "
    "done is kept, what changed is run again.",
    "cosim campaign scenes/double_flap_short.toml --out runs/flap_demo")
