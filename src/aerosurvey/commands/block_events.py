"""The events `upload`, `check FLIGHT`, `refly` and `qa accuracy` record in a campaign's register when the plan
folder they work on is a campaign block's (docs/campaign.md, "The register").

Called after the command's own work is written: a plan folder outside a campaign records nothing and prints
nothing; a block folder the register no longer holds (planned again under a new key) or holds as not planned
records nothing and logs one warning saying why; a damaged register is an InputError naming it (exit code 2,
the command's own files already written).
"""

from __future__ import annotations

import logging
from pathlib import Path

import click

from aerosurvey import console

log = logging.getLogger(__name__)


def record_block_event(plan_dir: Path, event: str, detail: str, accuracy: Path | None = None) -> None:
    """Record `event` with `detail` for the block whose folder `plan_dir` is (`campaign.register.block_of`);
    a "qa" event files the `accuracy` folder's accuracy.json as `campaign record BLOCK qa --accuracy` does
    (without one, nothing is recorded and a warning says so)."""
    from aerosurvey.campaign.register import NotRecorded, block_of, now_utc, record

    campaign = block_of(plan_dir)
    if campaign is None:
        return
    folder = plan_dir.resolve().name
    if event == "qa" and accuracy is None:
        log.warning("campaign %s: qa event not recorded: give -o DIR, the verdict filed is the accuracy.json written "
                    "there", campaign)
        return
    try:
        if accuracy is not None:
            from aerosurvey.campaign.verdicts import record_verdict

            row = record_verdict(campaign, None, accuracy, detail, now_utc(), folder=folder)
        else:
            row = record(campaign, None, event, detail, now_utc(), folder=folder)
    except NotRecorded as exc:
        log.warning("campaign %s: %s event not recorded: %s", campaign, event, exc)
        return
    if not console.quiet():
        click.echo(f"campaign {campaign}: block {row.name}: {event} recorded; status {row.status}", err=True)
