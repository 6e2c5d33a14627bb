"""A flight log's camera events against the plan it flew: the work of `aerosurvey log ingest`.

:func:`ingest` reads the log (and the images, when given), refuses a log of another plan,
compares the mission the log records with the plan's (which sortie it flew, what differs:
flight/mission_flown.py), matches events to the planned stations, measures the flown
footprints (overlaps, GSD, a photo-count raster) and runs the plan's rules on them; nothing
is written.
:func:`write_ingest` writes the result into a staged folder, all or nothing.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from aerosurvey.area import transformer
from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.flight import records
from aerosurvey.flight.coverage import (
    Aim,
    CountRaster,
    DemGround,
    FlownPhotos,
    count_raster,
    extras_summary,
    flown_photos,
    flown_view,
    heights_summary,
    on_the_ground,
    planned_aim,
    write_count_raster,
)
from aerosurvey.flight.events import Aims, Events, Match, match_to_stations, read_events
from aerosurvey.flight.handoff import camera_poses, geo_txt, metashape_csv, pix4d_csv
from aerosurvey.flight.images import ImageMatch, geotag_images, list_images, match_images
from aerosurvey.flight.mission_flown import (
    NOT_COMPARED,
    NOT_RECORDED,
    MissionCheck,
    PlannedMission,
    not_compared,
    planned_mission,
    recognise,
)
from aerosurvey.flight.mission_log import MissionRecord, read_mission
from aerosurvey.flight.modes import modes_report, read_modes
from aerosurvey.flight.photos import PhotoFlight, read_photo_flight
from aerosurvey.manifest import Manifest, Stations, sha256_file
from aerosurvey.plan.progress import Progress, no_progress
from aerosurvey.reproject import planar
from aerosurvey.rules.engine import Evidence, LayoutSettings, evaluate
from aerosurvey.rules.flown import on_view, plan_evidence
from aerosurvey.rules.planview import PlanView
from aerosurvey.rules.profile import apply_overrides, select_profiles

_EARTH_M = 6_371_000.0
#: `log ingest` fails (exit 1, outputs written) when reading lost more than this share of the
#: log's bytes to damage, or dropped more than this share of its camera events as implausible
MAX_LOST_SHARE = 0.01


def losses_beyond_share(log_name: str, read: dict[str, Any], events: int) -> str | None:
    """What reading the log lost, when it is more than MAX_LOST_SHARE of its bytes or of its
    camera events (copies of a chunk are not lost: each of their events is kept once)."""
    implausible, lost = int(read["implausible_events"]), int(read["lost_bytes"])
    logged = events + implausible
    if implausible <= MAX_LOST_SHARE * logged and lost <= MAX_LOST_SHARE * read["bytes"]:
        return None
    return (f"flight log {log_name!r}: {implausible} of {logged} camera events dropped as implausible "
            f"({100 * implausible / max(logged, 1):.1f} %) and {lost} of {read['bytes']} bytes skipped as damage "
            f"({100 * lost / max(read['bytes'], 1):.1f} %), more than the {100 * MAX_LOST_SHARE:g} % allowed; the outputs "
            "are written: see log_report.json's read.skipped for where and why")


@dataclass(frozen=True)
class Ingested:
    """What `log ingest` found; `report` is log_report.json's content (without the geotag part)."""

    events: Events
    mode: list[str | None]  # the flight mode at each event (None: not known)
    match: Match | None
    images: ImageMatch | None
    photos: FlownPhotos | None
    coverage: CountRaster | None
    report: dict[str, Any]
    rules: list[dict[str, Any]]
    aim: Aim | None = None  # each event's planned gimbal aim (with a plan)
    record: PhotoFlight | None = None  # the photos, when the flight record is a folder of them
    mission: MissionCheck | None = None  # the log's mission against the plan's (with a plan)


def _local_xy(lon: np.ndarray, lat: np.ndarray, lat0: float) -> np.ndarray:
    k = math.pi / 180.0
    return np.column_stack([np.asarray(lon, float) * k * math.cos(lat0 * k) * _EARTH_M, np.asarray(lat, float) * k * _EARTH_M])


