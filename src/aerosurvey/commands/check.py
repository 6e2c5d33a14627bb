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
    from aerosurvey.rules.engine import Evidence
    from aerosurvey.rules.load import Target

log = logging.getLogger(__name__)

_MARK = {"pass": "PASS", "fail": "FAIL", "warning": "WARN", "info": "INFO", "not-checkable": "N/A "}


def run_rules(target: Target, profile_ids: list[str], profile_dirs: list[Path]) -> tuple[list[dict[str, Any]], Evidence | None]:
    """The rule results of a plan (records as manifest.json holds them): the chosen profiles'
    (default: those the plan was checked with) and the planner's own, as `plan` counts them;
    with the control point evidence the profiles used."""
    # the rule engine loads numpy, shapely and pyproj: imported when rules run, not when help lists this command
    from aerosurvey.rules.engine import Evidence, evaluate, layout_settings
    from aerosurvey.rules.profile import apply_overrides, available_profiles, select_profiles

    ids = profile_ids or target.profiles
    if not ids:
        have = ", ".join(available_profiles(profile_dirs))
        log.warning("no rule profile chosen (none given, none in the plan's spec): only the planner's own rules are "
                    "checked; add --profile ID, one of: %s", have)
        return list(target.planner_rules), None
    profiles = apply_overrides(select_profiles(ids, profile_dirs), target.overrides)
    layout = None
    if target.outdir is not None and (target.outdir / "control_points.geojson").exists():
        from aerosurvey.rules.cp_files import read_layout

        f = target.outdir / "control_points.geojson"
        layout = read_layout(f.read_text(), target.view, str(f))
    ev = Evidence(target.view, layout_settings(target.view, profiles), layout)
    return [dict(r.as_dict()) for r in evaluate(profiles, ev)] + list(target.planner_rules), ev


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
@click.option("--json", "as_json", is_flag=True, help="Print the results and the plan's summary as JSON.")
def check(target: Path | None, profiles: tuple[str, ...], profile_dirs: tuple[Path, ...], list_profiles: bool,
          as_json: bool) -> None:
    """Check a mission spec or a plan folder against rule profiles.

    Prints each rule's result and the plan's summary, whose rule count is the one `plan`
    printed (the planner's own rule, uncovered-ground, included). Without a profile (none
    given, none in the plan) only the planner's own rules are checked, and a warning lists
    the available profiles. Exit code 0 when every error-level rule passes, 1 when one fails
    (named on stderr), 2 for bad input. With -q (and no --json), nothing but that error.
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
    plan = open_target(target)
    records, _ = run_rules(plan, list(profiles), list(profile_dirs))
    summary = plan_summary(plan.view.manifest, records)
    if as_json:
        click.echo(json.dumps({"results": records, "failed": list(summary.rules.failed), "summary": summary_json(summary)},
                              indent=1))
    else:
        for line in format_results(records) + summary_text(summary):
            console.echo(line)
    if summary.rules.failed:
        raise CheckFailed(f"{target}: rules failing at error level: {', '.join(summary.rules.failed)}")
