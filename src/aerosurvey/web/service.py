"""What the web page asks of the library, without HTTP: specs as JSON, a plan with its
files and map layers, area uploads, flown results.

The page never plans by itself: every number it shows comes from the same functions the
CLI calls (`parse_spec`, `plan_mission`, `render_outputs`, the rule engine), so a mission
downloaded from the page is byte for byte the one `aerosurvey plan` writes.
"""

from __future__ import annotations

import copy
import dataclasses
import datetime as dt
import io
import json
import tomllib
import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey import manifest as mf
from aerosurvey.errors import InputError
from aerosurvey.plan.pattern import PATTERNS, kind_of
from aerosurvey.report.summary import summary_json
from aerosurvey.web.mapproj import MapFrame

if TYPE_CHECKING:
    from aerosurvey.outputs import Rendered
    from aerosurvey.plan.inputs import PlanInputs
    from aerosurvey.plan.planner import Plan
    from aerosurvey.rules.planview import PlanView
    from aerosurvey.spec import MissionSpec
    from aerosurvey.web.vehicle import VehicleLink

#: Spec keys that name files; the page may only point them inside the allowed folders.
PATH_KEYS = (("area", "file"), ("terrain", "dem"))
AREA_SUFFIXES = (".geojson", ".json", ".kml", ".kmz", ".gpkg", ".zip", ".shp", ".fgb", ".gml", ".wkt")


def spec_to_json(data: dict[str, Any]) -> dict[str, Any]:
    """A TOML spec as JSON: dates and times become ISO 8601 text (the spec accepts both)."""

    def conv(v: Any) -> Any:
        if isinstance(v, dict):
            return {k: conv(x) for k, x in v.items()}
        if isinstance(v, list):
            return [conv(x) for x in v]
        if isinstance(v, (dt.datetime, dt.date, dt.time)):
            return v.isoformat()
        return v

    out: dict[str, Any] = conv(data)
    return out


def read_spec_file(path: Path) -> dict[str, Any]:
    try:
        return spec_to_json(tomllib.loads(path.read_text(encoding="utf-8")))
    except FileNotFoundError:
        raise InputError(f"mission spec {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"mission spec {str(path)!r} cannot be read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"mission spec {str(path)!r} is not valid TOML: {exc}") from None


def spec_to_toml(data: dict[str, Any]) -> str:
    """The spec as TOML text, tables in the documented order."""
    import tomli_w

    order = ["mission", "area", "pattern", "camera", "targets", "vehicle", "flight", "terrain", "battery", "conditions", "rules"]
    ordered = {k: data[k] for k in order if k in data}
    ordered.update({k: v for k, v in data.items() if k not in ordered})
    return tomli_w.dumps(_drop_none(ordered))


def _drop_none(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _drop_none(x) for k, x in v.items() if x is not None}
    if isinstance(v, list):
        return [_drop_none(x) for x in v]
    return v


@dataclass
class Workspace:
    """Where spec paths resolve (the spec's folder) and the only folders they may point into.

    Uploaded areas are not files here: they travel in the spec as WKT. `uploads` is scratch
    space for the flight results a page sends (a `log ingest` folder's files).
    """

    base: Path
    uploads: Path
    roots: list[Path] = field(default_factory=list)
    spec_file: Path | None = None  # the spec file the server was started with

    def file_of(self, spec: dict[str, Any], zones: list[str] | None) -> Path | None:
        """The spec file, when `spec` (without drawn zones) is what it holds now: its plan is then that of the file,
        whose manifest names it (`inputs.spec`, path and hash) as `aerosurvey plan` does; else None."""
        if self.spec_file is None or zones is not None:
            return None
        try:
            return self.spec_file if read_spec_file(self.spec_file) == spec else None
        except InputError:  # changed on disk since: the page's spec is not that file's
            return None

    def allowed(self, p: Path) -> bool:
        r = p.resolve()
        return any(r == root or root in r.parents for root in (x.resolve() for x in self.roots))

    def check_paths(self, spec: dict[str, Any]) -> None:
        """Refuse file paths outside the workspace: the page must not read arbitrary files."""
        for table, key in PATH_KEYS:
            v = (spec.get(table) or {}).get(key)
            if isinstance(v, str) and not self.allowed(self.resolve(v)):
                hint = " (or upload the area to this page)" if table == "area" else ""
                raise InputError(f"{table}.{key} = {v!r} is not allowed: a file in the mission's folder{hint}",
                                 key=f"{table}.{key}")
        ex = (spec.get("area") or {}).get("exclusions") or []
        if isinstance(ex, list):
            for v in ex:
                if isinstance(v, str) and not self.allowed(self.resolve(v)):
                    raise InputError(f"area.exclusions: {v!r} is not allowed: a file in the mission's folder",
                                     key="area.exclusions")

    def resolve(self, value: str) -> Path:
        p = Path(value)
        return p if p.is_absolute() else self.base / p