def nearest_station(lon: np.ndarray, lat: np.ndarray, stations: Stations) -> tuple[np.ndarray, np.ndarray]:
    """(metres to, index of) the nearest planned station of each position (WGS84); NaN and -1 for
    positions that are not numbers."""
    lon, lat = np.asarray(lon, float), np.asarray(lat, float)
    dist, index = np.full(len(lon), np.nan), np.full(len(lon), -1)
    ok = np.isfinite(lon) & np.isfinite(lat)
    sok = np.flatnonzero(np.isfinite(stations.lon) & np.isfinite(stations.lat))
    if not ok.any() or not len(sok):
        return dist, index
    lat0 = float(np.mean(stations.lat[sok]))
    tree = cKDTree(_local_xy(stations.lon[sok], stations.lat[sok], lat0))
    d, k = tree.query(_local_xy(lon[ok], lat[ok], lat0))
    dist[ok], index[ok] = d, sok[k]
    return dist, index


def distance_text(m: float) -> str:
    return f"{m / 1000:,.1f} km" if m >= 10_000 else f"{m:.0f} m"


def far_from_plan(lon: np.ndarray, lat: np.ndarray, doc: Manifest) -> tuple[float, float]:
    """(median metres from the positions to the nearest planned station, the limit: one footprint's longer side)."""
    d, _ = nearest_station(lon, lat, doc.stations)
    fin = d[np.isfinite(d)]
    return (float(np.median(fin)) if fin.size else math.nan), (doc.derived.footprint_m or 100.0)


def sortie_flown(ev: Events, doc: Manifest) -> tuple[str | None, int]:
    """The sortie whose stations most events lie nearest to, and how many do."""
    _, index = nearest_station(ev.lon, ev.lat, doc.stations)
    of = np.full(len(doc.stations), -1)
    for k, s in enumerate(doc.sorties):
        of[doc.stations.index(s.first_station): doc.stations.index(s.last_station) + 1] = k
    votes = of[index[index >= 0]]
    votes = votes[votes >= 0]
    if not votes.size:
        return None, 0
    best = int(np.bincount(votes).argmax())
    return doc.sorties[best].id, int(np.sum(votes == best))


def planned_missions(doc: Manifest) -> tuple[list[PlannedMission], list[str], list[str]]:
    """(the plan folder's missions, the files missing, those changed since `aerosurvey plan` wrote
    them): each sortie's .plan, and the whole mission's (`Manifest.mission_files`)."""
    from aerosurvey.mission.formats.qgc_plan import loads_plan

    folder = Path(doc.where).parent
    found, missing, changed = [], [], []
    for sortie, file in doc.mission_files():
        path = folder / file
        if not path.is_file():
            missing.append(file)
            continue
        if doc.outputs.get(file) not in (None, sha256_file(path)):
            changed.append(file)
        found.append(planned_mission(sortie, file, loads_plan(path.read_text(encoding="utf-8"), str(path))))
    return found, missing, changed


def mission_check(flight_log: Path, doc: Manifest) -> MissionCheck:
    """The mission the log records against the plan folder's missions (`compare_mission`)."""
    return compare_mission(logged_mission(flight_log), doc)


def logged_mission(flight_log: Path) -> MissionRecord | None:
    """The mission a flight log records (`mission_log.read_mission`); None for a folder of photos."""
    return None if flight_log.is_dir() else read_mission(flight_log)


