"""manifest.json: the record of a plan that every later step links to by id.

The one writer (:func:`build_manifest`, :func:`dumps`) and the one reader
(:func:`read_manifest`, :func:`loads`, :func:`from_data`) of the format. Its schema ships
with the package (data/manifest.schema.json); docs/manifest.md is generated from it.
Bump SCHEMA_VERSION (and the schema's `schema_version` const) on any incompatible change;
the reader refuses other versions and says what to do.

The manifest holds no time stamp and no absolute path, so the same spec and input files
give a byte-identical manifest.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aerosurvey import __version__, ids, schemas
from aerosurvey.camera import Camera
from aerosurvey.errors import InputError
from aerosurvey.jsontext import Column, rows_text, string_texts, table_text
from aerosurvey.plan import photogrammetry as pg

if TYPE_CHECKING:  # the writer's input; the reader does not need the planner
    from aerosurvey.airspace.check import AirspaceReport
    from aerosurvey.plan.passes import Pass
    from aerosurvey.plan.planner import Plan
    from aerosurvey.spec import MissionSpec

SCHEMA = "aerosurvey-manifest"
SCHEMA_VERSION = 3
#: The file name `aerosurvey plan` writes the manifest under.
FILE_NAME = "manifest.json"
#: The whole mission's QGroundControl plan (each sortie's is named by `ids.sortie_file_stem`)
WHOLE_MISSION_FILE = "mission.plan"


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _f(v: float, nd: int = 3) -> float | None:
    v = float(v)
    return None if not math.isfinite(v) else round(v, nd)


def _lonlats(plan: Plan, xys: list[tuple[float, float]]) -> list[list[float | None]]:
    """[lon, lat] of each planar point, rounded to 8 decimals (None if not finite): one
    transformation of them all (one a point cost ~60 µs of set-up each)."""
    if not xys:
        return []
    xy = np.asarray(xys, float).reshape(-1, 2)
    lon, lat = plan.site.planar.lonlat(xy[:, 0], xy[:, 1])
    return [[_f(a, 8), _f(b, 8)] for a, b in zip(lon.tolist(), lat.tolist())]


def sortie_record(plan: Plan, k: int, stem: str) -> dict[str, Any]:
    """Sortie k (from 1) as the manifest and resume.json record it, its files named `stem`.plan and
    .waypoints; with a [battery] table, also its wind allowance and battery use. Its mission items
    are those of its mission (home included), counted on the mission itself: PX4's leg split
    (mission/builder.py) adds waypoints the battery split does not count."""
    from aerosurvey.mission.builder import build_mission

    s, _wps = plan.sorties[k - 1]
    st, site = plan.stations, plan.launch.sites[s.launch]
    out: dict[str, Any] = {
        "id": ids.sortie_id(k), "files": [f"{stem}.plan", f"{stem}.waypoints"],
        "launch": {"index": s.launch + 1, "lon": _f(site.lon, 8), "lat": _f(site.lat, 8), "ground_amsl_m": _f(site.ground_m, 2)},
        "first_station": st.ids[s.first], "last_station": st.ids[s.last], "photos": s.last - s.first + 1,
        "time_s": _f(s.horizontal_s + s.vertical_s, 1), "distance_m": _f(s.distance_m, 1),
        "mission_items": len(build_mission(plan, k - 1).items) + 1,
    }
    budget = plan.battery
    if budget is not None and budget.reserve is not None:
        out["still_air_time_s"] = _f(s.still_air_s, 1)
        out["wind_used_pct"] = _f(100 * (s.battery_used - s.still_air_used), 1)
        out["battery_used_pct"] = _f(100 * s.battery_used * (1 - budget.reserve), 1)
        out["usable_used_pct"] = _f(100 * s.battery_used, 1)
    return out


def _sorties(plan: Plan) -> list[dict[str, Any]]:
    return [sortie_record(plan, k, ids.sortie_file_stem(k)) for k in range(1, len(plan.sorties) + 1)]


def _input(path: Path | None, base: Path) -> dict[str, Any] | None:
    if path is None:
        return None
    try:
        rel = path.resolve().relative_to(base.resolve()).as_posix()
    except ValueError:
        rel = path.name
    return {"path": rel, "sha256": sha256_file(path)}


def _gsd_cm(agl_m: np.ndarray, pitch_deg: np.ndarray, cam: Camera) -> np.ndarray:
    """GSD in cm at the image centre of photos taken at heights above ground with the camera at a pitch, by the
    photogrammetry module (`gsd_at_centre_m`: NaN for a level camera)."""
    return pg.gsd_at_centre_m(agl_m, pitch_deg, cam.pixel_pitch_mm, cam.focal_mm) * 100.0


def _run_id(plan: Plan, run: int) -> str:
    r = plan.route.runs[run]
    return ids.run_id(r.pass_index, r.line, r.part)


def _coverage(plan: Plan) -> dict[str, Any]:
    """The required ground and what of it next to the zones fewer than MIN_IMAGES photos see."""
    from aerosurvey.plan.coverage import MIN_IMAGES  # the writer's; the reader does not load the planner

    c = plan.coverage
    return {"min_images": MIN_IMAGES, "required_m2": round(c.required_m2, 1), "checked_m2": round(c.checked_m2, 1),
            "uncovered_m2": round(c.uncovered_m2, 2), "parts": c.parts}


#: the version of the manifest's `faces` record: a change of its fields bumps it
FACES_VERSION = 1


def _faces(plan: Plan) -> dict[str, Any] | None:
    """A structure's faces as the plan's photos see them (plan.faces, surfaces.FacesCheck), and the
    heights the photos are taken at: the figures a plan of a structure is judged by, where the
    nadir figures of `derived` (one height, the GSD on the ground) say nothing of its walls."""
    f = plan.faces
    if f is None:
        return None
    seen = f.coverage.images > 0
    gsd = f.coverage.finest_gsd_m[seen] * 100.0
    agl = plan.stations.agl_m
    return {"version": FACES_VERSION, "area_m2": round(f.coverage.area_m2, 2), "short_m2": round(f.short_m2, 2),
            "min_images": f.min_images, "fewest_images": int(f.coverage.images.min()) if len(f.coverage.images) else 0,
            "max_gsd_cm": None if f.max_gsd_m is None else _f(f.max_gsd_m * 100.0, 4),
            "gsd_cm": [_f(float(gsd.min()), 4), _f(float(gsd.max()), 4)] if len(gsd) else None,
            "station_agl_m": [_f(float(agl.min())), _f(float(agl.max()))] if len(agl) else None,
            "nadir_photos": int(np.count_nonzero(plan.stations.pitch_deg == -90.0))}


#: the version of the manifest's `airspace` record: a change of its fields bumps it (docs/airspace.md)
AIRSPACE_VERSION = 1


def airspace_record(report: AirspaceReport, spec: MissionSpec) -> dict[str, Any]:
    """The official zones the flights were checked against (airspace/check.py): the files, the authorisations, the
    planned window, and each zone near the flights with its verdict and the legs that meet it."""
    base = spec.path.parent if spec.path else Path(".")
    w = report.airspace.window
    return {"version": AIRSPACE_VERSION, "files": [_input(p, base) for p in spec.airspace.zones],
            "authorisations": list(report.airspace.authorisations),
            "window": None if w is None else {"start": w[0].isoformat(), "end": w[1].isoformat()},
            "zones_read": len(report.airspace.zones), "zones": report.manifest_zones(), "notes": list(report.notes)}


def run_stations(plan: Plan) -> list[tuple[int, int, int]]:
    """Each run's first and last station (their indexes) and how many it has. Stations are in
    flight order, so a stable sort by run keeps their order within a run: one sort, not a scan
    of every station for each run (~0.6 ms on the 1,000 ha plan's 64 runs). A run without
    stations is an IndexError, as its first station is not there."""
    n_runs = len(plan.route.runs)
    order = np.argsort(plan.stations.run, kind="stable").tolist()
    ends = np.cumsum(np.bincount(plan.stations.run, minlength=n_runs)).tolist()
    starts = [0, *ends[:-1]]
    if any(e == s for s, e in zip(starts[:n_runs], ends[:n_runs])):
        raise IndexError("a run has no stations")
    return [(order[s], order[e - 1], e - s) for s, e in zip(starts[:n_runs], ends[:n_runs])]


STATION_KEYS = ("id", "seq", "line", "x", "y", "lon", "lat", "ground_m", "alt_rel_m", "agl_m", "gsd_cm", "heading_deg",
                "pitch_deg", "camera_yaw_deg")


@dataclass(frozen=True)
class StationTable:
    """The manifest's stations as columns, one per STATION_KEYS, of plain JSON values."""

    columns: tuple[Column, ...]

    def rows(self) -> list[dict[str, Any]]:
        """The stations as the manifest's JSON rows."""
        return [dict(zip(STATION_KEYS, row)) for row in zip(*self.columns)]

    def text(self, sep: str) -> str:
        """The rows' JSON text, `sep` between them, as `dumps` writes rows (made from the columns)."""
        return table_text(STATION_KEYS, self.columns, sep)

    def column(self, key: str) -> Column:
        """The column of one of STATION_KEYS."""
        return self.columns[STATION_KEYS.index(key)]


def station_table(plan: Plan) -> StationTable:
    """The plan's stations as the manifest records them (rounded; None where a value is not
    finite). Its columns are `jsontext.Column`s: plan.geojson writes the ids,
    positions and heights from them too (`report.features.plan_geojson`), their texts made here,
    once for both files; the columns only the manifest writes get their texts from its writer."""
    st = plan.stations

    def col(a: np.ndarray, nd: int, geojson: bool = False) -> Column:
        r = np.round(np.asarray(a, float), nd)
        finite = np.isfinite(r)
        if finite.all():  # most columns: no per-value test
            return Column.of_array(r) if geojson else Column(r, kinds=frozenset({float}) if len(r) else frozenset())
        if not finite.any():  # the ground without a DEM
            return Column((None,) * len(r))
        return Column(None if not math.isfinite(v) else v for v in r.tolist())

    run_ids = [_run_id(plan, i) for i in range(len(plan.route.runs))]  # once a run, not once a station
    gsd_cm = _gsd_cm(np.asarray(st.agl_m, float), np.asarray(st.pitch_deg, float), plan.camera.camera)
    # the ids' JSON texts made here, once: plan.geojson writes them twice (feature id, property) and the manifest once
    return StationTable((Column(st.ids, string_texts(st.ids)), Column.of_array(np.arange(1, len(st.ids) + 1)),
                         Column.of_codes(run_ids, st.run),
                         col(st.x, 3), col(st.y, 3), col(st.lon, 8, True), col(st.lat, 8, True), col(st.ground_m, 2),
                         col(st.alt_rel_m, 2, True), col(st.agl_m, 2, True), col(gsd_cm, 3), col(st.heading_deg, 3, True),
                         col(st.pitch_deg, 2), col(st.camera_yaw_deg, 3)))


def _aim_extras(ps: Pass) -> dict[str, Any]:
    """A pass's aim and height beyond a pitch and a bearing, written only where they are set: a look
    turned from the flight (`turn_deg`), at a point (`look_at`, planning CRS), at an outline's nearest point
    (`look_at_outline`, its vertices), a raised pass (`rise_m`)."""
    out: dict[str, Any] = {}
    if ps.aim.turn_deg:
        out["turn_deg"] = _f(ps.aim.turn_deg)
    if ps.aim.point is not None:
        out["look_at"] = [_f(ps.aim.point[0]), _f(ps.aim.point[1])]
    if ps.aim.outline is not None:
        out["look_at_outline"] = [[_f(x), _f(y)] for x, y in ps.aim.outline]
    if ps.rise_m:
        out["rise_m"] = _f(ps.rise_m)
    return out


def _pattern(plan: Plan) -> dict[str, Any]:
    """The pattern and its parameters, and each pass's camera attitude and sensor solution."""
    from aerosurvey.plan.passes import look_pass
    from aerosurvey.plan.pattern import kind_of

    p = plan.pattern
    params = kind_of(p.kind).parameters(plan)
    trigger = _f(plan.sensor.trigger_distance_m) if plan.sensor.trigger_distance_m is not None else None
    # a pass shooting several aims at each station (`Pass.looks`): each look a pass of its own, as its stations' ids number it
    passes = [{"pass": look_pass(plan.route.runs, ps.index, j), "pitch_deg": aim.pitch_deg,
               "look_deg": _f(aim.bearing_deg) if aim.bearing_deg is not None else None, **_aim_extras(replace(ps, aim=aim)),
               **({"crab_deg": _f(c)} if (c := plan.crab_deg(ps)) is not None else {}),
               "footprint_across_m": _f(plan.sensor.across_m), "footprint_along_m": _f(plan.sensor.along_m),
               "line_spacing_m": _f(plan.sensor.spacing_m), "photo_base_m": _f(plan.sensor.base_m), "trigger_distance_m": trigger}
              for ps in plan.layout.passes if not ps.empty for j, aim in enumerate(ps.aims)]
    hover = plan.sensor.hover_s
    return {"kind": p.kind, "parameters": params, "hover_s": _f(hover) if hover is not None else None, "passes": passes}


def build_manifest(plan: Plan, spec: MissionSpec, mission_items: int, outputs: dict[str, str],
                   with_stations: bool = True) -> dict[str, Any]:
    """The manifest of `plan`, planned from `spec`, as plain JSON data. `outputs` maps each written file name to its sha256.
    Without `with_stations`, `stations` is left empty, for `dumps` to write from a StationTable."""
    if spec.name != plan.name:
        raise ValueError(f"build_manifest: the spec {spec.name!r} is not the one plan {plan.name!r} was made from")
    base = spec.path.parent if spec.path else Path(".")
    cam = plan.camera.camera
    st = plan.stations
    h = plan.sensor.heights
    lines = []
    ends = _lonlats(plan, [xy for r in plan.route.runs for xy in (r.lead_in_xy, r.end_xy)])
    bends = _lonlats(plan, [(float(x), float(y)) for r in plan.route.runs for x, y in r.bends_xy])
    bend_at = np.cumsum([0, *(len(r.bends_xy) for r in plan.route.runs)]).tolist()
    for i, (r, (first, last, photos)) in enumerate(zip(plan.route.runs, run_stations(plan))):
        lines.append({
            "id": _run_id(plan, i), "line": ids.line_id(r.pass_index, r.line), "pass": r.pass_index,
            "order": i + 1, "heading_deg": _f(r.heading_deg), "photos": photos,
            "first_station": st.ids[first], "last_station": st.ids[last],
            "lead_in": ends[2 * i],
            "end": ends[2 * i + 1],
            "bends": bends[bend_at[i]:bend_at[i + 1]],
        })
    stations = station_table(plan).rows() if with_stations else []
    inputs = {
        "spec": _input(spec.path, base) if spec.path else None,
        "area": _input(spec.area.file, base) if spec.area.file else {"wkt": spec.area.wkt, "crs": spec.area.wkt_crs},
        "exclusions": [_input(p, base) for p in spec.area.exclusions],
        "dem": _input(spec.terrain.dem, base),
    }
    return {
        "schema": SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "aerosurvey_version": __version__,
        "mission": {"name": plan.name, "vehicle": plan.vehicle.type, "firmware": plan.vehicle.firmware,
                    "profiles": list(spec.profiles)},
        "rule_overrides": dict(sorted(spec.rule_overrides.items())),
        "inputs": inputs,
        "crs": {"planning": plan.site.planar.name, "geographic": "EPSG:4326",
                "convergence_deg": _f(float(plan.site.planar.convergence_deg(*plan.launch.home_xy)), 6)},
        "camera": {"id": cam.id, "name": cam.name, "sensor_mm": [cam.sensor_width_mm, cam.sensor_height_mm],
                   "image_px": [cam.image_width_px, cam.image_height_px], "focal_mm": cam.focal_mm,
                   "pixel_pitch_um": _f(cam.pixel_pitch_um, 4), "mount": plan.camera.mount,
                   "gimbal": plan.camera.gimbal, "trigger": plan.camera.trigger, "min_cycle_s": plan.camera.min_cycle_s,
                   "exposure_s": plan.camera.exposure_s, "source": cam.source},
        "targets": {"gsd_cm": _f(plan.sensor.gsd_target_m * 100, 4), "forward_overlap": spec.targets.forward_overlap,
                    "side_overlap": spec.targets.side_overlap,
                    "images_beyond_boundary": spec.targets.images_beyond_boundary,
                    "coverage_margin_m": plan.layout.margin_m,
                    "max_height_agl_m": plan.vehicle.max_height_agl_m},
        "pattern": _pattern(plan),
        "derived": {
            "height_agl_m": _f(h.nominal_agl_m), "height_for_gsd_m": _f(h.target_agl_m),
            "lowest_agl_m": _f(h.spacing_agl_m), "highest_agl_m": _f(h.max_agl_m),
            "gsd_min_cm": _f(plan.sensor.gsd_min_m * 100, 4), "gsd_max_cm": _f(plan.sensor.gsd_max_m * 100, 4),
            "footprint_across_m": _f(plan.sensor.across_m), "footprint_along_m": _f(plan.sensor.along_m),
            "line_spacing_m": _f(plan.sensor.spacing_m), "photo_base_m": _f(plan.sensor.base_m),
            "trigger_distance_m": _f(plan.sensor.trigger_distance_m) if plan.sensor.trigger_distance_m is not None else None,
            "side_images_per_point": plan.sensor.side_images_per_point,
            "forward_images_per_point": plan.sensor.forward_images_per_point,
            "speed_ms": _f(plan.sensor.speed.speed_ms), "speed_reason": plan.sensor.speed.reason,
            "speed_limits_ms": {"cruise": _f(plan.sensor.speed.cruise_ms), "camera_cycle": _f(plan.sensor.speed.cycle_limit_ms),
                                "motion_blur": _f(plan.sensor.speed.blur_limit_ms)},
            "trigger_interval_s": _f(plan.sensor.trigger_interval_s) if plan.sensor.trigger_interval_s else None,
            "lead_in_m": _f(plan.sensor.lead_in_m), "turn_radius_m": _f(plan.sensor.turn_radius_m),
            "heading_deg": _f(plan.layout.heading_deg), "heading_chosen": plan.layout.heading_chosen,
            "cross_hatch": spec.flight.cross_hatch, "exclusion_margin_m": plan.site.margin_m,
            "route_strategy": list(plan.route.strategy),
            "altitude_frame": plan.altitudes.frame,
            "terrain": {"mode": h.mode, "ground_min_m": _f(h.ground_min_m) if h.ground_min_m is not None else None,
                        "ground_max_m": _f(h.ground_max_m) if h.ground_max_m is not None else None,
                        "fixed_alt_amsl_m": _f(h.fixed_alt_amsl_m) if h.fixed_alt_amsl_m is not None else None,
                        "tolerance_m": plan.altitudes.tolerance_m},
            "area_ha": _f(plan.site.area.area / 1e4, 4),
            "grid_scale": round(plan.site.grid_scale, 9),
            "fixed_yaw_deg": plan.launch.fixed_yaw_deg,
            "simplification": {"tolerance_m": _f(plan.site.simplification.tolerance_m, 4),
                               "area_vertices": list(plan.site.simplification.area_vertices),
                               "zone_vertices": list(plan.site.simplification.zone_vertices)},
            "bounds": {"min_width_m": _f(plan.bounds.min_width_m), "strips": plan.bounds.strips, "photos": plan.bounds.photos},
        },
        "home": {"lon": _f(plan.launch.home[0], 8), "lat": _f(plan.launch.home[1], 8), "ground_amsl_m": _f(plan.launch.home[2], 2)},
        "estimates": {k: (_f(v, 1) if k != "photos" else int(v)) for k, v in plan.estimates.items()},
        "conditions": plan.sun,
        "wind": None if plan.wind is None else dict(plan.wind),
        "sorties": _sorties(plan),
        "lines": lines,
        "stations": stations,
        "mission_items": mission_items,
        "outputs": dict(sorted(outputs.items())),
        "battery": None if spec.battery is None else {
            "usable_min": spec.battery.usable_min, "capacity_wh": spec.battery.capacity_wh,
            "cruise_power_w": spec.battery.cruise_power_w, "climb_power_w": spec.battery.climb_power_w,
            "reserve": spec.battery.reserve,
            "max_mission_items": spec.battery.max_mission_items},
        "warnings": list(plan.warnings),
        "coverage": _coverage(plan),
        **({} if plan.faces is None else {"faces": _faces(plan)}),
    }


def dumps(manifest: dict[str, Any], stations: StationTable | None = None) -> str:
    """JSON with one top-level key per line and one line or station per line: readable,
    diff-friendly, and written by json's C encoder (an `indent` would fall back to Python),
    rows of plain values by `jsontext.rows_text` (the same text, their numbers written faster).
    `stations`, if given, is written as the stations (their rows never made: most of the
    manifest's numbers), and `manifest["stations"]` must then be empty."""
    enc = json.JSONEncoder(ensure_ascii=False, allow_nan=False, separators=(", ", ": "))
    out = ["{\n"]  # pieces, joined once: the stations' rows, most of the text, are not copied before
    keys = list(manifest)
    for i, key in enumerate(keys):
        value = manifest[key]
        end = ",\n" if i < len(keys) - 1 else "\n"
        if key == "stations" and stations is not None:
            if value:
                raise ValueError("manifest dumps: stations given twice, as rows and as a table")
            rows = stations.text(",\n  ")
            out += [f"{enc.encode(key)}: [\n  ", rows, "\n]", end] if rows else [f"{enc.encode(key)}: []", end]
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            text = rows_text(value, ",\n  ")  # a column at a time
            rows = text if text is not None else ",\n  ".join(map(enc.encode, value))
            out += [f"{enc.encode(key)}: [\n  ", rows, "\n]", end]
        else:
            out += [f"{enc.encode(key)}: {enc.encode(value)}", end]
    out.append("}\n")
    return "".join(out)


# ---- the reader -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Mission:
    name: str
    vehicle: str
    firmware: str
    profiles: tuple[str, ...]


@dataclass(frozen=True)
class CameraInfo:
    id: str | None
    name: str
    sensor_mm: tuple[float, float]
    image_px: tuple[int, int]
    focal_mm: float
    pixel_pitch_um: float
    mount: str
    trigger: str
    min_cycle_s: float
    exposure_s: float
    source: str

    def model(self) -> Camera:
        """The camera as the photogrammetry functions take it."""
        return Camera(self.id or "manifest", self.name, self.sensor_mm[0], self.sensor_mm[1], self.image_px[0],
                      self.image_px[1], self.focal_mm, self.min_cycle_s, self.exposure_s, source=self.source)

    def gsd_cm(self, agl_m: np.ndarray, pitch_deg: np.ndarray) -> np.ndarray:
        """GSD (cm) at the image centre of photos at heights above ground with the camera at a pitch (`_gsd_cm`)."""
        return _gsd_cm(np.asarray(agl_m, float), np.asarray(pitch_deg, float), self.model())


@dataclass(frozen=True)
class Derived:
    """The derived figures consumers use; every other one is in `Manifest.raw["derived"]`."""

    height_agl_m: float | None
    footprint_across_m: float | None
    footprint_along_m: float | None
    line_spacing_m: float | None
    photo_base_m: float
    side_images_per_point: int
    forward_images_per_point: int
    area_ha: float | None
    grid_scale: float

    @property
    def images_per_point(self) -> int:
        return self.side_images_per_point * self.forward_images_per_point

    @property
    def footprint_m(self) -> float:
        """The longer side of the nominal footprint (ground metres)."""
        return float(max(self.footprint_across_m or 0.0, self.footprint_along_m or 0.0))


@dataclass(frozen=True)
class Home:
    lon: float | None
    lat: float | None
    ground_amsl_m: float | None


@dataclass(frozen=True)
class Sortie:
    id: str
    files: tuple[str, ...]
    first_station: str
    last_station: str
    photos: int
    time_s: float | None


@dataclass(frozen=True)
class Line:
    id: str  # run id P1-L003-R1
    line: str
    pass_index: int
    order: int
    heading_deg: float | None
    photos: int
    first_station: str
    last_station: str


def _col(rows: list[dict[str, Any]], key: str) -> np.ndarray:
    a = np.array([np.nan if r[key] is None else r[key] for r in rows], float)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Stations:
    """The planned photo stations in flight order, as read-only columns."""

    ids: tuple[str, ...]
    seq: np.ndarray
    run: tuple[str, ...]  # the run (line id) of each station
    x: np.ndarray  # planning CRS
    y: np.ndarray
    lon: np.ndarray
    lat: np.ndarray
    ground_m: np.ndarray  # NaN where null
    alt_rel_m: np.ndarray
    agl_m: np.ndarray
    gsd_cm: np.ndarray
    heading_deg: np.ndarray
    pitch_deg: np.ndarray  # the camera's (−90 straight down)
    camera_yaw_deg: np.ndarray  # the bearing the camera looks to

    def __len__(self) -> int:
        return len(self.ids)

    @classmethod
    def from_rows(cls, rows: list[dict[str, Any]]) -> Stations:
        seq = np.array([r["seq"] for r in rows], int)
        seq.setflags(write=False)
        return cls(tuple(r["id"] for r in rows), seq, tuple(r["line"] for r in rows),
                   *(_col(rows, k) for k in ("x", "y", "lon", "lat", "ground_m", "alt_rel_m", "agl_m", "gsd_cm", "heading_deg",
                                             "pitch_deg", "camera_yaw_deg")))

    def index(self, station: str) -> int:
        try:
            return self.ids.index(station)
        except ValueError:
            raise InputError(f"station {station!r} is not in the manifest") from None

    def select(self, first: int, last: int) -> Stations:
        """Stations first..last (indices, both included)."""
        sl = slice(first, last + 1)
        return Stations(self.ids[sl], self.seq[sl], self.run[sl], self.x[sl], self.y[sl], self.lon[sl], self.lat[sl],
                        self.ground_m[sl], self.alt_rel_m[sl], self.agl_m[sl], self.gsd_cm[sl], self.heading_deg[sl],
                        self.pitch_deg[sl], self.camera_yaw_deg[sl])

    def take(self, index: np.ndarray) -> Stations:
        """The stations at `index` (ascending indices: flight order kept)."""
        return Stations(tuple(self.ids[i] for i in index), self.seq[index], tuple(self.run[i] for i in index),
                        *(getattr(self, k)[index] for k in ("x", "y", "lon", "lat", "ground_m", "alt_rel_m", "agl_m",
                                                            "gsd_cm", "heading_deg", "pitch_deg", "camera_yaw_deg")))


@dataclass(frozen=True)
class Manifest:
    """A manifest read and checked against its schema; `raw` is the validated JSON data."""

    raw: Mapping[str, Any]
    where: str
    schema_version: int
    aerosurvey_version: str
    mission: Mission
    rule_overrides: Mapping[str, Any]
    crs: str  # the planning CRS
    camera: CameraInfo
    targets: Mapping[str, Any]
    derived: Derived
    home: Home
    estimates: Mapping[str, float]
    sorties: tuple[Sortie, ...]
    lines: tuple[Line, ...]
    stations: Stations
    mission_items: int
    outputs: Mapping[str, str]
    rules: tuple[Mapping[str, Any], ...]
    warnings: tuple[str, ...]
    wind: Mapping[str, float] | None = None  # the wind planned in (`wind`); None: still air, or a plan written before it

    def sortie(self, sortie_id: str) -> Sortie:
        found = next((s for s in self.sorties if s.id == sortie_id), None)
        if found is None:
            have = ", ".join(s.id for s in self.sorties) or "none (the plan is one mission)"
            raise InputError(f"--sortie {sortie_id!r} is not a sortie of {self.where}: it has {have}", key="--sortie")
        return found

    def mission_files(self) -> tuple[tuple[str | None, str], ...]:
        """(sortie id, its mission's .plan file) of each sortie, then (None, the whole mission's
        WHOLE_MISSION_FILE) unless the plan is one sortie: the flyable missions `aerosurvey plan` wrote."""
        files: list[tuple[str | None, str]] = [(s.id, s.files[0]) for s in self.sorties]
        return tuple(files if len(files) == 1 else [*files, (None, WHOLE_MISSION_FILE)])

    def sortie_stations(self, sortie_id: str | None) -> Stations:
        """The stations one sortie flies (all of them for None)."""
        if sortie_id is None:
            return self.stations
        s = self.sortie(sortie_id)
        return self.stations.select(self.stations.index(s.first_station), self.stations.index(s.last_station))


def from_data(data: Any, where: str, *, check: bool = True) -> Manifest:
    """Check parsed JSON data against the schema (name, version, then content) and type it.
    `check=False` skips the content check, for a manifest `build_manifest` has just made in
    this process (its output is checked against the schema by the tests): jsonschema then
    never loads while planning (~80 ms of start-up)."""
    if not isinstance(data, dict):
        raise InputError(f"{where} is not an aerosurvey manifest: a JSON {type(data).__name__}, not an object")
    if data.get("schema") != SCHEMA:
        raise InputError(f"{where} is not an aerosurvey manifest: schema = {data.get('schema')!r}, expected {SCHEMA!r}")
    version = data.get("schema_version")
    schemas.check_version(where, "manifest", version, SCHEMA_VERSION, "re-plan it with `aerosurvey plan SPEC -o DIR`",
                          str(data.get("aerosurvey_version", "?")))
    if check:
        schemas.check("manifest", data, where, "manifest", SCHEMA_VERSION)
    m, cam, d, h = data["mission"], data["camera"], data["derived"], data["home"]
    return Manifest(
        raw=data, where=where, schema_version=SCHEMA_VERSION, aerosurvey_version=data["aerosurvey_version"],
        mission=Mission(m["name"], m["vehicle"], m["firmware"], tuple(m["profiles"])),
        rule_overrides=data["rule_overrides"], crs=data["crs"]["planning"],
        camera=CameraInfo(cam["id"], cam["name"], (float(cam["sensor_mm"][0]), float(cam["sensor_mm"][1])),
                          (int(cam["image_px"][0]), int(cam["image_px"][1])), float(cam["focal_mm"]),
                          float(cam["pixel_pitch_um"]), cam["mount"], cam["trigger"], float(cam["min_cycle_s"]),
                          float(cam["exposure_s"]), cam["source"]),
        targets=data["targets"],
        derived=Derived(d["height_agl_m"], d["footprint_across_m"], d["footprint_along_m"], d["line_spacing_m"],
                        float(d["photo_base_m"]), int(d["side_images_per_point"]), int(d["forward_images_per_point"]),
                        d["area_ha"], float(d["grid_scale"])),
        home=Home(h["lon"], h["lat"], h["ground_amsl_m"]),
        estimates=data["estimates"],
        sorties=tuple(Sortie(s["id"], tuple(s["files"]), s["first_station"], s["last_station"], s["photos"], s["time_s"])
                      for s in data["sorties"]),
        lines=tuple(Line(r["id"], r["line"], r["pass"], r["order"], r["heading_deg"], r["photos"], r["first_station"],
                         r["last_station"]) for r in data["lines"]),
        stations=Stations.from_rows(data["stations"]),
        mission_items=data["mission_items"], outputs=data["outputs"],
        rules=tuple(data.get("rules", [])), warnings=tuple(data["warnings"]), wind=data.get("wind"),
    )


def loads(text: str | bytes, where: str) -> Manifest:
    """A manifest from its JSON text."""
    try:
        data = json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{where} is not valid JSON: {exc}") from None
    return from_data(data, where)


def manifest_path(path: str | Path, option: str = "--plan") -> Path:
    """The manifest file of a plan folder (or the file itself), or a one-line error."""
    p = Path(path)
    if p.is_dir():
        m = p / FILE_NAME
        if not m.is_file():
            raise InputError(f"{option} {str(p)!r} has no {FILE_NAME}: give the folder `aerosurvey plan` wrote", key=option)
        return m
    if not p.exists():
        raise InputError(f"{option} {str(p)!r} does not exist: give the folder `aerosurvey plan` wrote", key=option)
    return p


def read_manifest(path_or_folder: str | Path, option: str = "--plan") -> Manifest:
    """Read and check the manifest of a plan folder (or a manifest file)."""
    p = manifest_path(path_or_folder, option)
    try:
        text = p.read_bytes()
    except OSError as exc:
        raise InputError(f"{option} {str(p)!r} cannot be read: {exc.strerror}", key=option) from None
    return loads(text, str(p))