def default_spec(area: dict[str, Any], name: str) -> dict[str, Any]:
    """A new plan's spec: the defaults a pilot most often starts from."""
    return {
        "mission": {"name": name, "crs": "auto"},
        "area": area,
        "camera": {"model": "dji-phantom-4-rtk", "trigger": "distance"},
        "targets": {"gsd_cm": 2.5, "forward_overlap": 0.75, "side_overlap": 0.65},
        "vehicle": {"type": "copter", "cruise_speed_ms": 10.0},
        "flight": {"heading": "auto"},
        "rules": {"profiles": []},
    }


def with_new_area(spec: dict[str, Any], area: dict[str, Any], name: str) -> dict[str, Any]:
    """The current settings over a new area (the spec's `[area]` table): what belonged to the
    old place is dropped (exclusion zones, launch points, DEM, a national CRS)."""
    out = copy.deepcopy(spec) if spec else default_spec(area, name)
    out.setdefault("mission", {})["name"] = name
    out["mission"]["crs"] = "auto"
    out["area"] = dict(area)
    out.pop("terrain", None)
    kind = (out.get("pattern") or {}).get("kind")
    if isinstance(kind, str) and kind in PATTERNS and PATTERNS[kind].area_is_centreline:  # an area file holds polygons, not a centreline
        out.pop("pattern")
    if "battery" in out:
        out["battery"].pop("launch_points", None)
        out["battery"].pop("launch", None)
    return out


# ---- area uploads: read in memory, never stored --------------------------------------------

#: What an upload's archive (a zipped Shapefile, a KMZ) may unpack to in memory.
MAX_UNPACKED = 100 * 1024 * 1024
#: A Shapefile's own files: the ones of the .shp's name that GDAL reads.
SHAPEFILE_PARTS = (".shp", ".shx", ".dbf", ".prj", ".cpg")


@dataclass(frozen=True)
class UploadedArea:
    """An uploaded area, read as the planner reads an area file: the `[area]` table that holds it
    (WKT in WGS84, exact), and its bounds for a first look."""

    area: dict[str, Any]
    bounds: tuple[float, float, float, float]
    vertices: int


def read_uploaded_area(filename: str, data: bytes, max_wkt: int) -> UploadedArea:
    """An uploaded area file's bytes → the spec's `[area]` as exact WKT in WGS84.

    Parsed in memory by the loader's own parser (`read_area_data`); nothing is written to
    disk. The WKT travels in every plan request, so it may not exceed `max_wkt` characters.
    """
    from aerosurvey.area import read_area_data

    name = Path(filename).name or "area"
    try:
        geom = read_area_data(name, _dataset_files(name, data), f"area file {name}")
    except InputError as exc:  # the loader's message; the page shows it by the area's drop zone
        if exc.key is not None:
            raise
        raise InputError(str(exc), key="area.file") from None
    wkt = exact_wkt(geom)
    vertices = int(shapely.get_num_coordinates(geom))
    if len(wkt) > max_wkt:
        raise InputError(f"area upload {name!r}: {vertices} vertices make {len(wkt) / 1048576:.1f} MB of WKT; the page plans "
                         f"areas up to {max_wkt / 1048576:.1f} MB (half the upload limit): simplify the outline or plan "
                         "it with `aerosurvey plan`", key="area.file")
    x0, y0, x1, y1 = geom.bounds
    return UploadedArea({"wkt": wkt}, (x0, y0, x1, y1), vertices)