def compare_mission(record: MissionRecord | None, doc: Manifest) -> MissionCheck:
    """The mission a log records (`logged_mission`) against the plan folder's missions
    (`mission_flown.recognise`); a folder of photos (None) records none (a DJI flight's photos do
    not carry the mission)."""
    if record is None:
        return not_compared(NOT_RECORDED, "", "a folder of photos records no mission")
    flown = record.flown
    if flown is None:
        return not_compared(NOT_RECORDED, record.source, record.note)
    note = record.note + (f"; {record.superseded} mission(s) recorded before it were replaced before the first photo"
                          if record.superseded else "")
    candidates, missing, changed = planned_missions(doc)
    if not candidates:
        return not_compared(NOT_COMPARED, record.source, f"the plan folder has no mission file ({', '.join(missing)}) to "
                            f"compare the log's mission with ({note})", len(flown.items), flown.total)
    if missing:
        note += f"; {', '.join(missing)} not in the plan folder, not compared"
    if changed:
        note += f"; {', '.join(changed)} changed since `aerosurvey plan` wrote it (sha256 not the manifest's): compared as it is"
    return recognise(candidates, flown.items, flown.complete, flown.total, [(m.at, m.items) for m in record.later],
                     record.autopilot, record.stored, doc.mission.vehicle == "plane", record.source, note, doc.mission.name,
                     np.column_stack([doc.stations.lat, doc.stations.lon]))


def check_same_plan(ev: Events, view: PlanView, log_name: str, sortie: str | None) -> float:
    """The median distance of the events to the nearest planned station. A log whose events lie
    farther than one footprint (the longer side) is of another mission, and one whose events lie
    mostly nearest another sortie's stations than `sortie`'s is of that sortie: both refused."""
    doc = view.document
    med, limit = far_from_plan(ev.lon, ev.lat, doc)
    what = f"mission {doc.mission.name!r}"
    if not math.isfinite(med):
        raise InputError(f"flight log {log_name!r}: none of its {len(ev)} camera events has a position, so it cannot be "
                         f"matched to {what} of {doc.where}")
    if med > limit:
        raise InputError(f"flight log {log_name!r} is not of {what} ({doc.where}): its camera events lie a median "
                         f"{distance_text(med)} from the nearest planned station, more than one footprint ({limit:.0f} m); "
                         "give the plan folder of the mission flown")
    if sortie is not None:
        flown, votes = sortie_flown(ev, doc)
        if flown is not None and flown != sortie and votes > len(ev) / 2:
            raise InputError(f"flight log {log_name!r} is not of --sortie {sortie} of {what}: {votes} of its {len(ev)} "
                             f"camera events lie nearest the stations of sortie {flown}; give --sortie {flown}", key="--sortie")
    return med


def recorded_aims(ev: Events, stations: Stations, crs: str) -> Aims | None:
    """The stations' aims and the events' recorded ones on the planning grid, when the events record their
    camera's own attitude (a photo flight's gimbal, Events.camera_attitude); else None."""
    if not ev.camera_attitude:
        return None
    grid = planar(crs)
    x, y = grid.xy(ev.lon, ev.lat)
    return Aims(np.asarray(stations.pitch_deg, float), np.asarray(stations.camera_yaw_deg, float),
                np.asarray(ev.pitch, float), np.asarray(grid.grid_bearing(ev.yaw, x, y), float))


def _dem_ground(dem_path: Path | None, view: PlanView | None) -> DemGround | None:
    if dem_path is None:
        return None
    if view is None:
        raise InputError(f"--dem {str(dem_path)!r}: heights above the DEM are used for the flown footprints, "
                         "which need the plan: give --plan too", key="--dem")
    return DemGround(dem_path, view.crs)


@dataclass(frozen=True)
class Read:
    """A flight record as read, before it meets the plan: its camera events, the flight mode at
    each, the photos when the record is a folder of them, the images matched when given, and
    log_report.json's first fields."""

    events: Events
    mode: list[str | None]
    record: PhotoFlight | None
    images: ImageMatch | None
    report: dict[str, Any]


