"""An independent check of where an exported mission flies and what it leaves unphotographed.

It shares no code with the planner: it parses the QGC WPL 110 text and the QGroundControl
.plan JSON itself, takes the zones from the input files the test wrote and the camera from
the manifest's "camera" section, and rebuilds every leg the autopilot flies in a local
azimuthal equidistant projection centred at the area (metres). Only the horizontal path is
rebuilt; ArduPilot's rules as modelled here:

- home is the first line of the file (the launch point);
- NAV_TAKEOFF: a copter climbs vertically at home (its lat/lon are ignored); a plane climbs
  straight ahead along its take-off heading for alt / tan(pitch) metres (param1, 15° if 0)
  and then turns to the next waypoint. The take-off heading is not in the mission: it is
  taken as the bearing to the next waypoint (the pilot points the plane at it), so the path
  is home → climb-out point → next waypoint (a straight line when the waypoint lies beyond
  the climb-out). Turn radii are not modelled: legs are straight lines between points;
- NAV_WAYPOINT, NAV_SPLINE_WAYPOINT, NAV_LOITER_* and NAV_LAND fly straight from the
  current position to their point; lat = lon = 0 means "here" (the current position); a
  loiter with a radius adds its circle; NAV_LAND ends the flight;
- DO_LAND_START is a marker (no movement in a mission flown in sequence; the legs after it
  are labelled land-approach); DO_JUMP repeats;
- NAV_RETURN_TO_LAUNCH flies straight to the nearest of home and the .plan's rally points
  (ArduCopter, RALLY_INCL_HOME = 1; ArduPlane, 0: the nearest rally point when there is one)
  and ends the flight; a copter climbs to RTL_ALT first (vertical) and lands there, a plane
  loiters over it at `plane_loiter_radius_m` (ArduPlane WP_LOITER_RAD, default 60 m);
- a mission that runs out of items without RTL or LAND: a copter holds where it is, a plane
  returns to launch (as above).

`legs_inside_zones` gives every leg with its metres inside each zone (shapely intersection
length, with the zones shrunk by `tol_m` so that file rounding, 1e-8° ≈ 1 mm, on a route
that follows a zone's edge is not counted). `coverage_gaps` replays the camera trigger with
tests/independent_coverage.py (ArduPilot's distance trigger, footprints from the sensor)
and finds ground of the required area (the area minus the zones grown by the margin) seen
by fewer than `min_images` photos, and whether the plan reports it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import shapely

import independent_coverage as ic
from independent_qgc import uploaded_items

NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME = 16, 17, 18, 19
NAV_RTL, NAV_LAND, NAV_TAKEOFF, NAV_LOITER_TO_ALT, NAV_SPLINE_WAYPOINT = 20, 21, 22, 31, 82
NAV_VTOL_TAKEOFF, NAV_VTOL_LAND, DO_JUMP, DO_LAND_START = 84, 85, 177, 189
#: the radius parameter (index into param1..4) of the loiter commands
LOITER_RADIUS_PARAM = {NAV_LOITER_UNLIM: 2, NAV_LOITER_TURNS: 2, NAV_LOITER_TIME: 2, NAV_LOITER_TO_ALT: 1}
GOTO = {NAV_WAYPOINT, NAV_SPLINE_WAYPOINT, *LOITER_RADIUS_PARAM}


@dataclass(frozen=True)
class Item:
    seq: int
    frame: int
    command: int
    params: tuple[float, float, float, float]
    lat: float
    lon: float
    alt: float


@dataclass(frozen=True)
class Leg:
    file: str
    item: int  # the seq of the item that starts the leg (0 = home)
    kind: str  # climb-out, to-first (take-off to the first point), waypoint, loiter, land-approach, land, rtl, rtl-loiter, end-rtl
    path: shapely.LineString  # local metres
    inside_m: tuple[float, ...]  # metres inside each zone
    in_margin_m: float = 0.0  # metres inside the zones grown by the margin less 0.5 m (information: the docs promise it too)

    @property
    def worst_m(self) -> float:
        return max(self.inside_m, default=0.0)


@dataclass
class FileReport:
    file: str
    home: tuple[float, float]  # lon, lat
    home_zones: list[int]  # zones (0-based) the launch point lies in
    legs: list[Leg]
    fence_missing: list[int] = field(default_factory=list)  # zones the .plan's exclusion fence does not cover
    notes: list[str] = field(default_factory=list)  # rally points; how the .plan differs from the .waypoints

    @property
    def violations(self) -> list[Leg]:
        return [leg for leg in self.legs if leg.worst_m > 0.0]


def parse_wpl(text: str, source: str = "waypoints") -> tuple[Item, list[Item]]:
    """(home, items) of a QGC WPL 110 file: tab- or space-separated columns
    seq, current, frame, command, p1..p4, lat, lon, alt, autocontinue."""
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines or lines[0].split() != ["QGC", "WPL", "110"]:
        raise ValueError(f"{source}: not a QGC WPL 110 file (first line {lines[0] if lines else ''!r})")
    rows = []
    for n, ln in enumerate(lines[1:], start=2):
        cols = ln.split()
        if len(cols) != 12:
            raise ValueError(f"{source} line {n}: {len(cols)} columns, a WPL item has 12")
        v = [float(c) for c in cols]
        rows.append(Item(int(v[0]), int(v[2]), int(v[3]), (v[4], v[5], v[6], v[7]), v[8], v[9], v[10]))
    if not rows:
        raise ValueError(f"{source}: no home line")
    return rows[0], rows[1:]


class Local:
    """lon/lat <-> metres in an azimuthal equidistant projection centred at a point."""

    def __init__(self, lon: float, lat: float):
        crs = pyproj.CRS.from_proj4(f"+proj=aeqd +lat_0={lat} +lon_0={lon} +datum=WGS84 +units=m")
        self.fwd = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
        self.inv = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)

    def xy(self, lon: float, lat: float) -> tuple[float, float]:
        x, y = self.fwd.transform(lon, lat)
        return float(x), float(y)

    def geom(self, g: shapely.Geometry) -> shapely.Geometry:
        return shapely.transform(g, lambda a: np.column_stack(self.fwd.transform(a[:, 0], a[:, 1])))


def _circle(cx: float, cy: float, r: float) -> shapely.LineString:
    t = np.linspace(0, 2 * np.pi, 73)
    return shapely.LineString(np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)]))


def rebuild_legs(home: Item, items: list[Item], local: Local, vehicle: str,
                 rally: Sequence[tuple[float, float]] = (), plane_loiter_radius_m: float = 60.0,
                 max_steps: int = 100_000) -> list[tuple[int, str, shapely.LineString]]:
    """(item seq, kind, horizontal path in metres) of every leg flown, in order."""
    hx, hy = local.xy(home.lon, home.lat)
    pos = (hx, hy)
    rally_xy = [local.xy(lon, lat) for lon, lat in rally]
    # ArduCopter counts home among the rally points (RALLY_INCL_HOME = 1), ArduPlane does not (0)
    targets = rally_xy if rally_xy and vehicle == "plane" else [(hx, hy), *rally_xy]
    legs: list[tuple[int, str, shapely.LineString]] = []
    takeoff: Item | None = None
    jumps: dict[int, int] = {}
    by_seq = {it.seq: k for k, it in enumerate(items)}
    k = 0
    steps = 0
    landing = False  # after DO_LAND_START: the legs of the landing sequence

    def go(seq: int, kind: str, to: tuple[float, float]) -> None:
        nonlocal pos, takeoff
        if takeoff is not None:
            kind = "to-first"  # the leg from take-off to the first point
        if takeoff is not None and vehicle == "plane":
            # climb straight out along the bearing to this point, then turn to it
            d = math.hypot(to[0] - pos[0], to[1] - pos[1])
            pitch = takeoff.params[0] if takeoff.params[0] > 0 else 15.0
            climb = max(takeoff.alt, 0.0) / math.tan(math.radians(pitch))
            if d > 0 and climb > d:
                out = (pos[0] + (to[0] - pos[0]) * climb / d, pos[1] + (to[1] - pos[1]) * climb / d)
                legs.append((takeoff.seq, "climb-out", shapely.LineString([pos, out])))
                pos = out
        takeoff = None
        if to != pos:
            legs.append((seq, kind, shapely.LineString([pos, to])))
        pos = to

    def rtl(seq: int, kind: str) -> None:
        to = min(targets, key=lambda t: math.hypot(t[0] - pos[0], t[1] - pos[1]))
        go(seq, kind, to)
        if vehicle == "plane" and plane_loiter_radius_m > 0:
            legs.append((seq, "rtl-loiter", _circle(to[0], to[1], plane_loiter_radius_m)))

    while k < len(items):
        steps += 1
        if steps > max_steps:
            raise ValueError("the mission does not end (DO_JUMP loop)")
        it = items[k]
        here = it.lat == 0.0 and it.lon == 0.0
        to = pos if here else local.xy(it.lon, it.lat)
        if it.command in (NAV_TAKEOFF, NAV_VTOL_TAKEOFF):
            takeoff = it if it.command == NAV_TAKEOFF else None
        elif it.command == DO_LAND_START:
            landing = True
        elif it.command in GOTO:
            go(it.seq, "loiter" if it.command in LOITER_RADIUS_PARAM else ("land-approach" if landing else "waypoint"), to)
            r = abs(it.params[LOITER_RADIUS_PARAM[it.command]]) if it.command in LOITER_RADIUS_PARAM else 0.0
            if r > 0:
                legs.append((it.seq, "loiter", _circle(to[0], to[1], r)))
        elif it.command in (NAV_LAND, NAV_VTOL_LAND):
            go(it.seq, "land", to)
            return legs
        elif it.command == NAV_RTL:
            rtl(it.seq, "rtl")
            return legs
        elif it.command == DO_JUMP:
            left = jumps.setdefault(it.seq, int(it.params[1]))
            target = by_seq.get(int(it.params[0]))
            if target is not None and (left != 0):
                jumps[it.seq] = left - 1
                k = target
                continue
        k += 1
    if vehicle == "plane":
        rtl(items[-1].seq + 1 if items else 1, "end-rtl")
    return legs


def read_plan_json(path: Path) -> dict[str, Any]:
    doc = json.loads(path.read_text())
    if not isinstance(doc, dict):
        raise ValueError(f"{path.name}: not a QGroundControl plan (a JSON object)")
    return doc


def plan_fence_and_rally(doc: dict[str, Any]) -> tuple[list[shapely.Polygon], list[tuple[float, float]]]:
    """Exclusion fence polygons (lon/lat) and rally points (lon, lat) of a QGroundControl .plan."""
    excl = []
    for poly in doc.get("geoFence", {}).get("polygons", []):
        if not poly.get("inclusion", True):
            excl.append(shapely.Polygon([(p[1], p[0]) for p in poly["polygon"]]))
    for c in doc.get("geoFence", {}).get("circles", []):
        if not c.get("inclusion", True):
            lat, lon = c["circle"]["center"]
            r = c["circle"]["radius"]
            k_lat, k_lon = 1 / 111_320.0, 1 / (111_320.0 * math.cos(math.radians(lat)))
            excl.append(shapely.Polygon([(lon + r * k_lon * math.cos(t), lat + r * k_lat * math.sin(t))
                                         for t in np.linspace(0, 2 * np.pi, 73)[:-1]]))
    rally = [(float(p[1]), float(p[0])) for p in doc.get("rallyPoints", {}).get("points", [])]
    return excl, rally


def plan_items_differ(doc: dict[str, Any], home: Item, items: list[Item]) -> str | None:
    """Why the .plan would fly elsewhere than the .waypoints (home, commands, positions), or None."""
    m = doc.get("mission", {})
    ph = m.get("plannedHomePosition") or [0.0, 0.0, 0.0]
    if abs(ph[0] - home.lat) > 1e-7 or abs(ph[1] - home.lon) > 1e-7:
        return f"home {ph[:2]} in the .plan, {[home.lat, home.lon]} in the .waypoints"
    # what QGroundControl uploads: SimpleItems, and a Survey item's stored Items
    simple = uploaded_items(doc) if "items" in m else []
    if any(it.get("type") != "SimpleItem" for it in simple) or len(simple) != len(items):
        return f"{len(simple)} items in the .plan, {len(items)} in the .waypoints"
    for k, (a, b) in enumerate(zip(simple, items), start=1):
        lat, lon = (a["params"][4] or 0.0), (a["params"][5] or 0.0)
        if a["command"] != b.command or abs(lat - b.lat) > 1e-7 or abs(lon - b.lon) > 1e-7:
            return f"item {k}: command {a['command']} at {lat}, {lon} in the .plan, {b.command} at {b.lat}, {b.lon} in the .waypoints"
    return None


def legs_inside_zones(wpl: Path, zones_ll: list[shapely.Geometry], local: Local, vehicle: str,
                      plan: Path | None = None, tol_m: float = 0.02, plane_loiter_radius_m: float = 60.0,
                      margin_m: float = 0.0) -> FileReport:
    """Every leg of one exported mission file with its metres inside each zone (input geometry)."""
    home, items = parse_wpl(wpl.read_text(), wpl.name)
    zones = [local.geom(z) for z in zones_ll]
    shrunk = [shapely.buffer(z, -tol_m) for z in zones]
    grown = shapely.buffer(shapely.union_all(zones), margin_m - 0.5) if zones and margin_m > 0.5 else None
    rally: list[tuple[float, float]] = []
    fence_missing: list[int] = []
    notes: list[str] = []
    if plan is not None:
        doc = read_plan_json(plan)
        fence, rally = plan_fence_and_rally(doc)
        fence_xy = shapely.union_all([local.geom(f) for f in fence]) if fence else shapely.Polygon()
        for i, z in enumerate(zones):
            # the zone must lie in the fence's exclusion polygons (to 1 m² and 0.1 % for rounding)
            if shapely.difference(z, shapely.buffer(fence_xy, 0.05)).area > 1.0 + 1e-3 * z.area:
                fence_missing.append(i)
        if rally:
            notes.append(f"{len(rally)} rally points")
        differ = plan_items_differ(doc, home, items)
        if differ:
            notes.append(f"{plan.name} differs from {wpl.name}: {differ}")
    out = []
    for seq, kind, path in rebuild_legs(home, items, local, vehicle, rally, plane_loiter_radius_m):
        inside = tuple(float(shapely.length(shapely.intersection(path, z))) if not z.is_empty else 0.0 for z in shrunk)
        in_margin = float(shapely.length(shapely.intersection(path, grown))) if grown is not None else 0.0
        out.append(Leg(wpl.name, seq, kind, path, inside, in_margin))
    hx, hy = local.xy(home.lon, home.lat)
    home_zones = [i for i, z in enumerate(shrunk) if shapely.contains_xy(z, hx, hy)]
    return FileReport(wpl.name, (home.lon, home.lat), home_zones, out, fence_missing, notes)


def mission_files(outdir: Path) -> list[tuple[Path, Path | None]]:
    """(waypoints, plan) of the whole mission and of every sortie."""
    out = []
    for wpl in [outdir / "mission.waypoints", *sorted(outdir.glob("sortie-*.waypoints"))]:
        plan = wpl.with_suffix(".plan")
        out.append((wpl, plan if plan.exists() else None))
    return out


def check_legs(outdir: Path, zones_ll: list[shapely.Geometry], local: Local, vehicle: str, **kw: Any) -> list[FileReport]:
    return [legs_inside_zones(w, zones_ll, local, vehicle, p, **kw) for w, p in mission_files(outdir)]


# ---------------------------------------------------------------- coverage


@dataclass
class Coverage:
    required_m2: float
    samples: int
    gap_samples: np.ndarray  # (n, 2) metres: samples seen by fewer than min_images photos
    unreported: np.ndarray  # (n, 2): gap samples not within 1 m of the reported uncovered layer
    measured_gap_m2: float  # the checker's estimate of the uncovered required ground
    reported_m2: float | None  # manifest coverage.uncovered_m2
    layer_m2: float  # area of the plan.geojson uncovered layer
    rule_status: str | None  # status of the uncovered-ground rule result
    near_zone: int  # gap samples within margin + 50 m of a zone
    photos: int

    @property
    def reported(self) -> bool:
        return (self.reported_m2 is not None and self.reported_m2 > 0 and self.rule_status == "fail")

    @property
    def unreported_count(self) -> int:
        """Gap samples the plan does not report: all of them when the manifest or rule does not say so."""
        return len(self.gap_samples) if not self.reported else len(self.unreported)

    @property
    def grossly_overstated(self) -> bool:
        rep = self.reported_m2 if self.reported_m2 is not None else 0.0
        return rep > 2 * self.measured_gap_m2 + 100.0


def _uncovered_layer(outdir: Path, local: Local) -> shapely.Geometry:
    doc = json.loads((outdir / "plan.geojson").read_text())
    parts = [local.geom(shapely.from_geojson(json.dumps(f["geometry"]))) for f in doc["features"]
             if (f.get("properties") or {}).get("role") == "uncovered" and f.get("geometry")]
    return shapely.union_all(parts) if parts else shapely.Polygon()


def _replay(outdir: Path, local: Local) -> ic.Photos:
    """Photos of the sorties when there are sortie files (they are what is flown), else of the mission."""
    files = sorted(outdir.glob("sortie-*.waypoints")) or [outdir / "mission.waypoints"]
    parts = []
    for f in files:
        home, rows = ic.read_wpl(f)
        parts.append(ic.replay_triggers(rows, local.fwd, None, home[2]))
    return ic.Photos(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("x", "y", "heading", "agl", "run")))


def _grid(geom: shapely.Geometry, step: float) -> np.ndarray:
    x0, y0, x1, y1 = geom.bounds
    mx, my = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    gx, gy = mx.ravel(), my.ravel()
    inside = shapely.contains_xy(geom, gx, gy)
    return np.column_stack([gx[inside], gy[inside]])


def _edge_samples(geom: shapely.Geometry, inset: float, step: float) -> np.ndarray:
    """Points along the boundary of `geom`, `inset` metres inside it, every `step` metres."""
    inner = shapely.buffer(geom, -inset, join_style="mitre")
    pts = []
    for ring in shapely.get_parts(shapely.boundary(inner)):
        n = max(int(ring.length / step), 4)
        pts.extend(shapely.get_coordinates(shapely.line_interpolate_point(ring, np.linspace(0, ring.length, n, endpoint=False))))
    return np.asarray(pts, dtype=float).reshape(-1, 2)


def coverage_gaps(outdir: Path, area_ll: shapely.Geometry, zones_ll: list[shapely.Geometry], margin_m: float, local: Local,
                  min_images: int = 2, grid_points: int = 6000, edge_step_m: float = 3.0) -> Coverage:
    """Required ground seen by fewer than `min_images` photos, and whether the plan reports it."""
    manifest = json.loads((outdir / "manifest.json").read_text())
    cam = manifest["camera"]
    sensor = (cam["sensor_mm"][0], cam["sensor_mm"][1], cam["image_px"][0], cam["image_px"][1], cam["focal_mm"])
    area = local.geom(area_ll)
    zones = shapely.union_all([local.geom(z) for z in zones_ll]) if zones_ll else shapely.Polygon()
    required = shapely.difference(area, shapely.buffer(zones, margin_m)) if zones_ll else area
    photos = _replay(outdir, local)
    step = math.sqrt(required.area / grid_points)
    grid = _grid(required, step)
    edge = _edge_samples(required, 0.25, edge_step_m)
    pts = np.vstack([grid, edge]) if len(edge) else grid
    counts: np.ndarray = (ic.footprint_counts(photos, pts[:, 0], pts[:, 1], sensor, cam["mount"]) if len(photos.x)
                          else np.zeros(len(pts), int))
    gap = counts < min_images
    layer = _uncovered_layer(outdir, local)
    gaps = pts[gap]
    if len(gaps) and not layer.is_empty:
        near = shapely.dwithin(layer, shapely.points(gaps), 1.0)
        unreported = gaps[~near]
    else:
        unreported = gaps
    # the checker's estimate of the uncovered area: grid cells outside the reported layer, plus a
    # finer grid inside the reported layer (so a sliver the plan reports is measured, not guessed)
    grid_gap = grid[counts[: len(grid)] < min_images]
    outside = grid_gap if layer.is_empty or not len(grid_gap) else grid_gap[~shapely.contains_xy(layer, grid_gap[:, 0], grid_gap[:, 1])]
    measured = len(outside) * step * step
    layer_req = shapely.intersection(layer, required) if not layer.is_empty else layer
    if not layer_req.is_empty and layer_req.area > 0:
        fine = _grid(layer_req, max(math.sqrt(layer_req.area / 2000), 0.2))
        if len(fine):
            c2 = ic.footprint_counts(photos, fine[:, 0], fine[:, 1], sensor, cam["mount"])
            measured += layer_req.area * float(np.mean(c2 < min_images))
    cov = manifest.get("coverage") or {}
    rule = next((r for r in manifest.get("rules", []) if r.get("rule") == "uncovered-ground"), None)
    near_zone = int(np.sum(shapely.dwithin(zones, shapely.points(gaps), margin_m + 50.0))) if len(gaps) and zones_ll else 0
    return Coverage(float(required.area), len(pts), gaps, unreported, float(measured),
                    cov.get("uncovered_m2"), float(layer.area), rule.get("status") if rule else None, near_zone, len(photos.x))