def _dataset_files(name: str, data: bytes) -> dict[str, bytes]:
    """The files of the upload's dataset by base name: the upload itself, the files of the one
    Shapefile in a .zip, or the .kml documents of a KMZ."""
    suffix = Path(name).suffix.lower()
    if suffix not in AREA_SUFFIXES:
        raise InputError(f"area upload {name!r} is not allowed: a GeoJSON, KML/KMZ, GeoPackage, FlatGeobuf, GML, WKT "
                         "or a Shapefile as .zip", key="area.file")
    if suffix == ".shp":
        raise InputError(f"area upload {name!r}: a Shapefile needs its .shx, .dbf and .prj files; upload them together "
                         "as a .zip", key="area.file")
    if suffix not in (".zip", ".kmz"):
        return {name: data}
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            members = [m for m in zf.infolist() if not m.is_dir()]
            for m in members:
                p = PurePosixPath(m.filename)
                if p.is_absolute() or ".." in p.parts:
                    raise InputError(f"area upload {name!r}: member {m.filename!r} points outside the archive", key="area.file")
            if suffix == ".kmz":
                wanted = [m for m in members if m.filename.lower().endswith(".kml")]
                if not wanted:
                    raise InputError(f"area upload {name!r}: a KMZ must hold a .kml document, found none", key="area.file")
            else:
                shp = [m for m in members if m.filename.lower().endswith(".shp")]
                if len(shp) != 1:
                    raise InputError(f"area upload {name!r}: a zipped Shapefile must hold exactly one .shp file, found "
                                     f"{len(shp)}", key="area.file")
                stem = shp[0].filename[:-4]
                wanted = [m for m in members if m.filename[:-4] == stem and m.filename[-4:].lower() in SHAPEFILE_PARTS]
            if sum(m.file_size for m in wanted) > MAX_UNPACKED:
                raise InputError(f"area upload {name!r}: unpacks to more than {MAX_UNPACKED // 1048576} MB", key="area.file")
            # base names at the root (a KMZ's documents flattened: GDAL's LIBKML driver reads them as one folder)
            return {m.filename.replace("/", "_") if suffix == ".kmz" else PurePosixPath(m.filename).name: zf.read(m)
                    for m in wanted}
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, EOFError) as exc:
        raise InputError(f"area upload {name!r} is not a valid zip archive: {exc}", key="area.file") from None


def exact_wkt(geom: BaseGeometry) -> str:
    """A polygon, a line or one of their multi forms as WKT that reads back to the same coordinates, bit for bit.

    GEOS's writer (shapely.to_wkt) keeps 16 significant digits (17 or 18 with
    rounding_precision): 1137 (126, 14) of 400 000 random longitudes and latitudes came back
    changed in their last bit, which would make a plan of an upload differ from the plan of
    its file. Python's float repr is the shortest text that reads back exactly.
    """

    def ring(r: Any) -> str:
        return "(" + ", ".join(f"{x!r} {y!r}" for x, y in shapely.get_coordinates(r).tolist()) + ")"

    def polygon(p: Any) -> str:
        return "(" + ", ".join(ring(r) for r in (p.exterior, *p.interiors)) + ")"

    if geom.geom_type == "Polygon":
        return "POLYGON " + polygon(geom)
    if geom.geom_type == "MultiPolygon":
        return "MULTIPOLYGON (" + ", ".join(polygon(p) for p in geom.geoms) + ")"
    if geom.geom_type == "LineString":
        return "LINESTRING " + ring(geom)
    if geom.geom_type == "MultiLineString":
        return "MULTILINESTRING (" + ", ".join(ring(p) for p in geom.geoms) + ")"
    raise ValueError(f"exact_wkt: a {geom.geom_type} is not an area or a centreline")


# ---- plans ---------------------------------------------------------------------------------

Progress = Callable[[str, float], None]


