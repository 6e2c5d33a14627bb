"""Where a flight cut short resumes: the stations its log shows photographed as the mission asked,
and the first station of the flight order that is not.

A photo counts for its station only when it was taken in the mission's own mode (AUTO, PX4's
AUTO_MISSION: flight/modes.py) and lies within the tolerance `log ingest` matched with. A
return to launch keeps the distance trigger running (ArduPilot's CAM_AUTO_ONLY = 0, its
default): its photos along the line are near stations, but not at them and not as planned, so
those stations are flown again. The resumed flight starts at the first station of the flight
order no counted photo took, not after the last photo matched: every station before it is done.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerosurvey.errors import InputError
from aerosurvey.flight.modes import MISSION_MODES
from aerosurvey.flight.records import EventRows
from aerosurvey.ids import station_index
from aerosurvey.manifest import Manifest


@dataclass(frozen=True)
class ResumeStart:
    """The first station to fly (index in flight order and id), the stations counted as done
    (all of those before it among them) and what was counted and why, one line each."""

    first: int
    first_id: str
    done: int
    said: tuple[str, ...]


def start_after(station_ids: tuple[str, ...], after: str) -> ResumeStart:
    """`--after STATION`: the stations up to it (flight order) are done, the next one is the first to fly."""
    i = station_index(station_ids, after)
    if i + 1 == len(station_ids):
        raise InputError(f"station {after!r} is the plan's last: nothing is left to fly", key="--after")
    return ResumeStart(i + 1, station_ids[i + 1], i + 1,
                       (f"--after {after}: the {i + 1} stations up to it in the flight order are taken as photographed",))


def counted_stations(rows: EventRows, tolerance_m: float) -> tuple[set[str], list[str]]:
    """(the stations a photo counts for, what was counted and why): a photo counts when it is
    matched to a station within `tolerance_m` and was taken in the mission's mode; when the log
    records no mode at all, by its distance alone (and the lines say so)."""
    modes_logged = any(m is not None for m in rows.mode)
    done: set[str] = set()
    out_of_mode: dict[str, int] = {}
    unknown = far = 0
    far_max = 0.0
    for station, dist, mode in zip(rows.station, rows.distance_m.tolist(), rows.mode):
        if station is None:
            continue
        if modes_logged and mode is None:
            unknown += 1
        elif mode is not None and mode not in MISSION_MODES:
            out_of_mode[mode] = out_of_mode.get(mode, 0) + 1
        elif not dist <= tolerance_m:
            far += 1
            far_max = max(far_max, dist)
        else:
            done.add(station)
    unmatched = sum(s is None for s in rows.station)
    mission = "/".join(sorted({m for m in rows.mode if m in MISSION_MODES})) or "AUTO"
    said = [f"counted as done: {len(done)} photo(s) taken in {mission} within {tolerance_m:.2f} m of their station "
            "(the tolerance `log ingest` matched with)" if modes_logged else
            f"counted as done: {len(done)} photo(s) within {tolerance_m:.2f} m of their station; the log records no "
            "flight modes, so a photo taken out of the mission (in a return to launch) cannot be told and counts too"]
    skipped = [f"{n} taken in {m} (out of the mission: not the planned photo)" for m, n in sorted(out_of_mode.items())]
    if unknown:
        skipped.append(f"{unknown} taken before the log's first flight mode")
    if far:
        skipped.append(f"{far} farther than {tolerance_m:.2f} m from their station (up to {far_max:.1f} m)")
    if skipped:
        said.append("not counted, their stations are flown again: " + ", ".join(skipped))
    if unmatched:
        said.append(f"{unmatched} photo(s) matched to no station (extra triggers)")
    return done, said


def first_not_done(station_ids: tuple[str, ...], done: set[str], said: list[str]) -> ResumeStart:
    """The first station of the flight order not in `done`; InputError when every one is."""
    todo = [i for i, s in enumerate(station_ids) if s not in done]
    if not todo:
        raise InputError(f"every one of the plan's {len(station_ids)} stations has a photo counted as done ("
                         + "; ".join(said) + "): nothing is left to fly", key="--log")
    first = todo[0]
    again = sum(s in done for s in station_ids[first:])
    said = [*said, f"resume from {station_ids[first]}, the first station of the flight order with no photo counted"
            + (f"; {again} station(s) after it that were photographed are flown again" if again else "")]
    return ResumeStart(first, station_ids[first], len(done), tuple(said))


def start_from_log(log_dir: Path, doc: Manifest) -> ResumeStart:
    """The start of the resumed flight from a `log ingest --plan` folder of this plan (events.csv
    and log_report.json). A log of one sortie says nothing of the stations before it: they are
    taken as flown by the sorties before."""
    from aerosurvey.flight import records
    from aerosurvey.flight.refly import read_log_of_plan

    report = read_log_of_plan(log_dir, doc)
    events_path = log_dir / "events.csv"
    if not events_path.is_file():
        raise InputError(f"--log {str(log_dir)!r} has no events.csv: give the folder "
                         "`aerosurvey log ingest LOG --plan PLAN -o FOLDER` wrote", key="--log")
    rows = records.read_events_csv(events_path)
    done, said = counted_stations(rows, float(report["tolerance_m"]))
    ids = doc.stations.ids
    before = _stations_before_sortie(report, doc)
    if before:
        done |= set(ids[:before])
        said.append(f"the log is of sortie {report['plan']['sortie']}: the {before} stations before it are taken as flown")
    return first_not_done(ids, done, said)


def _stations_before_sortie(report: dict[str, Any], doc: Manifest) -> int:
    sortie = (report.get("plan") or {}).get("sortie")
    if sortie is None:
        return 0
    first = next((s.first_station for s in doc.sorties if s.id == sortie), None)
    if first is None:
        raise InputError(f"the log report names sortie {sortie!r}, which {doc.where} does not have: ingest the log again "
                         "with this plan", key="--log")
    return doc.stations.index(first)
