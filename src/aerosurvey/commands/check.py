"""`aerosurvey check`: evaluate rule profiles on a plan, the strict gate before flight."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import click

from aerosurvey.errors import InputError

if TYPE_CHECKING:
    from aerosurvey.rules.engine import Evidence, RuleResult
    from aerosurvey.rules.load import Target

_MARK = {"pass": "PASS", "fail": "FAIL", "warning": "WARN", "info": "INFO", "not-checkable": "N/A "}


def run_rules(target: Target, profile_ids: list[str], profile_dirs: list[Path]) -> tuple[list[RuleResult], Evidence]:
    """Results of the chosen profiles on a target, with the control point layout used."""
    # the rule engine loads numpy, shapely and pyproj: imported when rules run, not when help lists this command
    from aerosurvey.rules.engine import Evidence, evaluate, layout_settings
    from aerosurvey.rules.profile import apply_overrides, select_profiles

    ids = profile_ids or target.profiles
    if not ids:
        raise InputError("no rule profile chosen: give --profile ID (see `aerosurvey check --list`) "
                         "or name them in the spec's [rules] profiles")
    profiles = apply_overrides(select_profiles(ids, profile_dirs), target.overrides)
    layout = None
    if target.outdir is not None and (target.outdir / "control_points.geojson").exists():
        from aerosurvey.rules.cp_files import read_layout

        f = target.outdir / "control_points.geojson"
        layout = read_layout(f.read_text(), target.view, str(f))
    ev = Evidence(target.view, layout_settings(target.view, profiles), layout)
    return evaluate(profiles, ev), ev


def format_results(results: list[RuleResult]) -> list[str]:
    lines = []
    for r in results:
        lines.append(f"{_MARK[r.status]} {r.rule}: {r.statement}")
        lines.append(f"     measured {r.outcome.measured}; required {r.outcome.required}")
        lines.extend(f"     - {e}" for e in r.outcome.evidence)
    return lines


@click.command()
@click.argument("target", required=False, type=click.Path(path_type=Path))
@click.option("--profile", "profiles", multiple=True, help="Rule profile id (repeatable); default: the spec's [rules] profiles.")
@click.option("--profile-dir", "profile_dirs", multiple=True, type=click.Path(file_okay=False, path_type=Path),
              help="A folder of your own rule profiles (*.toml); also AEROSURVEY_PROFILES.")
@click.option("--list", "list_profiles", is_flag=True, help="List the rule profiles there are (no TARGET needed).")
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON.")
@click.option("--plan", "plan_dir", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="With a flight folder: the plan folder it flew (default: the one its log_report.json names).")
def check(target: Path | None, profiles: tuple[str, ...], profile_dirs: tuple[Path, ...], list_profiles: bool,
          as_json: bool, plan_dir: Path | None) -> None:
    """Check a mission spec or a plan folder against rule profiles.

    A flight folder (`log ingest --plan` output) is checked planned vs flown; the places a rule
    fails on the flown photos go to its failing_places.geojson.

    Exit code 0 when every error-level rule passes, 1 when one fails, 2 for bad input.
    """
    from aerosurvey.rules.engine import failed_errors
    from aerosurvey.rules.load import open_target

    if list_profiles:
        from aerosurvey.rules.profile import available_profiles

        for p in available_profiles(list(profile_dirs)).values():
            click.echo(f"{p.id:24} {len(p.rules):3d} rules  {p.name}")
        return
    if target is None:
        raise InputError("give TARGET, a mission spec or a plan folder (or --list for the rule profiles)")
    if (target / "log_report.json").is_file():  # a `log ingest` folder: planned vs flown (docs/flight-logs.md)
        from aerosurvey.flight.compliance import check_flight

        check_flight(target, plan_dir, lambda t: run_rules(t, list(profiles), list(profile_dirs)), list(profile_dirs), as_json)
        return
    if plan_dir is not None:
        raise InputError(f"--plan {str(plan_dir)!r} is for a flight folder (`aerosurvey log ingest` output); {str(target)!r} is none")
    results, _ = run_rules(open_target(target), list(profiles), list(profile_dirs))
    if as_json:
        click.echo(json.dumps({"results": [r.as_dict() for r in results],
                               "failed": [r.rule for r in failed_errors(results)]}, indent=1))
    else:
        for line in format_results(results):
            click.echo(line)
        bad = failed_errors(results)
        click.echo(f"{len(results)} rules: {sum(r.status == 'pass' for r in results)} passed, {len(bad)} failed")
    if failed_errors(results):
        raise SystemExit(1)