@dataclass
class PlanBundle:
    """A plan as the page shows it, and the files it offers for download.

    `files` are the text files, `binary` the others (a DJI camera's .kmz waylines). `manifest` and
    `plan_view` are its manifest.json and plan.geojson as read once when it was made, for the flight
    results, re-fly and resume asked of it later (None: a resumed flight, which has no manifest)."""

    view: dict[str, Any]
    files: dict[str, str]
    frame: MapFrame
    spec: dict[str, Any] = field(default_factory=dict)  # what was planned: the page's spec and drawn zones
    zones: list[str] | None = None
    manifest: mf.Manifest | None = None
    plan_view: PlanView | None = None
    binary: dict[str, bytes] = field(default_factory=dict)

    def names(self) -> list[str]:
        """Every file's name, sorted."""
        return sorted({*self.files, *self.binary})

    def data(self, name: str) -> bytes | None:
        """A file's bytes (text as UTF-8), or None when the plan has no such file."""
        if name in self.files:
            return self.files[name].encode("utf-8")
        return self.binary.get(name)


def drawn_zones(zones: list[str]) -> tuple[BaseGeometry, ...]:
    """Exclusion zones drawn on the page (WKT in WGS84), checked by the loader's own reader."""
    from aerosurvey.area import read_area

    try:
        return tuple(read_area(None, z, "EPSG:4326", f"exclusion zone {i} (drawn)") for i, z in enumerate(zones, start=1))
    except InputError as exc:
        raise InputError(str(exc), key="zones") from None


def spec_and_inputs(spec_data: dict[str, Any], ws: Workspace, zones: list[str] | None) -> tuple[MissionSpec, PlanInputs]:
    """The page's spec checked, and what planning reads: `zones` (WKT in WGS84), when given, are the
    exclusion zones drawn on the page, in place of the spec's zone files."""
    from aerosurvey.inputs import load_inputs
    from aerosurvey.spec import parse_spec

    if not isinstance(spec_data, dict):
        raise InputError("spec: expected a JSON object with the mission spec's tables")
    ws.check_paths(spec_data)
    spec = parse_spec(spec_data, base=ws.base, path=ws.file_of(spec_data, zones))
    if zones is not None and spec.area.exclusions:
        raise InputError("zones: drawn exclusion zones replace area.exclusions; send one or the other", key="zones")
    # an uploaded or drawn area is inline WKT: the loader parses it in memory and reads files only
    # for what the spec's folder holds (exclusion zone files, a DEM)
    inputs = load_inputs(spec)
    if zones is not None:
        inputs = dataclasses.replace(inputs, exclusions_wgs84=drawn_zones(zones))
    return spec, inputs


def plan_bundle(spec_data: dict[str, Any], ws: Workspace, progress: Progress, zones: list[str] | None = None) -> PlanBundle:
    """Plan the page's spec; `zones` (WKT in WGS84), when given, are the exclusion zones drawn on the
    page, handed to the planner in its PlanInputs in place of the spec's zone files."""
    from aerosurvey.outputs import render_outputs
    from aerosurvey.plan.planner import plan_mission

    spec, inputs = spec_and_inputs(spec_data, ws, zones)
    plan = plan_mission(spec, inputs, progress)
    progress("mission files and rules", 0.92)
    rendered = render_outputs(plan, spec)
    progress("control points", 0.97)
    files = dict(rendered.files)
    manifest, features, plan_view = plan_documents(files, "the page's plan")
    points, cp_files = _control_points(rendered, plan_view)
    files.update(cp_files)
    frame = MapFrame.around(plan.site.area_wgs84, plan.site.planar)
    view = _view(plan, frame, manifest, features, points, rendered)
    progress("done", 1.0)
    return PlanBundle(view, files, frame, copy.deepcopy(spec_data), zones, manifest, plan_view, dict(rendered.binary))


def bundle_brief(bundle: PlanBundle, ws: Workspace, at: dt.datetime, battery_change_min: float,
                 vehicle: VehicleLink | None = None) -> dict[str, Any]:
    """`aerosurvey brief` of the page's plan flown from `at`: its spec (and drawn zones) planned again for the window;
    with the server's `vehicle`, its checks as `aerosurvey brief --connect` makes them (web/vehicle.py)."""
    from aerosurvey.brief import brief_for
    from aerosurvey.plan.planner import plan_mission
    from aerosurvey.web.vehicle import brief_items

    if bundle.manifest is None:
        raise InputError("brief: a resumed flight has no plan of its own; brief the plan", key="brief")
    checks = brief_items(vehicle, bundle, ws.uploads) if vehicle is not None else []

    def replan(start: dt.datetime, end: dt.datetime) -> Any:
        window = {**(bundle.spec.get("conditions") or {}), "start": start.isoformat(), "end": end.isoformat()}
        return plan_mission(*spec_and_inputs({**bundle.spec, "conditions": window}, ws, bundle.zones))

    return brief_for(bundle.manifest.raw, at, battery_change_min, replan, checks).as_dict()


