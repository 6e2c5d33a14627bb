"""`aerosurvey check`: evaluate rule profiles on a plan, the strict gate before flight."""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from aerosurvey import console
from aerosurvey.errors import CheckFailed, InputError

if TYPE_CHECKING:
    from aerosurvey.rules.load import Target
    from aerosurvey.rules.profile import Profile

log = logging.getLogger(__name__)

_MARK = {"pass": "PASS", "fail": "FAIL", "warning": "WARN", "info": "INFO", "not-checkable": "N/A "}


def chosen_profiles(target: Target, profile_ids: list[str], profile_dirs: list[Path]) -> list[Profile]:
    """The chosen profiles (default: those the plan was checked with), with the plan's overrides.
    None chosen (none given, none in the plan): [] and a one-line warning that lists the profiles there are."""
    # the rule engine loads numpy, shapely and pyproj: imported when rules run, not when help lists this command
    from aerosurvey.rules.profile import apply_overrides, available_profiles, select_profiles

    ids = profile_ids or target.profiles
    if ids:
        return apply_overrides(select_profiles(ids, profile_dirs), target.overrides)
    log.warning("no rule profile chosen (none given, none in the plan's spec): only the planner's own rules are "
                "checked; add --profile ID, one of: %s", ", ".join(available_profiles(profile_dirs)))
    return []


def plan_records(target: Target, profiles: list[Profile]) -> list[dict[str, Any]]:
    """Every rule result of a plan, as manifest.json records and as `plan` counts them: the
    profiles' and the planner's own (uncovered-ground)."""
    from aerosurvey.rules.engine import evaluate
    from aerosurvey.rules.flown import plan_evidence

    results = evaluate(profiles, plan_evidence(target.view, profiles, target.outdir)) if profiles else []
    return [dict(r.as_dict()) for r in results] + list(target.planner_rules)


def format_results(records: Sequence[Mapping[str, Any]]) -> list[str]:
    lines = []
    for r in records:
        lines.append(f"{_MARK[r['status']]} {r['rule']}: {r['statement']}")
        lines.append(f"     measured {r['measured']}; required {r['required']}")
        lines.extend(f"     - {e}" for e in r["evidence"])
    return lines


@click.command()
@click.argument("target", required=False, type=click.Path(path_type=Path))
@click.option("--profile", "profiles", multiple=True,
              help="Rule profile id (repeatable); default: the profiles the plan was checked with (the spec's [rules] profiles).")
@click.option("--profile-dir", "profile_dirs", multiple=True, type=click.Path(file_okay=False, path_type=Path),
              help="A folder of your own rule profiles (*.toml); also AEROSURVEY_PROFILES.")
@click.option("--list", "list_profiles", is_flag=True, help="List the rule profiles there are (no TARGET needed).")
@click.option("--json", "as_json", is_flag=True, help="Print the results (and a plan's summary) as JSON.")
@click.option("--zones", "zone_files", multiple=True, type=click.Path(dir_okay=False, path_type=Path),
              help="An official UAS zone file (ED-269 or ED-318; repeatable) to check a mission spec against, besides its "
                   "[airspace] zones (docs/airspace.md).")
@click.option("--plan", "plan_dir", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="With a flight folder: the plan folder it flew (default: the one its log_report.json names).")
@click.option("--wind", default=None, metavar="SPEED@FROM[GGUST]",
              help="With a mission spec: the wind to plan it in, over its conditions.wind (m/s @ the true bearing it "
                   "blows from, e.g. 6@240G9).")
def check(target: Path | None, profiles: tuple[str, ...], profile_dirs: tuple[Path, ...], list_profiles: bool,
          as_json: bool, zone_files: tuple[Path, ...], plan_dir: Path | None, wind: str | None) -> None:
    """Check a mission spec or a plan folder against rule profiles.

    Prints each rule's result and the plan's summary, whose rule count is the one `plan`
    printed (the planner's own rule, uncovered-ground, included). Without a profile (none
    given, none in the plan) only the planner's own rules are checked, and a warning lists
    the available profiles. With -q (and no --json), nothing but the error of a failing check.

    A flight folder (`log ingest` output, with the plan) is checked planned vs flown, without a
    profile on the planner's own rule too; the places a rule fails on the flown photos go to its
    failing_places.geojson. A flight of a campaign block's plan records a "compliance" event in the
    campaign's register (docs/campaign.md).

    Exit code 0 when every error-level rule passes, 1 when one fails (named on stderr), 2 for bad input.
    """
    from aerosurvey.report.summary import plan_summary, summary_json, summary_text
    from aerosurvey.rules.load import open_target

    if list_profiles:
        from aerosurvey.rules.profile import available_profiles

        for p in available_profiles(list(profile_dirs)).values():
            click.echo(f"{p.id:24} {len(p.rules):3d} rules  {p.name}")
        return
    if target is None:
        raise InputError("give TARGET, a mission spec or a plan folder (or --list for the rule profiles)")
    from aerosurvey.flight import DAY_FILE

    if (target / "log_report.json").is_file() or (target / DAY_FILE).is_file():  # a `log ingest` folder: planned vs flown
        from aerosurvey.commands.block_events import record_block_event
        from aerosurvey.flight.compliance import check_flight

        flown = check_flight(target, plan_dir, lambda t: chosen_profiles(t, list(profiles), list(profile_dirs)), as_json)
        record_block_event(flown.plan_folder, "compliance", f"{target.resolve().name}: {flown.text()}")
        if flown.failed:
            raise SystemExit(1)
        return
    if plan_dir is not None:
        raise InputError(f"--plan {str(plan_dir)!r} is for a flight folder (`aerosurvey log ingest` output); {str(target)!r} is none")
    plan = open_target(target, zone_files, wind)
    records = plan_records(plan, chosen_profiles(plan, list(profiles), list(profile_dirs)))
    summary = plan_summary(plan.view.manifest, records)
    if as_json:
        click.echo(json.dumps({"results": records, "failed": list(summary.rules.failed), "summary": summary_json(summary)},
                              indent=1))
    else:
        for line in format_results(records) + summary_text(summary):
            console.echo(line)
    if summary.rules.failed:
        raise CheckFailed(f"{target}: rules failing at error level: {', '.join(summary.rules.failed)}")
