"""`aerosurvey brief`: what a pilot checks before launch, for the day and time of the flight; go or no-go."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import click

from aerosurvey import console
from aerosurvey.errors import CheckFailed, InputError


def flight_start(value: str | None) -> dt.datetime:
    """--at (brief, upload): ISO 8601 with a UTC offset; default the machine's clock now (the one place the brief reads it)."""
    if value is None:
        return dt.datetime.now(dt.UTC).astimezone().replace(microsecond=0)
    try:
        t = dt.datetime.fromisoformat(value)
    except ValueError:
        t = None
    if t is None or t.tzinfo is None:
        raise InputError(f"--at = {value!r} is not allowed: a date and time in ISO 8601 with its UTC offset, "
                         "e.g. 2026-05-14T09:00+02:00")
    return t


@click.command()
@click.argument("plan_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--spec", "spec_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="The spec the plan was made from (default: the manifest's, beside the plan folder or here).")
@click.option("--at", "at", default=None, help="The first launch, ISO 8601 with its UTC offset (default: now).")
@click.option("--zones", "zone_files", multiple=True, type=click.Path(dir_okay=False, path_type=Path),
              help="An official UAS zone file (ED-269 or ED-318; repeatable) besides the spec's [airspace] zones.")
@click.option("--wind", default=None, metavar="SPEED@FROM[GGUST]",
              help="The wind of the day, over the spec's conditions.wind (m/s @ the true bearing it blows from, e.g. "
                   "6@240G9): the flights are timed and the batteries counted in it.")
@click.option("--battery-change-min", type=click.FloatRange(0, 120), default=5.0, show_default=True,
              help="Minutes between one flight's landing and the next one's launch.")
@click.option("--connect", "url", default=None,
              help="A vehicle to check as `aerosurvey upload` checks it before the first flight (type, position, "
                   "battery, settings), read only: nothing is sent to it (pymavlink connection string).")
@click.option("--launch-distance", "launch_distance", default="200", show_default=True,
              help="With --connect: the farthest (m) the vehicle may be from the first flight's launch point; 'off': "
                   "not compared.")
@click.option("--json", "as_json", is_flag=True, help="Print the brief as JSON.")
def brief(plan_dir: Path, spec_path: Path | None, at: str | None, zone_files: tuple[Path, ...], wind: str | None,
          battery_change_min: float, url: str | None, launch_distance: str, as_json: bool) -> None:
    """What a pilot checks before launch, for the day and time of the flight: go or no-go.

    For the flights of PLAN_DIR at --at: the official zones that apply then, with their verdicts
    and messages; the batteries and the reserve left on the last; the sun at the first launch and
    the last landing, and sunset. Exit code 0 go (advice printed), 1 no-go, 2 bad input
    (docs/brief.md)."""
    from dataclasses import replace

    from aerosurvey.brief import brief_for
    from aerosurvey.inputs import plan_from_files, planned_spec
    from aerosurvey.manifest import read_manifest
    from aerosurvey.spec import load_spec, with_wind, with_zone_files

    doc = read_manifest(plan_dir, "PLAN_DIR")
    vehicle = []
    if url is not None:
        from aerosurvey.commands.upload import launch_distance_limit
        from aerosurvey.link.mission_protocol import Policy
        from aerosurvey.link.preflight import vehicle_items

        vehicle = vehicle_items(plan_dir, doc, url, Policy(), launch_distance_limit(launch_distance))
    spec = with_wind(with_zone_files(load_spec(planned_spec(plan_dir, spec_path, doc.raw["inputs"]["spec"])), zone_files), wind)
    result = brief_for(doc.raw, flight_start(at), battery_change_min,
                       lambda a, b: plan_from_files(replace(spec, conditions=replace(spec.conditions, start=a, end=b))),
                       vehicle)
    if as_json:
        click.echo(json.dumps(result.as_dict(), indent=1, ensure_ascii=False))
    else:
        for line in result.lines():
            console.echo(line)
    if result.verdict == "no-go":
        raise CheckFailed(f"no-go: {'; '.join(i.topic for i in result.items if i.verdict == 'no-go')}")