def plan_documents(files: dict[str, str], where: str) -> tuple[mf.Manifest, dict[str, Any], PlanView]:
    """A plan's manifest.json and plan.geojson (texts by name) read once: the typed manifest, the GeoJSON
    and the plan as the rules see it."""
    from aerosurvey.rules.planview import PlanView

    manifest = mf.loads(files["manifest.json"], where)
    features = json.loads(files["plan.geojson"])
    return manifest, features, PlanView.from_manifest(manifest, features, where)


def _control_points(rendered: Rendered, plan_view: PlanView) -> tuple[Any, dict[str, str]]:
    from aerosurvey.rules.cp_files import control_point_files
    from aerosurvey.rules.engine import Evidence, layout_settings

    ev = rendered.evidence
    if ev is None:
        ev = Evidence(plan_view, layout_settings(plan_view, []))
    return ev.points, control_point_files(ev.view, ev.points)


def _sortie_of_stations(manifest: mf.Manifest) -> list[int]:
    ids = manifest.stations.ids
    out = [0] * len(ids)
    index = {sid: i for i, sid in enumerate(ids)}
    for k, s in enumerate(manifest.sorties, start=1):
        for i in range(index[s.first_station], index[s.last_station] + 1):
            out[i] = k
    return out


def _view(plan: Plan, frame: MapFrame, manifest: mf.Manifest, features: dict[str, Any], points: Any,
          rendered: Rendered) -> dict[str, Any]:
    feats = features["features"]
    by_role: dict[str, list[dict[str, Any]]] = {}
    for f in feats:
        by_role.setdefault(f["properties"]["role"], []).append(f)
    sortie = _sortie_of_stations(manifest)
    st = plan.stations
    sx, sy = frame.from_lonlat(st.lon, st.lat)
    station_index = {sid: i for i, sid in enumerate(st.ids)}
    lines = []
    for f in by_role.get("line", []):  # a corridor's lines bend: every vertex of each
        lonlat = np.asarray(f["geometry"]["coordinates"], dtype=float)
        x, y = frame.from_lonlat(lonlat[:, 0], lonlat[:, 1])
        p = f["properties"]
        lines.append({"id": p["id"], "pass": p["pass"], "photos": p["photos"],
                      "sortie": sortie[station_index[p["first_station"]]],
                      "xy": [[_m(a), _m(b)] for a, b in zip(x, y, strict=True)]})
    launch = []
    for i, site in enumerate(plan.launch.sites, start=1):
        x, y = frame.from_lonlat(np.array([site.lon]), np.array([site.lat]))
        launch.append({"id": f"launch-{i}", "x": _m(x[0]), "y": _m(y[0])})
    rally = []
    for i, place in enumerate(plan.launch.rally, start=1):
        x, y = frame.from_lonlat(np.array([place.lon]), np.array([place.lat]))
        rally.append({"id": f"rally-{i}", "x": _m(x[0]), "y": _m(y[0])})
    fence = [frame.rings(shapely.Polygon([(lon, lat) for lat, lon in ring])) for ring in plan.launch.fence.inclusion]
    hx, hy = frame.from_lonlat(np.array([plan.launch.home[0]]), np.array([plan.launch.home[1]]))
    cps = []
    for p in points:
        lon, lat = plan.site.planar.lonlat(np.array([p.x / 1.0]), np.array([p.y / 1.0]))
        x, y = frame.from_lonlat(lon, lat)
        cps.append({"id": p.id, "role": p.role, "x": _m(x[0]), "y": _m(y[0]), "images": p.images, "note": p.note})
    rules = []
    for r in rendered.rules:
        where = []
        for w in r.get("where", []):
            if "xy" in w:
                lon, lat = plan.site.planar.lonlat(np.array([w["xy"][0]]), np.array([w["xy"][1]]))
                x, y = frame.from_lonlat(lon, lat)
                where.append({"xy": [_m(x[0]), _m(y[0])]})
            else:
                where.append(w)
        rules.append({**r, "where": where})
    return {
        "name": plan.name,
        "pattern": plan.pattern.kind,
        # a centreline's "area" (a corridor's) is its band around the centreline
        "area_is_centreline": kind_of(plan.pattern.kind).area_is_centreline,
        "frame": frame.as_dict(),
        "dem": plan.site.dem is not None,  # without one, launch points have no ground height (the manifest's 0 m)
        "profile": _profile(plan),  # the route over the terrain, None without a DEM
        "layers": {
            "area": [frame.rings(g) for g in _polygons(by_role.get("area", []))],
            "exclusions": [frame.rings(g) for g in _polygons(by_role.get("exclusion", []))],
            # required ground next to the zones fewer than two photos see (rule uncovered-ground)
            "uncovered": [frame.rings(g) for g in _polygons(by_role.get("uncovered", []))],
            "lines": lines,
            "stations": {"ids": st.ids, "x": [_m(v) for v in sx], "y": [_m(v) for v in sy], "sortie": sortie},
            "launch": launch,
            "rally": rally,  # the spec's rally points (every launch site is one too)
            "fence": fence,  # the geofence's inclusion polygon the mission files carry
            "home": {"x": _m(hx[0]), "y": _m(hy[0])},
            "control_points": cps,
        },
        "summary": summary_json(rendered.summary),  # the figures `plan` and `check` print
        "sorties": manifest.raw["sorties"],
        "rules": rules,
        "warnings": rendered.warnings,
    }