def ingest(flight_log: Path, view: PlanView | None = None, *, sortie: str | None = None, tolerance_m: float | None = None,
           fixed_camera: bool = False, dem_path: Path | None = None, images_dir: Path | None = None,
           progress: Progress | None = None) -> Ingested:
    """Camera events of `flight_log`; with the plan's `view`, their match to its stations and the flown coverage.

    `progress` hears of each stage (the planner's signature: stage name, share done)."""
    report_progress = progress or no_progress
    if dem_path is not None and view is None:
        _dem_ground(dem_path, view)
    if sortie is not None and view is None:
        raise InputError(f"--sortie {sortie!r}: a sortie is of a plan; give --plan too", key="--sortie")
    if sortie is not None and view is not None:
        view.document.sortie(sortie)  # an unknown sortie is refused before the log is read
    read = read_record(flight_log, view.document.mission.vehicle if view is not None else None, images_dir=images_dir,
                       fixed_camera=fixed_camera, progress=report_progress)
    if view is None:
        return Ingested(read.events, read.mode, None, read.images, None, None, read.report, [], record=read.record)
    return against_plan(flight_log, read, view, mission_check(flight_log, view.document), sortie, tolerance_m=tolerance_m,
                        fixed_camera=fixed_camera, dem_path=dem_path, progress=report_progress)


def against_plan(flight_log: Path, read: Read, view: PlanView, mission: MissionCheck, sortie: str | None = None, *,
                 tolerance_m: float | None = None, fixed_camera: bool = False, dem_path: Path | None = None,
                 progress: Progress = no_progress) -> Ingested:
    """A record read (`read_record`) and its mission compared (`compare_mission`) matched to the plan as
    `ingest` matches it: refused when of another sortie than `sortie` or of another plan (`check_same_plan`),
    else `on_plan` with the sortie its mission names (else `sortie`; neither, a mission flying part of the plan: the
    stations its photos lie nearest)."""
    if mission.names_sortie and sortie is not None and mission.sortie != sortie:
        of = f"sortie {mission.sortie}'s" if mission.sortie else "the whole mission's"
        raise InputError(f"flight log {flight_log.name!r} is not of --sortie {sortie}: the mission its vehicle was given is {of} "
                         f"({mission.comparison.planned.file if mission.comparison else '?'}); give "
                         + (f"--sortie {mission.sortie}" if mission.sortie else "no --sortie"), key="--sortie")
    median = check_same_plan(read.events, view, flight_log.name, sortie)
    named = mission.sortie if mission.names_sortie else sortie
    # a mission flying part of the plan (a resumed one) may begin farther into it than the matcher's window reaches
    return on_plan(flight_log, read, view, mission, named, median, tolerance_m=tolerance_m, fixed_camera=fixed_camera,
                   dem_path=dem_path, nearest_only=named is None and mission.flies_part_of_plan, progress=progress)


def read_record(flight_log: Path, vehicle: str | None, *, images_dir: Path | None = None, fixed_camera: bool = False,
                progress: Progress = no_progress) -> Read:
    """Read a flight record (a log, or a folder of photos) and the images given with it; nothing is matched to the plan.
    `vehicle` (the plan's: copter or plane; None without a plan) names the flight modes of a log that does not say."""
    progress("reading the log", 0.0)
    record = None
    if flight_log.is_dir():
        photo_flight_options(flight_log, images_dir, fixed_camera)
        record = read_photo_flight(flight_log, lambda stage, done: progress(stage, 0.4 * done))
        ev, info = record.events, record.read
    else:
        ev, info = read_events(flight_log)
    progress("camera events read", 0.4)
    report: dict[str, Any] = {"log": flight_log.name, "events": len(ev), "source": ev.source, "read": info}
    modes = read_modes(flight_log, vehicle)
    mode = modes.at(ev.time_s)
    report["modes"] = modes_report(modes, mode)
    img = None
    if record is not None:
        report["photos"] = dict(record.report)
        img = ImageMatch(list(record.files), list(range(len(record))), "the photos are the flight record", None, [], [])
    if images_dir is not None:
        img = match_images(list_images(images_dir), ev)
        report["images"] = {"files": len(img.files), "method": img.method, "clock_offset_s": img.offset_s,
                            "unmatched_files": img.unmatched_files, "unmatched_events": img.unmatched_events}
    return Read(ev, mode, record, img, report)


