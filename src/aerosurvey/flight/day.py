"""A day of flights as one record: several flight records of one plan (logs and photo folders:
its sorties, a sortie flown again, a re-fly) ingested together (`aerosurvey log ingest` with
several records; docs/flight-logs.md, "A day of flights").

Each record is read and recognised (:func:`recognise`): as the sortie its log's mission is, or
the whole mission (then matched to those stations, as one log is); else by its photos, as the
sortie whose stations more than half of them lie nearest, else as a re-fly of the plan's
stations (its photos spread over several sorties), and matched to the stations its photos lie
nearest (the matcher takes stations in flight order within a window: a record that starts far
into the plan, or holds a few photos of another sortie, would lose photos against the sortie's
or the plan's stations). A record of another plan, another mission or too damaged is refused
with its name before anything is written.

The day's flown record is the union of the records' photos (:func:`union`): a station
photographed by several records counts once, with the photo nearest it (ties: the earlier
record, then the earlier photo); a photo matched to no station is always kept. Its coverage,
figures and the plan's rules are measured on that union as for one record, for each sortie (the
records recognised as it) and for the whole; the stations no record photographed are listed.
The one re-fly of what is still missing is `aerosurvey refly DAY_FOLDER` over the union's
coverage.tif.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey import ids
from aerosurvey.errors import CheckFailed, InputError
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.flight import DAY_FILE, records
from aerosurvey.flight.coverage import CountRaster, flown_view, write_count_raster
from aerosurvey.flight.events import Events
from aerosurvey.flight.ingest import (
    Ingested,
    check_same_plan,
    flown_figures,
    losses_beyond_share,
    mission_check,
    on_plan,
    read_record,
    sortie_flown,
    write_record,
)
from aerosurvey.flight.mission_flown import MissionCheck, another_mission
from aerosurvey.manifest import Manifest
from aerosurvey.plan.progress import Progress, no_progress
from aerosurvey.rules.planview import PlanView

#: what a record is of: one sortie, the whole mission, or a re-fly of stations of several sorties
SORTIE, WHOLE, REFLY = "sortie", "whole", "re-fly"
#: where each record's own outputs go inside the day's folder
RECORDS_FOLDER = "records"
KEEP_RULE = ("a station photographed by several records counts once: the photo nearest its station is kept (ties: "
             "the earlier record, then the earlier photo); photos matched to no station are all kept")


@dataclass(frozen=True)
class Recognised:
    """What a record is of (`kind`: SORTIE, WHOLE or REFLY), its sortie, and how that was found."""

    kind: str
    sortie: str | None
    by: str  # "mission" (its log's mission) or "photos" (where its photos lie)
    why: str


def recognise(ev: Events, mission: MissionCheck, doc: Manifest) -> Recognised:
    """The sortie a record is of: the one its log's mission is (or the whole mission); else the
    sortie whose stations more than half of its photos lie nearest; else a re-fly of stations of
    several sorties (nothing holds more than half), matched to every station."""
    if mission.names_sortie:
        file = mission.comparison.planned.file if mission.comparison is not None else "?"
        if mission.sortie is None:
            return Recognised(WHOLE, None, "mission", f"its log's mission is the whole mission's ({file})")
        return Recognised(SORTIE, mission.sortie, "mission", f"its log's mission is sortie {mission.sortie}'s ({file})")
    if not doc.sorties:
        return Recognised(WHOLE, None, "photos", "the plan is one mission, no sorties")
    flown, votes = sortie_flown(ev, doc)
    if flown is not None and votes > len(ev) / 2:
        return Recognised(SORTIE, flown, "photos", f"{votes} of its {len(ev)} photos lie nearest the stations of sortie {flown}")
    return Recognised(REFLY, None, "photos", f"no sortie's stations lie nearest more than half of its {len(ev)} photos"
                      + (f" (sortie {flown}: {votes})" if flown is not None else "") + ": a re-fly")


@dataclass(frozen=True)
class Flown:
    """One record's photos as the rules see them (`flown`: the plan with its photos in place of
    the stations), the station each photo matched (None: none) and its distance to it (NaN: none)."""

    flown: PlanView
    station: tuple[str | None, ...]
    distance_m: np.ndarray


@dataclass(frozen=True)
class Repeat:
    """A station photographed by more than one record: the photo kept and those left out, each
    as (record number from 1, photo id, metres from the station)."""

    station: str
    kept: tuple[int, str, float]
    dropped: tuple[tuple[int, str, float], ...]

    def as_dict(self) -> dict[str, Any]:
        def photo(p: tuple[int, str, float]) -> dict[str, Any]:
            return {"record": p[0], "photo": p[1], "distance_m": round(p[2], 3)}

        return {"station": self.station, "kept": photo(self.kept), "dropped": [photo(p) for p in self.dropped]}


@dataclass(frozen=True)
class Union:
    """The records' photos as one flight: `flown` the plan with the kept photos in place of its
    stations (in the plan's flight order: each run's photos in the order of its stations, a photo
    matched to none after the one before it in its record), `kept` each record's photos kept,
    the stations photographed and the repeats."""

    flown: PlanView
    kept: tuple[np.ndarray, ...]
    photographed: frozenset[str]
    repeats: tuple[Repeat, ...]


def union(view: PlanView, flowns: Sequence[Flown], numbers: Sequence[int]) -> Union:
    """The union of records' photos (`numbers`: each record's number in the day, from 1); see the module's rule."""
    best: dict[str, tuple[float, int, int]] = {}  # station -> (distance, record index, photo index)
    for r, f in enumerate(flowns):
        for i, (s, d) in enumerate(zip(f.station, f.distance_m.tolist())):
            key = (d if math.isfinite(d) else math.inf, r, i)
            if s is not None and (s not in best or key < best[s]):
                best[s] = key
    kept = []
    at = {sid: k for k, sid in enumerate(view.station_ids)}
    order: list[tuple[int, int, int, int]] = []  # (anchor station index, 0 matched / 1 not, record, photo)
    for r, f in enumerate(flowns):
        mask = np.array([s is None or best[s][1:] == (r, i) for i, s in enumerate(f.station)], bool)
        kept.append(mask)
        anchor = -1
        for i, s in enumerate(f.station):
            if s is not None:
                anchor = at[s]
            if mask[i]:
                order.append((anchor, int(s is None), r, i))
    order.sort()
    start = np.cumsum([0, *(len(f.station) for f in flowns)])
    pick = np.array([start[r] + i for _, _, r, i in order], np.intp)
    views = [f.flown for f in flowns]
    names = [ids.day_photo_id(n, p) for n, v in zip(numbers, views) for p in v.station_ids]
    runs = [q for v in views for q in v.run_ids]

    def column(key: str) -> np.ndarray:
        return np.concatenate([np.asarray(getattr(v, key), float) for v in views])[pick]

    flown = dataclasses.replace(view, station_ids=[names[g] for g in pick], run_ids=[runs[g] for g in pick],
                                x=column("x"), y=column("y"), agl=column("agl"), heading_deg=column("heading_deg"),
                                pitch_deg=column("pitch_deg"), camera_yaw_deg=column("camera_yaw_deg"))
    shots: dict[str, list[tuple[int, int]]] = {}
    for r, f in enumerate(flowns):
        for i, s in enumerate(f.station):
            if s is not None:
                shots.setdefault(s, []).append((r, i))
    repeats = [Repeat(s, _photo(flowns, numbers, r, i), tuple(_photo(flowns, numbers, q, j) for q, j in shots[s] if (q, j) != (r, i)))
               for s, (_, r, i) in best.items() if len(shots[s]) > 1]
    repeats.sort(key=lambda p: at[p.station])
    return Union(flown, tuple(kept), frozenset(best), tuple(repeats))