def _profile(plan: Plan) -> dict[str, Any] | None:
    """The whole mission's route over the DEM (mission/clearance.py's legs and heights) for the page's profile, with
    the height bands of the zones it crosses; None without a DEM."""
    site = plan.site
    if site.dem is None:
        return None
    from aerosurvey.mission.clearance import terrain_profile
    from aerosurvey.mission.program import flight_program
    from aerosurvey.plan.landing import PLANE_RTL_LOITER_M

    return terrain_profile(flight_program(plan), "mission", site.dem, site.planar, site.grid_scale, site.min_clearance_m,
                           PLANE_RTL_LOITER_M * site.grid_scale, zones=_profile_zones(plan)).record()


def _profile_zones(plan: Plan) -> list[Any]:
    """The exclusion zones (from the ground, no ceiling) and the official zones whose outlines reach into the plan's
    geofence (which holds everything flown), in the planning CRS."""
    import shapely

    from aerosurvey.airspace.outline import outlines_wgs84
    from aerosurvey.mission.clearance import ProfileZone

    site = plan.site
    zones = [ProfileZone("exclusion zone", "exclusion", g, "the surface to no ceiling") for g in _parts(site.zones)]
    if plan.airspace is not None:
        fence = shapely.MultiPolygon([shapely.Polygon([(lon, lat) for lat, lon in ring]) for ring in plan.launch.fence.inclusion])
        outlines = outlines_wgs84(plan.airspace.zones)
        for i in shapely.STRtree(outlines).query(fence, predicate="intersects"):
            z = plan.airspace.zones[int(i)]
            zones.append(ProfileZone(f"{z.label}, {z.restriction}", "official", site.planar.forward(outlines[int(i)]),
                                     z.band_text(), z.lower, z.upper))
    return zones


def _parts(geom: Any) -> list[Any]:
    if geom is None or geom.is_empty:
        return []
    return list(getattr(geom, "geoms", [geom]))


def _polygons(feats: list[dict[str, Any]]) -> list[Any]:
    import shapely.geometry

    out: list[Any] = []
    for f in feats:
        g = shapely.geometry.shape(f["geometry"])
        out.extend(g.geoms if g.geom_type == "MultiPolygon" else [g])
    return out


def _m(v: float) -> float:
    return round(float(v), 2)