def on_plan(flight_log: Path, read: Read, view: PlanView, mission: MissionCheck, sortie: str | None, median: float, *,
            tolerance_m: float | None = None, fixed_camera: bool = False, dem_path: Path | None = None,
            nearest_only: bool = False, progress: Progress = no_progress) -> Ingested:
    """The record's events matched to the stations of `sortie` (None: every station; with
    `nearest_only`, the plan's stations some event lies nearest, whatever their sortie: a record
    of a day of flights recognised by its photos, whose photos the matcher's window of stations
    in flight order might not reach), the flown
    footprints, figures, rules and coverage; `mission` is what the log's mission says (`mission_check`),
    `median` the events' median distance to the plan's stations (`check_same_plan`)."""
    doc = view.document
    ev, record, report = read.events, read.record, dict(read.report)
    if record is not None:
        report["photos"] = dict(report["photos"])
    report["mission"] = mission.as_dict()
    stations = doc.sortie_stations(sortie)
    if nearest_only:
        _, nearest = nearest_station(ev.lon, ev.lat, doc.stations)
        stations = doc.stations.take(np.unique(nearest[nearest >= 0]))
    tol = tolerance_m if tolerance_m is not None else doc.derived.photo_base_m / 4
    rows = [{"id": sid, "lon": lon, "lat": lat} for sid, lon, lat in zip(stations.ids, stations.lon.tolist(), stations.lat.tolist())]
    match = match_to_stations(ev, rows, tol, unmatched=on_the_ground(ev.rel_alt_m, stations.alt_rel_m),
                              aims=recorded_aims(ev, stations, view.crs))
    progress("flown footprints and overlaps", 0.55)
    report["plan"] = {"mission": doc.mission.name, "folder": doc.where, "sortie": sortie, "median_distance_m": round(median, 3)}
    report.update({"planned": len(stations), "matched": len(ev) - len(match.extra), "missed_stations": match.missed,
                   "extra_triggers": match.extra, "far_triggers": match.far, "tolerance_m": tol,
                   "max_distance_m": float(max((d for d in match.distance_m if d == d), default=0.0))})
    dem = _dem_ground(dem_path, view)
    try:
        if record is not None:
            ev, report["photos"]["rel_alt_from_dem_at_home"] = heights_above_take_off(ev, dem, doc, view.crs, flight_log)
        photos = flown_photos(view.crs, dict(zip(doc.stations.ids, doc.stations.run)), ev, match, fixed_camera, dem)
        report["heights"] = heights_summary(photos, ev, dem, doc.home, view.crs, fixed_camera)
    finally:
        if dem is not None:
            dem.close()
    report["extras"] = extras_summary(photos.run, ev.rel_alt_m, ev.lon, ev.lat)
    figures = flown_figures(view, flown_view(view, photos))
    report["realized"] = figures.realized
    if figures.profiles:
        report["rules_on_flown_data"] = figures.rules
    progress("flown coverage", 0.8)
    assert figures.coverage is not None
    report["coverage"] = figures.coverage.summary
    progress("done", 1.0)
    records.report_document(report)  # a report that does not match its schema is a bug: found before writing
    return Ingested(ev, read.mode, match, read.images, photos, figures.coverage, report, figures.rules, planned_aim(view, photos),
                    record, mission)


@dataclass(frozen=True)
class Figures:
    """What the flown photos (a view of the plan with them in place of its stations) measure: the
    realized overlaps and GSD, the plan's rules on them (none without a profile) and the photo-count raster."""

    profiles: list[Any]
    realized: dict[str, Any]
    rules: list[dict[str, Any]]
    coverage: CountRaster | None


