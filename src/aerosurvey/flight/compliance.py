"""Compliance after the flight: `aerosurvey check FLIGHT_FOLDER` on a folder `log ingest` wrote.

The plan's rules run on the plan as planned and on the flown photos of events.csv (the same
checks, :mod:`aerosurvey.rules.flown`); each rule is shown planned against flown, and the
places where a rule fails on the flown photos are written into the folder as a GeoJSON
layer (`failing_places.geojson`) for `refly` and the web page.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click
import numpy as np

from aerosurvey import ids
from aerosurvey import manifest as mf
from aerosurvey.errors import CheckFailed, InputError
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.flight import DAY_FILE, records
from aerosurvey.flight.coverage import flown_view, recorded_photos
from aerosurvey.flight.mission_flown import another_mission
from aerosurvey.flight.refly import check_report_of_plan
from aerosurvey.rules.engine import Evidence, evaluate, failed_errors
from aerosurvey.rules.flown import PLACES_FILE, Judged, failing_places, judge, on_view, part, plan_evidence, planner_profile
from aerosurvey.rules.load import Target
from aerosurvey.rules.planview import PlanView
from aerosurvey.rules.profile import Profile

#: `check`'s choice of profiles for a plan ([] when none is chosen: the planner's own rule is checked)
ChooseProfiles = Callable[[Target], list[Profile]]


@dataclass(frozen=True)
class Flight:
    """A `log ingest` folder with the plan it flew."""

    folder: Path
    plan_folder: Path
    plan: PlanView  # the whole plan
    planned: PlanView  # the stations the log is of: one sortie's, or all
    flown: PlanView  # the plan with the flown photos in place of its stations
    sortie: str | None
    heights: str  # where the flown heights above ground came from, and the camera mount
    #: the station each flown photo matched (None: none) and its metres from it (NaN: none), in `flown`'s order
    station: tuple[str | None, ...]
    distance_m: np.ndarray
    other_mission: str | None = None  # why the log's mission is another than the plan's (`mission_flown.another_mission`)

    @property
    def target(self) -> Target:
        doc = self.plan.document
        return Target(self.plan, list(doc.mission.profiles), dict(doc.rule_overrides), self.plan_folder)


def _plan_folder(folder: Path, named: str, plan_dir: Path | None) -> Path:
    if plan_dir is not None:
        return plan_dir
    p = Path(named)
    p = p.parent if p.name == mf.FILE_NAME else p
    if not (p / mf.FILE_NAME).is_file():
        raise InputError(f"{str(folder)!r}: its log_report.json names the plan {named!r}, which is not there (from "
                         f"{str(Path.cwd())!r}); give the plan folder with --plan", key="--plan")
    return p


def _heights(report: dict[str, Any]) -> str:
    h = report.get("heights") or {}
    if h.get("source") == "dem":
        text = (f"heights above the DEM {h.get('dem')}" + (f" ({h['outside_dem']} photo(s) off it: above home)"
                                                           if h.get("outside_dem") else ""))
    else:
        text = "heights above home: flat ground assumed (`log ingest --dem` gives heights above the terrain)"
    if "photos" in report:
        return text + "; each photo's camera attitude as it recorded it (its gimbal's pitch and yaw)"
    if "fixed_camera" not in h:
        return text + "; camera taken as on a nadir gimbal (the report does not say)"
    return text + ("; camera fixed to the body: roll and pitch move the footprints" if h["fixed_camera"]
                   else "; camera on a nadir gimbal")


def open_flight(folder: Path, plan_dir: Path | None = None) -> Flight:
    """The flight folder's photos as a view of the plan (`plan_dir`, or the one its report names)."""
    report = records.read_report(folder / "log_report.json")
    info = report.get("plan")
    if info is None:
        raise InputError(f"{str(folder)!r} was ingested without --plan, so its photos are of no plan: run "
                         f"`aerosurvey log ingest LOG --plan PLAN -o {folder}`")
    plan_folder = _plan_folder(folder, info["folder"], plan_dir)
    view = PlanView.from_outdir(plan_folder, "--plan")
    check_report_of_plan(report, folder, view.document)
    events = folder / "events.csv"
    if not events.is_file():
        raise InputError(f"{str(folder)!r} has no events.csv: give the folder `aerosurvey log ingest` wrote")
    rows = records.read_events_csv(events)
    doc = view.document
    unknown = sorted({s for s in rows.station if s} - set(doc.stations.ids))
    if unknown:
        raise InputError(f"{events}: station {unknown[0]!r}{f' and {len(unknown) - 1} more' if len(unknown) > 1 else ''} "
                         f"is not in the plan {doc.where!r}: the plan has changed since the flight was ingested; "
                         "run `aerosurvey log ingest` again")
    sortie = info["sortie"]
    fixed = bool((report.get("heights") or {}).get("fixed_camera", False))
    photos = recorded_photos(view.crs, dict(zip(doc.stations.ids, doc.stations.run)), rows, fixed, "photos" in report)
    if not len(photos):
        raise InputError(f"{events}: none of its {len(rows)} photos has a position and a height above ground: "
                         "nothing flown can be measured")
    planned = view if sortie is None else part(view, doc.sortie_stations(sortie).ids)
    heights = _heights(report)
    if len(photos) < len(rows):
        heights += f"; {len(rows) - len(photos)} photo(s) without a position or height left out"
    distance = dict(zip((ids.event_id(int(e)) for e in rows.event), rows.distance_m.tolist()))
    return Flight(folder, plan_folder, view, planned, flown_view(view, photos), sortie, heights, photos.station,
                  np.array([distance[p] for p in photos.ids], float), another_mission(report))