def _photo(flowns: Sequence[Flown], numbers: Sequence[int], r: int, i: int) -> tuple[int, str, float]:
    return numbers[r], flowns[r].flown.station_ids[i], float(flowns[r].distance_m[i])


def record_flown(view: PlanView, result: Ingested) -> Flown:
    """A record's photos as :func:`union` takes them, from what `log ingest` found."""
    assert result.photos is not None and result.match is not None
    station = tuple(result.photos.station)
    distance = np.where([s is not None for s in station], np.asarray(result.match.distance_m, float), np.nan)
    return Flown(flown_view(view, result.photos), station, distance)


@dataclass(frozen=True)
class Record:
    """One flight record of the day: its path, its number (from 1), what it is of and what `log ingest` found."""

    path: Path
    number: int
    recognised: Recognised
    result: Ingested

    @property
    def folder(self) -> str:
        """Its outputs' folder inside the day's (numbered: two records may share a name)."""
        return f"{RECORDS_FOLDER}/{self.number:02d}-{self.path.name}"


@dataclass(frozen=True)
class Day:
    """The day's records and the day's summary (day_report.json's content) and union coverage."""

    records: tuple[Record, ...]
    report: dict[str, Any]
    coverage: CountRaster


def ingest_day(paths: Sequence[Path], view: PlanView, *, tolerance_m: float | None = None, fixed_camera: bool = False,
               dem_path: Path | None = None, progress: Progress | None = None) -> Day:
    """Every record of `paths` ingested against the plan and recognised, then the day's union;
    InputError (a record unreadable, of another plan) or CheckFailed (of another mission, damaged
    beyond `log ingest`'s share) naming the first record refused. Nothing is written."""
    report_progress = progress or no_progress
    doc = view.document
    found = []
    for k, path in enumerate(paths, start=1):
        def step(stage: str, done: float, k: int = k) -> None:
            report_progress(f"record {k} of {len(paths)}: {stage}", 0.9 * (k - 1 + done) / len(paths))

        name = f"record {k} of {len(paths)} ({path.name!r})"
        try:
            read = read_record(path, doc.mission.vehicle, fixed_camera=fixed_camera, progress=step)
            mission = mission_check(path, doc)
            median = check_same_plan(read.events, view, path.name, None)
            seen = recognise(read.events, mission, doc)
            result = on_plan(path, read, view, mission, seen.sortie, median, tolerance_m=tolerance_m,
                             fixed_camera=fixed_camera, dem_path=dem_path, nearest_only=seen.by == "photos", progress=step)
        except InputError as exc:
            raise InputError(f"{name} refused, nothing written: {exc}", key=exc.key) from None
        why = another_mission(result.report) or losses_beyond_share(path.name, result.report["read"], result.report["events"])
        if why is not None:
            raise CheckFailed(f"{name} refused, nothing written: {why}")
        found.append(Record(path, k, seen, result))
    report_progress("the day's union", 0.9)
    day, coverage = day_summary(view, found)
    report_progress("done", 1.0)
    return Day(tuple(found), day, coverage)