def flown_figures(view: PlanView, flown: PlanView, coverage: bool = True) -> Figures:
    """The flown photos' footprints and overlaps, measured once for the figures, the rules and the
    coverage (none unless `coverage`); the plan's control points seen by the flown photos."""
    doc = view.document
    profiles = apply_overrides(select_profiles(list(doc.mission.profiles)), dict(doc.rule_overrides)) \
        if doc.mission.profiles else []
    evidence = on_view(plan_evidence(view, profiles, Path(doc.where).parent), flown) if profiles \
        else Evidence(flown, LayoutSettings())
    fwd = evidence.forward_overlaps
    side = evidence.side_overlaps
    gsd = doc.camera.gsd_cm(flown.agl, flown.pitch_deg)
    realized = {
        "forward_overlap_min": min((v for _, v in fwd), default=None),
        "side_overlap_min": min((v for _, _, v in side), default=None),
        "gsd_cm_min": float(np.nanmin(gsd)) if np.isfinite(gsd).any() else None,
        "gsd_cm_max": float(np.nanmax(gsd)) if np.isfinite(gsd).any() else None,
    }
    rules = [dict(r.as_dict()) for r in evaluate(profiles, evidence)] if profiles else []
    raster = count_raster(flown, evidence.footprints, max(doc.derived.photo_base_m / 5, 0.5)) if coverage else None
    return Figures(profiles, realized, rules, raster)


def photo_flight_options(folder: Path, images_dir: Path | None, fixed_camera: bool, geotag: bool = False) -> None:
    """A folder of photos is the flight record: the photos are the events (nothing to match them
    to or tag them with), and each records its camera's own attitude (nothing fixed to the body
    to apply). Options that say otherwise are refused."""
    if geotag:
        raise InputError(f"--geotag-copies / --geotag-in-place: the photos of {str(folder)!r} are the flight record and "
                         "carry their positions already; geotagging tags a log's matched images", key="--geotag-copies")
    if images_dir is not None:
        raise InputError(f"--images {str(images_dir)!r}: the flight record {str(folder)!r} is a folder of photos, which "
                         "are the camera events themselves; --images matches a log's events to photos", key="--images")
    if fixed_camera:
        raise InputError(f"--fixed-camera: the photos of {str(folder)!r} record their camera's own attitude (a gimbal's "
                         "angles, or straight down); --fixed-camera applies a log's vehicle attitude", key="--fixed-camera")


def heights_above_take_off(ev: Events, dem: DemGround | None, doc: Manifest, crs: str, folder: Path) -> tuple[Events, int]:
    """(the events, how many took it) with a height above take-off for each photo that records
    only its altitude (a camera without DJI's RelativeAltitude): its altitude minus the DEM's
    ground at the plan's home. Without a DEM, or where the DEM has no ground there, InputError."""
    missing = ~np.isfinite(ev.rel_alt_m) & np.isfinite(ev.alt_m)
    if not missing.any():
        return ev, 0
    where = (f"{int(missing.sum())} of the {len(ev)} photos of {str(folder)!r} record their altitude but no height "
             "above the take-off point (DJI's RelativeAltitude)")
    if dem is None:
        raise InputError(f"{where}: give --dem, the terrain under the flight (their heights above ground are their "
                         "altitude minus the DEM's ground)", key="--dem")
    ground = math.nan
    if doc.home.lon is not None and doc.home.lat is not None:
        hx, hy = transformer("EPSG:4326", crs).transform(doc.home.lon, doc.home.lat)
        ground = float(dem(np.array([hx]), np.array([hy]))[0])
    if not math.isfinite(ground):
        raise InputError(f"{where}, and --dem {dem.path.name!r} has no ground at the plan's home "
                         f"({doc.home.lon}, {doc.home.lat}) to take them from", key="--dem")
    rel = np.where(missing, ev.alt_m - ground, ev.rel_alt_m)
    return dataclasses.replace(ev, rel_alt_m=rel), int(missing.sum())


def event_columns(result: Ingested) -> dict[str, Any]:
    """The columns of events.csv."""
    ev, match, photos = result.events, result.match, result.photos
    n = len(ev)
    station = list(match.station) if match is not None else [None] * n
    dist = np.where([s is not None for s in station], match.distance_m, np.nan) if match is not None else np.full(n, np.nan)
    return {"event": np.arange(1, n + 1), "time_s": ev.time_s, "lat": ev.lat, "lon": ev.lon, "alt_m": ev.alt_m,
            "rel_alt_m": ev.rel_alt_m, "roll": ev.roll, "pitch": ev.pitch, "yaw": ev.yaw, "mode": result.mode, "station": station,
            "distance_m": dist, "ground_m": photos.ground_m if photos is not None else np.full(n, np.nan),
            "agl_m": photos.agl_m if photos is not None else np.full(n, np.nan)}