def judge_flight(flight: Flight, profiles: list[Profile]) -> tuple[list[Judged], Evidence]:
    """Each rule of the profiles planned (on the stations the log is of) and flown, with the flown evidence."""
    base = plan_evidence(flight.plan, profiles, flight.plan_folder)
    planned = evaluate(profiles, base if flight.planned is flight.plan else on_view(base, flight.planned))
    flown = on_view(base, flight.flown)
    return judge(profiles, planned, flown), flown


def write_places(folder: Path, layer: dict[str, Any]) -> None:
    """failing_places.geojson into the flight folder, atomically; its other files are kept."""
    with staged_directory(folder, merge=True) as stage:
        atomic_write_text(stage / PLACES_FILE, json.dumps(layer, indent=1) + "\n")


@dataclass(frozen=True)
class FlownVerdict:
    """What `check FLIGHT_FOLDER` found: the plan folder flown, the rules judged on the flown photos, how many
    passed, the error-level ones that failed (the command exits 1 when there is one)."""

    plan_folder: Path
    rules: int
    passed: int
    failed: tuple[str, ...]

    def text(self) -> str:
        return (f"{self.rules} rules as flown: {self.passed} passed, {len(self.failed)} failed"
                + (f" at error level: {', '.join(self.failed)}" if self.failed else ""))


def check_flight(folder: Path, plan_dir: Path | None, choose: ChooseProfiles, as_json: bool) -> FlownVerdict:
    """`aerosurvey check FLIGHT_FOLDER`: print each rule planned / flown, write the failing places; the
    verdict (the command exits 1 when an error-level rule fails on the flown photos). CheckFailed when
    `log ingest` found that the vehicle flew another mission (its rules are then not judged against this
    plan). Without a profile chosen, the planner's own rule (`planner_profile`), as `check PLAN_FOLDER` does."""
    if (folder / DAY_FILE).is_file():
        return check_day(folder, plan_dir, choose, as_json)
    flight = open_flight(folder, plan_dir)
    if flight.other_mission is not None:
        raise CheckFailed(flight.other_mission)
    judged, flown = judge_flight(flight, choose(flight.target) or [planner_profile()])
    layer = failing_places(judged, flown)
    write_places(folder, layer)
    bad = failed_errors([j.flown for j in judged])
    if as_json:
        click.echo(json.dumps({"results": [j.as_dict() for j in judged], "failed": [r.rule for r in bad],
                               "heights": flight.heights, "places": str(folder / PLACES_FILE)}, indent=1))
    else:
        _echo_judged(flight, judged)
        before = sum(r.outcome.status == "fail" and r.severity == "error" for r in (j.planned for j in judged))
        click.echo(f"{len(judged)} rules as flown: {sum(j.status == 'pass' for j in judged)} passed, {len(bad)} failed "
                   f"({before} failed as planned); {len(layer['features'])} failing place(s) in {folder / PLACES_FILE}")
    return verdict(flight.plan_folder, judged)