def day_summary(view: PlanView, found: Sequence[Record]) -> tuple[dict[str, Any], CountRaster]:
    """day_report.json's content and the whole day's coverage raster."""
    doc = view.document
    flowns = [record_flown(view, r.result) for r in found]
    numbers = [r.number for r in found]
    whole = union(view, flowns, numbers)
    figures = flown_figures(view, whole.flown)
    assert figures.coverage is not None
    sorties = []
    for s in doc.sorties:
        of = [k for k, r in enumerate(found) if r.recognised.sortie == s.id]
        if of:
            u = union(view, [flowns[k] for k in of], [numbers[k] for k in of])
            planned = doc.sortie_stations(s.id).ids
            sorties.append({"sortie": s.id, "records": [numbers[k] for k in of],
                            **_group(planned, u, flown_figures(view, u.flown, coverage=False).rules)})
    recs = []
    for r, kept in zip(found, whole.kept):
        rep = r.result.report
        recs.append({"record": r.number, "name": r.path.name, "folder": r.folder, "kind": r.recognised.kind,
                     "sortie": r.recognised.sortie, "recognised_by": r.recognised.by, "recognised": r.recognised.why,
                     "events": rep["events"], "matched": rep["matched"], "kept": int(kept.sum()),
                     "rules_failed": [x["rule"] for x in rep.get("rules_on_flown_data", []) if x["status"] == "fail"]})
    report = {"plan": {"mission": doc.mission.name, "folder": doc.where}, "keep_rule": KEEP_RULE, "records": recs,
              "sorties": sorties,
              "day": {**_group(doc.stations.ids, whole, figures.rules), "realized": figures.realized,
                      "coverage": figures.coverage.summary}}
    records.day_document(report)  # a report that does not match its schema is a bug: found before writing
    return report, figures.coverage


def _group(planned: Sequence[str], u: Union, rules: list[dict[str, Any]]) -> dict[str, Any]:
    missing = [s for s in planned if s not in u.photographed]
    return {"planned": len(planned), "photographed": len(planned) - len(missing), "photos": len(u.flown.station_ids),
            "missing_stations": missing, "repeated_stations": [p.as_dict() for p in u.repeats],
            "rules_on_flown_data": rules}


def write_day(day: Day, outdir: Path, *, accuracy_xy: float = 2.0, accuracy_z: float = 4.0,
              fixed_camera: bool = False) -> dict[str, Any]:
    """Each record's outputs into its own folder (records/NN-NAME/: events.csv, log_report.json,
    coverage.tif, and a photo folder's camera poses), the union's coverage.tif and day_report.json
    into `outdir`, all or nothing. Returns the day report as written."""
    with staged_directory(outdir) as stage:
        for r in day.records:
            write_record(r.result, stage / r.folder, accuracy_xy=accuracy_xy, accuracy_z=accuracy_z, fixed_camera=fixed_camera)
        write_count_raster(stage / "coverage.tif", day.coverage)
        atomic_write_text(stage / DAY_FILE, records.dumps_day(day.report))
    return records.day_document(day.report)