def write_ingest(result: Ingested, outdir: Path, *, accuracy_xy: float = 2.0, accuracy_z: float = 4.0,
                 fixed_camera: bool = False, geotag_dir: Path | None = None, geotag_in_place: bool = False) -> dict[str, Any]:
    """Write events.csv, log_report.json and coverage.tif (with a plan), and with images the
    camera poses for photogrammetry (geo.txt, pix4d_geolocation.csv, metashape_reference.csv:
    flight/handoff.py) into `outdir`, all or nothing; tag the images when asked. Returns the
    report as written."""
    with staged_directory(outdir) as stage:
        return write_record(result, stage, accuracy_xy=accuracy_xy, accuracy_z=accuracy_z, fixed_camera=fixed_camera,
                            geotag_dir=geotag_dir, geotag_in_place=geotag_in_place)


def write_record(result: Ingested, folder: Path, *, accuracy_xy: float = 2.0, accuracy_z: float = 4.0,
                 fixed_camera: bool = False, geotag_dir: Path | None = None, geotag_in_place: bool = False) -> dict[str, Any]:
    """The files of :func:`write_ingest` into `folder`, a staging folder (or one inside it); returns the report as written."""
    report = dict(result.report)
    events_text = records.dumps_events(event_columns(result))
    folder.mkdir(parents=True, exist_ok=True)
    if result.coverage is not None:
        write_count_raster(folder / "coverage.tif", result.coverage)
    atomic_write_text(folder / "events.csv", events_text)
    if result.images is not None:
        rec = result.record
        std = np.column_stack([rec.std_lon_m, rec.std_lat_m, rec.std_hgt_m]) if rec is not None else None
        poses = camera_poses(result.images, result.events, fixed_camera, result.aim, std)
        for name, write in (("geo.txt", geo_txt), ("pix4d_geolocation.csv", pix4d_csv),
                            ("metashape_reference.csv", metashape_csv)):
            atomic_write_text(folder / name, write(poses, accuracy_xy, accuracy_z))
        if geotag_dir is not None:
            report["geotag"] = {**geotag_images(result.images, result.events, geotag_dir), "in_place": geotag_in_place}
    atomic_write_text(folder / "log_report.json", records.dumps_report(report))
    return records.report_document(report)


def geotag_destination(images_dir: Path | None, geotag_dir: Path | None, in_place: bool) -> Path | None:
    """Where geotagged JPEGs go; the originals' folder only when --geotag-in-place says so."""
    if geotag_dir is None and not in_place:
        return None
    option = "--geotag-in-place" if geotag_dir is None else f"--geotag-copies {str(geotag_dir)!r}"
    if images_dir is None:
        raise InputError(f"{option}: geotagging needs the images; give --images too", key="--images")
    if in_place:
        if geotag_dir is not None and not _same_folder(geotag_dir, images_dir):
            raise InputError(f"--geotag-copies {str(geotag_dir)!r} with --geotag-in-place: in place means into the "
                             f"--images folder {str(images_dir)!r}; give one of the two options", key="--geotag-copies")
        return images_dir
    assert geotag_dir is not None
    if _same_folder(geotag_dir, images_dir):
        raise InputError(f"--geotag-copies {str(geotag_dir)!r} is the --images folder {str(images_dir)!r}: the originals are never "
                         "overwritten by copies; give another folder, or --geotag-in-place to tag the originals "
                         "themselves", key="--geotag-copies")
    return geotag_dir


def _same_folder(a: Path, b: Path) -> bool:
    if a.exists() and b.exists():
        return a.samefile(b)
    return a.resolve() == b.resolve()