def verdict(plan_folder: Path, judged: list[Judged]) -> FlownVerdict:
    return FlownVerdict(plan_folder, len(judged), sum(j.status == "pass" for j in judged),
                        tuple(r.rule for r in failed_errors([j.flown for j in judged])))


def _echo_judged(flight: Flight, judged: list[Judged], title: str = "") -> None:
    doc = flight.plan.document
    of = f"sortie {flight.sortie} of " if flight.sortie else ""
    click.echo(f"{title}{len(flight.flown.station_ids)} flown photos against {len(flight.planned.station_ids)} planned "
               f"stations of {of}mission {doc.mission.name!r} ({flight.plan_folder})")
    click.echo(flight.heights)
    for j in judged:
        click.echo(j.line())
        if j.flown.outcome.status == "fail":
            click.echo("".join(f"     - {e}\n" for e in j.flown.outcome.evidence), nl=False)


def day_flights(folder: Path, plan_dir: Path | None) -> tuple[list[Flight], Flight]:
    """A day of flights' folder (day_report.json) as flights: the union of the records of each
    sortie it names, against that sortie's stations, and the union of every record against all
    (flight/day.py's union: a station photographed twice counts once)."""
    from aerosurvey.flight.day import Flown, union

    day = records.read_day(folder / DAY_FILE)
    flights = [open_flight(folder / r["folder"], plan_dir) for r in day["records"]]
    for f in flights:
        if f.other_mission is not None:
            raise CheckFailed(f.other_mission)
    numbers = [r["record"] for r in day["records"]]
    first = flights[0]
    heights = " | ".join(dict.fromkeys(f.heights for f in flights))

    def group(of: list[int], sortie: str | None) -> Flight:
        u = union(first.plan, [Flown(flights[k].flown, flights[k].station, flights[k].distance_m) for k in of],
                  [numbers[k] for k in of])
        planned = first.plan if sortie is None else part(first.plan, first.plan.document.sortie_stations(sortie).ids)
        return Flight(folder, first.plan_folder, first.plan, planned, u.flown, sortie, heights, (), np.zeros(0))

    sorties = [group([numbers.index(n) for n in s["records"]], s["sortie"]) for s in day["sorties"]]
    return sorties, group(list(range(len(flights))), None)


def check_day(folder: Path, plan_dir: Path | None, choose: ChooseProfiles, as_json: bool) -> FlownVerdict:
    """`aerosurvey check DAY_FOLDER`: each sortie's and the whole day's rules planned / flown, on
    the union of the records' photos; the whole day's failing places into the folder; the whole
    day's verdict (exit 1 when an error-level rule fails on its photos; a sortie's failures are shown)."""
    sorties, whole = day_flights(folder, plan_dir)
    profiles = choose(whole.target) or [planner_profile()]
    judged = [(f, *judge_flight(f, profiles)) for f in [*sorties, whole]]
    _, whole_judged, whole_flown = judged[-1]
    layer = failing_places(whole_judged, whole_flown)
    write_places(folder, layer)
    bad = failed_errors([j.flown for j in whole_judged])
    if as_json:
        click.echo(json.dumps({"sorties": [{"sortie": f.sortie, "results": [j.as_dict() for j in js],
                                            "failed": [r.rule for r in failed_errors([j.flown for j in js])]}
                                           for f, js, _ in judged[:-1]],
                               "results": [j.as_dict() for j in whole_judged], "failed": [r.rule for r in bad],
                               "heights": whole.heights, "places": str(folder / PLACES_FILE)}, indent=1))
    else:
        for f, js, _ in judged:
            _echo_judged(f, js, "" if f.sortie else "the whole day: ")
            failed = failed_errors([j.flown for j in js])
            click.echo(f"{len(js)} rules as flown: {sum(j.status == 'pass' for j in js)} passed, {len(failed)} failed")
        click.echo(f"{len(layer['features'])} failing place(s) of the whole day in {folder / PLACES_FILE}")
    return verdict(whole.plan_folder, whole_judged)
