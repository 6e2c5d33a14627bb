"""QGroundControl's side of a .plan, rebuilt from its sources for the tests and benchmarks: its
loader's rules (keys, JSON types, versions), its Survey generator and its Structure Scan
generator, ported from reading
QGroundControl's master branch (the files as stored at commit 00d5b5e018e54e303cb650790bd1b6e08f818bd0:
SurveyComplexItem.cc, TransectStyleComplexItem.cc/.h, CameraCalc.cc, CameraSpec.cc,
QGCMapPolygon.cc, MissionItem.cc, QGCGeo.cc). Written here in our own words; it shares no code
with aerosurvey's writer (mission/formats/qgc_plan.py, qgc_survey.py): json and numpy only.

What the generator port does (SurveyComplexItem::_rebuildTransectsPhase1WorkerSinglePolygon):
project the polygon onto the plane tangent at its first vertex (x east, y north; up to 5.0 an
azimuthal equidistant projection on a sphere of radius 6378137 m, from 5.1 GeographicLib's
LocalCartesian on the WGS84 ellipsoid, as stored at commit 06a5e7676fa2: `FRAMES`); lay lines every AdjustedFootprintSide metres,
starting half of (the larger side of the east-north bounding box + 2000 m) before the box's
centre, each as long as that, rotated clockwise by the clamped angle; cut each to the two
farthest crossings with the polygon's edges (the pair found first, edges in polygon order);
turn every line to the first line's direction; apply the entry location and the alternate
order; reverse every second line. Camera shots as _recalcCameraShots counts them from
transects: per transect, ceil(its length / AdjustedFootprintFrontal).

The Structure Scan port (StructureScanComplexItem.cc as stored at commit
00d5b5e018e54e303cb650790bd1b6e08f818bd0: load, appendMissionItems, _rebuildFlightPolygon,
_recalcLayerInfo, _recalcCameraShots; QGCMapPolygon::offset and nedPolygon at the same commit,
with Qt's QLineF::angle/setAngle/setLength, whose angles run counter-clockwise in a y-down
frame): the structure polygon put on the plane at its vertex 0 (QPointF(east, north)), each edge
offset by DistanceToSurface to the side QLineF's angle − 90° points, consecutive offset edges
intersected; layers max(⌈max(StructureHeight − ScanBottomAlt, 0) / AdjustedFootprintFrontal⌉, 1),
the first half a layer above ScanBottomAlt (below StructureHeight when StartFromTop), a layer
apart; the uploaded items (entrance, ROI_WPNEXT_OFFSET, per layer the vertices 0..n−1, 0 with
the trigger on after the first at AdjustedFootprintSide and off after the last, ROI_NONE, exit);
camera shots int(the closed flight polygon's length / AdjustedFootprintSide) × layers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

R_TANGENT = 6378137.0  # QGCGeo: GeographicLib::Constants::WGS84_a()
R_QGEO = 6371007.2  # QGeoCoordinate::distanceTo's mean earth radius
MIN_SPACING = 0.5  # SurveyComplexItem::_minimumTransectSpacingMeters
FORCED_SPACING = 100000.0  # ... _forceLargeTransectSpacingMeters

# ------------------------------------------------------------------ the loader's rules

NUMBER, STRING, BOOL, ARRAY, OBJECT = "Double", "String", "Bool", "Array", "Object"


def qt_type(v: Any) -> str:
    """The QJsonValue type of a JSON value (a number is Double; null is Null)."""
    if isinstance(v, bool):
        return BOOL
    if isinstance(v, (int, float)):
        return NUMBER
    return {str: STRING, list: ARRAY, dict: OBJECT}.get(type(v), "Null")


def validate_keys(obj: dict[str, Any], rules: list[tuple[str, str, bool]], where: str) -> list[str]:
    """JsonHelper::validateKeys: required keys present, present keys of their type."""
    out = []
    for key, typ, required in rules:
        if key not in obj:
            if required:
                out.append(f"{where}: required key {key!r} missing")
        elif qt_type(obj[key]) != typ:
            out.append(f"{where}: key {key!r} is {qt_type(obj[key])}, {typ} expected")
    return out


def _coords(v: Any, where: str, altitude: bool) -> list[str]:
    """JsonHelper::loadGeoCoordinateArray: an array of [lat, lon(, alt)] numbers."""
    if not isinstance(v, list):
        return [f"{where}: not an array"]
    n = 3 if altitude else 2
    return [f"{where}[{k}]: {p!r} is not a coordinate" for k, p in enumerate(v)
            if not (isinstance(p, list) and len(p) in (n, 3) and all(qt_type(c) == NUMBER for c in p))]


def mission_item_problems(it: Any, where: str) -> list[str]:
    """MissionItem::load (the v3 form: seven params, the first four may be null)."""
    if not isinstance(it, dict):
        return [f"{where}: not an object"]
    out = validate_keys(it, [("type", STRING, True), ("frame", NUMBER, True), ("command", NUMBER, True),
                             ("params", ARRAY, True), ("autoContinue", BOOL, True), ("doJumpId", NUMBER, False)], where)
    if it.get("type") != "SimpleItem":
        out.append(f"{where}: type {it.get('type')!r} must be SimpleItem")
    params = it.get("params", [])
    if not isinstance(params, list) or len(params) != 7:
        out.append(f"{where}: params must hold 7 values")
    elif any(qt_type(p) not in (NUMBER, "Null") for p in params):
        out.append(f"{where}: params must be numbers or null")
    return out


def camera_calc_problems(c: Any, where: str) -> list[str]:
    """CameraCalc::load (version 2) and, for any camera but the manual one, CameraSpec::load."""
    if not isinstance(c, dict):
        return [f"{where}: not an object"]
    out = []
    if c.get("version") != 2:
        out.append(f"{where}: CameraCalc version {c.get('version')!r}, 2 expected")
    out += validate_keys(c, [("CameraName", STRING, True), ("AdjustedFootprintSide", NUMBER, True),
                             ("AdjustedFootprintFrontal", NUMBER, True), ("DistanceToSurface", NUMBER, True),
                             ("DistanceMode", NUMBER, True)], where)
    if c.get("CameraName") != "Manual (no camera specs)":
        out += validate_keys(c, [("ValueSetIsDistance", BOOL, True), ("ImageDensity", NUMBER, True),
                                 ("FrontalOverlap", NUMBER, True), ("SideOverlap", NUMBER, True),
                                 ("SensorWidth", NUMBER, True), ("SensorHeight", NUMBER, True),
                                 ("ImageWidth", NUMBER, True), ("ImageHeight", NUMBER, True),
                                 ("FocalLength", NUMBER, True), ("Landscape", BOOL, True),
                                 ("FixedOrientation", BOOL, True), ("MinTriggerInterval", NUMBER, True)], where)
    if c.get("DistanceMode") not in (1, 2, 3, 4):
        out.append(f"{where}: DistanceMode {c.get('DistanceMode')!r} is not one a survey flies (1-4)")
    return out


def corridor_problems(it: dict[str, Any], where: str) -> list[str]:
    """CorridorScanComplexItem::_loadWorker (version 2), QGCMapPolyline::loadFromJson, then the
    TransectStyleComplexItem as for a Survey."""
    out = validate_keys(it, [("version", NUMBER, True), ("type", STRING, True), ("complexItemType", STRING, True),
                             ("CorridorWidth", NUMBER, True), ("EntryPoint", NUMBER, True), ("polyline", ARRAY, True),
                             ("TransectStyleComplexItem", OBJECT, True)], where)
    if it.get("version") != 2:
        out.append(f"{where}: CorridorScan version {it.get('version')!r}, 2 expected")
    if it.get("EntryPoint") not in (0, 1, 2, 3):
        out.append(f"{where}: EntryPoint {it.get('EntryPoint')!r} is not 0-3")
    return out + _shape_and_transects(it, "polyline", 2, "", where)


def survey_problems(it: dict[str, Any], where: str) -> list[str]:
    """SurveyComplexItem::load -> _loadV4V5 (version 5), QGCMapPolygon::loadFromJson,
    TransectStyleComplexItem::_load (version 2), CameraCalc::load, MissionItem::load of each Items entry."""
    out = validate_keys(it, [("version", NUMBER, True)], where)
    if it.get("version") != 5:
        return out + [f"{where}: survey version {it.get('version')!r}, 5 expected"]
    out += validate_keys(it, [("type", STRING, True), ("complexItemType", STRING, True), ("entryLocation", NUMBER, True),
                              ("angle", NUMBER, True), ("flyAlternateTransects", BOOL, False),
                              ("splitConcavePolygons", BOOL, True), ("polygon", ARRAY, True),
                              ("TransectStyleComplexItem", OBJECT, True)], where)
    if it.get("entryLocation") not in (0, 1, 2, 3):
        out.append(f"{where}: entryLocation {it.get('entryLocation')!r} is not 0-3")
    return out + _shape_and_transects(it, "polygon", 3, " (QGroundControl draws nothing)", where)


def structure_scan_problems(it: dict[str, Any], where: str) -> list[str]:
    """StructureScanComplexItem::load (version 3), CameraCalc::load, QGCMapPolygon::loadFromJson."""
    out = validate_keys(it, [("version", NUMBER, True), ("type", STRING, True), ("complexItemType", STRING, True),
                             ("polygon", ARRAY, True), ("ScanBottomAlt", NUMBER, True), ("StructureHeight", NUMBER, True),
                             ("Layers", NUMBER, True), ("CameraCalc", OBJECT, True), ("EntranceAltitude", NUMBER, True),
                             ("GimbalPitch", NUMBER, True), ("StartFromTop", BOOL, True)], where)
    if it.get("version") != 3:
        out.append(f"{where}: StructureScan version {it.get('version')!r}, 3 expected")
    out += _coords(it.get("polygon", []), f"{where} polygon", altitude=False)
    if len(it.get("polygon", [])) < 3:
        out.append(f"{where}: polygon has fewer than 3 vertices")
    return out + camera_calc_problems(it.get("CameraCalc"), f"{where} CameraCalc")


def _shape_and_transects(it: dict[str, Any], key: str, fewest: int, why: str, where: str) -> list[str]:
    """QGCMapPolyline/QGCMapPolygon::loadFromJson of the item's `key` (2-D vertices, at least
    `fewest`), then its TransectStyleComplexItem."""
    out = _coords(it.get(key, []), f"{where} {key}", altitude=False)
    if len(it.get(key, [])) < fewest:
        out.append(f"{where}: {key} has fewer than {fewest} vertices{why}")
    return out + transect_problems(it.get("TransectStyleComplexItem", {}), f"{where} TransectStyleComplexItem")


def transect_problems(inner: Any, w: str) -> list[str]:
    """TransectStyleComplexItem::_load (version 2), CameraCalc::load, MissionItem::load of each Items entry."""
    out: list[str] = []
    if not isinstance(inner, dict):
        return [f"{w}: not an object"]
    if inner.get("version") != 2:
        out.append(f"{w}: version {inner.get('version')!r}, 2 expected")
    out += validate_keys(inner, [("version", NUMBER, True), ("TurnAroundDistance", NUMBER, True),
                                 ("CameraTriggerInTurnAround", BOOL, True), ("HoverAndCapture", BOOL, True),
                                 ("Refly90Degrees", BOOL, True), ("CameraCalc", OBJECT, True),
                                 ("VisualTransectPoints", ARRAY, True), ("Items", ARRAY, True),
                                 ("CameraShots", NUMBER, True)], w)
    out += _coords(inner.get("VisualTransectPoints", []), f"{w} VisualTransectPoints", altitude=False)
    out += camera_calc_problems(inner.get("CameraCalc"), f"{w} CameraCalc")
    if isinstance(inner.get("CameraCalc"), dict) and inner["CameraCalc"].get("DistanceMode") == 3:
        out += validate_keys(inner, [("TerrainAdjustTolerance", NUMBER, True), ("TerrainAdjustMaxClimbRate", NUMBER, True),
                                     ("TerrainAdjustMaxDescentRate", NUMBER, True), ("TerrainFlightSpeed", NUMBER, False)], w)
    for k, item in enumerate(inner.get("Items", []), start=1):
        out += mission_item_problems(item, f"{w} Items[{k}]")
    return out


def plan_problems(doc: Any) -> list[str]:
    """What QGroundControl's loader would refuse in a plan file (the parts aerosurvey writes)."""
    if not isinstance(doc, dict):
        return ["not an object"]
    out = validate_keys(doc, [("fileType", STRING, True), ("version", NUMBER, True), ("mission", OBJECT, True),
                              ("geoFence", OBJECT, True), ("rallyPoints", OBJECT, True)], "plan")
    if doc.get("fileType") != "Plan" or doc.get("version") != 1:
        out.append("plan: fileType Plan, version 1 expected")
    m = doc.get("mission", {})
    out += validate_keys(m, [("version", NUMBER, True), ("firmwareType", NUMBER, True), ("vehicleType", NUMBER, False),
                             ("cruiseSpeed", NUMBER, False), ("hoverSpeed", NUMBER, False),
                             ("plannedHomePosition", ARRAY, True), ("items", ARRAY, True)], "mission")
    for k, it in enumerate(m.get("items", []), start=1):
        where = f"mission item {k}"
        if not isinstance(it, dict) or qt_type(it.get("type")) != STRING:
            out.append(f"{where}: no type")
        elif it["type"] == "SimpleItem":
            out += mission_item_problems(it, where)
        elif it["type"] == "ComplexItem" and it.get("complexItemType") == "survey":
            out += survey_problems(it, where)
        elif it["type"] == "ComplexItem" and it.get("complexItemType") == "CorridorScan":
            out += corridor_problems(it, where)
        elif it["type"] == "ComplexItem" and it.get("complexItemType") == "StructureScan":
            out += structure_scan_problems(it, where)
        else:
            out.append(f"{where}: {it.get('type')!r}/{it.get('complexItemType')!r} is not written by aerosurvey")
    return out


def uploaded_items(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """The items QGroundControl uploads for a plan loaded and not edited: each SimpleItem, and
    each Survey's stored Items (TransectStyleComplexItem::appendMissionItems with loaded items)."""
    out = []
    for it in doc["mission"]["items"]:
        if it["type"] == "ComplexItem":
            out += it["TransectStyleComplexItem"]["Items"]
        else:
            out.append(it)
    return out


# ------------------------------------------------------------------ the generator


# QGroundControl's plane: QGCGeo::convertGeoToNed / convertNedToGeo at the polygon's first vertex.
# Two conversions, by release (docs/clients/qgroundcontrol.md):
#   "sphere": up to 5.0, an azimuthal equidistant projection on a sphere of radius WGS84_a;
#   "ellipsoid": from 5.1 (master since January 2026), GeographicLib::LocalCartesian on the WGS84
#   ellipsoid, heights 0: east and north on the plane tangent to the ellipsoid at the origin.
FRAMES = ("sphere", "ellipsoid")
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)


def _ecef(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    p, lam = np.radians(lat), np.radians(lon)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * np.sin(p) ** 2)
    return np.stack([n * np.cos(p) * np.cos(lam), n * np.cos(p) * np.sin(lam), n * (1.0 - WGS84_E2) * np.sin(p)], axis=-1)


def _enu_axes(lat0: float, lon0: float) -> np.ndarray:
    """Rows: the unit vectors east, north and up at (lat0, lon0), in ECEF."""
    p, lam = math.radians(lat0), math.radians(lon0)
    return np.array([[-math.sin(lam), math.cos(lam), 0.0],
                     [-math.sin(p) * math.cos(lam), -math.sin(p) * math.sin(lam), math.cos(p)],
                     [math.cos(p) * math.cos(lam), math.cos(p) * math.sin(lam), math.sin(p)]])


def _geodetic(xyz: np.ndarray) -> tuple[float, float]:
    """ECEF -> (latitude, longitude), by fixed-point iteration on the latitude (converges to 1e-12 rad in a few steps)."""
    x, y, z = map(float, xyz)
    r = math.hypot(x, y)
    lat = math.atan2(z, r * (1.0 - WGS84_E2))
    for _ in range(10):
        n = WGS84_A / math.sqrt(1.0 - WGS84_E2 * math.sin(lat) ** 2)
        h = r / math.cos(lat) - n
        lat = math.atan2(z, r * (1.0 - WGS84_E2 * n / (n + h)))
    return math.degrees(lat), math.degrees(math.atan2(y, x))


def to_plane(lat: np.ndarray, lon: np.ndarray, lat0: float, lon0: float, frame: str = "sphere") -> np.ndarray:
    """QGCGeo::convertGeoToNed, as (east, north), in QGroundControl's `frame` (FRAMES)."""
    if frame == "ellipsoid":
        d = _ecef(np.asarray(lat, float), np.asarray(lon, float)) - _ecef(np.array(lat0), np.array(lon0))
        enu = d @ _enu_axes(lat0, lon0).T
        return np.column_stack([enu[..., 0], enu[..., 1]])
    p, p0 = np.radians(lat), math.radians(lat0)
    dl = np.radians(lon) - math.radians(lon0)
    cos_c = np.clip(math.sin(p0) * np.sin(p) + math.cos(p0) * np.cos(p) * np.cos(dl), -1.0, 1.0)
    c = np.arccos(cos_c)
    k = np.where(np.abs(c) < 1e-15, 1.0, c / np.where(np.abs(c) < 1e-15, 1.0, np.sin(c)))
    north = k * (math.cos(p0) * np.sin(p) - math.sin(p0) * np.cos(p) * np.cos(dl)) * R_TANGENT
    east = k * np.cos(p) * np.sin(dl) * R_TANGENT
    return np.column_stack([east, north])


def from_plane(east: float, north: float, lat0: float, lon0: float, frame: str = "sphere") -> tuple[float, float]:
    """QGCGeo::convertNedToGeo (down 0): the inverse of `to_plane`."""
    if frame == "ellipsoid":
        xyz = _ecef(np.array(lat0), np.array(lon0)) + np.array([east, north, 0.0]) @ _enu_axes(lat0, lon0)
        return _geodetic(xyz)
    x, y = north / R_TANGENT, east / R_TANGENT
    c = math.hypot(x, y)
    p0, l0 = math.radians(lat0), math.radians(lon0)
    if c < 1e-15:
        return lat0, lon0
    lat = math.asin(math.cos(c) * math.sin(p0) + x * math.sin(c) * math.cos(p0) / c)
    lon = l0 + math.atan2(y * math.sin(c), c * math.cos(p0) * math.cos(c) - x * math.sin(p0) * math.sin(c))
    return math.degrees(lat), math.degrees(lon)


def _rotate(pt: tuple[float, float], origin: tuple[float, float], angle: float) -> tuple[float, float]:
    """SurveyComplexItem::_rotatePoint: by -angle in the x-east, y-north plane (clockwise on the map)."""
    r = math.radians(-angle)
    dx, dy = pt[0] - origin[0], pt[1] - origin[1]
    return (dx * math.cos(r) - dy * math.sin(r) + origin[0], dx * math.sin(r) + dy * math.cos(r) + origin[1])


def _bounded_cross(a1, a2, b1, b2) -> tuple[float, float] | None:
    """QLineF::intersects == BoundedIntersection: the crossing point when it lies on both segments."""
    d1 = (a2[0] - a1[0], a2[1] - a1[1])
    d2 = (b2[0] - b1[0], b2[1] - b1[1])
    den = d1[0] * d2[1] - d1[1] * d2[0]
    if den == 0:
        return None
    t = ((b1[0] - a1[0]) * d2[1] - (b1[1] - a1[1]) * d2[0]) / den
    u = ((b1[0] - a1[0]) * d1[1] - (b1[1] - a1[1]) * d1[0]) / den
    if 0.0 <= t <= 1.0 and 0.0 <= u <= 1.0:
        return (a1[0] + t * d1[0], a1[1] + t * d1[1])
    return None


def _cut(line, closed: list[tuple[float, float]]):
    """SurveyComplexItem::_intersectLinesWithPolygon for one line: the farthest pair of its crossings."""
    hits: list[tuple[float, float]] = []
    for j in range(len(closed) - 1):
        p = _bounded_cross(line[0], line[1], closed[j], closed[j + 1])
        if p is not None and p not in hits:
            hits.append(p)
    if len(hits) < 2:
        return None
    best, pair = 0.0, None
    for i in range(len(hits)):
        for j in range(len(hits)):
            d = math.dist(hits[i], hits[j])
            if d > best:
                best, pair = d, (hits[i], hits[j])
    return pair


def _qt_angle(line) -> float:
    """QLineF::angle: degrees counter-clockwise from +x with Qt's y pointing down."""
    return math.degrees(math.atan2(-(line[1][1] - line[0][1]), line[1][0] - line[0][0])) % 360.0


@dataclass(frozen=True)
class Regenerated:
    transects: list[list[tuple[float, float]]]  # flight order, each [entry (lat, lon), exit (lat, lon)]
    camera_shots: int
    spacing_m: float
    angle_deg: float


def regenerate(survey: dict[str, Any], frame: str = "sphere") -> Regenerated:
    """The transects QGroundControl builds from a Survey item's settings when it is edited (no refly, no turnaround points),
    on the plane of `frame` (FRAMES)."""
    poly = survey["polygon"]
    lat0, lon0 = poly[0]
    pts = to_plane(np.array([p[0] for p in poly]), np.array([p[1] for p in poly]), lat0, lon0, frame)
    pts[0] = (0.0, 0.0)
    closed = [tuple(map(float, p)) for p in pts] + [tuple(map(float, pts[0]))]
    inner = survey["TransectStyleComplexItem"]
    cam = inner["CameraCalc"]
    angle = float(survey["angle"])
    if angle > 90.0:
        angle -= 180.0
    elif angle < -90.0:
        angle += 180.0
    spacing = float(cam["AdjustedFootprintSide"])
    if spacing < MIN_SPACING:
        spacing = FORCED_SPACING
    xs, ys = [p[0] for p in closed], [p[1] for p in closed]
    centre = ((min(xs) + max(xs)) / 2.0, (min(ys) + max(ys)) / 2.0)
    width = max(max(xs) - min(xs), max(ys) - min(ys)) + 2000.0
    half = width / 2.0
    lines = []
    x = centre[0] - half
    while x < centre[0] - half + width:
        lines.append((_rotate((x, centre[1] - half), centre, angle), _rotate((x, centre[1] + half), centre, angle)))
        x += spacing
    cut = [c for c in (_cut(line, closed) for line in lines) if c is not None]
    if len(cut) < 2:  # one line through the box's centre
        mid = ((lines[0][0][0] + lines[0][1][0]) / 2.0, (lines[0][0][1] + lines[0][1][1]) / 2.0)
        dx, dy = centre[0] - mid[0], centre[1] - mid[1]
        one = ((lines[0][0][0] + dx, lines[0][0][1] + dy), (lines[0][1][0] + dx, lines[0][1][1] + dy))
        cut = [c for c in [_cut(one, closed)] if c is not None]
    first = _qt_angle(cut[0]) if cut else 0.0
    cut = [(b, a) if abs(_qt_angle((a, b)) - first) > 1.0 else (a, b) for a, b in cut]
    transects = [[from_plane(a[0], a[1], lat0, lon0, frame), from_plane(b[0], b[1], lat0, lon0, frame)] for a, b in cut]
    entry = int(survey["entryLocation"])
    if entry in (2, 3):
        transects = [t[::-1] for t in transects]
    if entry in (1, 3):
        transects = transects[::-1]
    if survey.get("flyAlternateTransects", False):
        transects = [t for i, t in enumerate(transects) if i % 2 == 0] + \
                    [transects[i] for i in range(len(transects) - 1, 0, -1) if i % 2 == 1]
    transects = [t[::-1] if i % 2 else t for i, t in enumerate(transects)]
    trigger = float(cam["AdjustedFootprintFrontal"])
    shots = sum(math.ceil(sphere_distance(t[0], t[1]) / trigger) for t in transects) if trigger > 0 else 0
    return Regenerated(transects, shots, spacing, angle)


def sphere_distance(a: tuple[float, float], b: tuple[float, float]) -> float:
    """QGeoCoordinate::distanceTo: haversine on its mean-radius sphere."""
    p1, p2 = math.radians(a[0]), math.radians(b[0])
    dp, dl = p2 - p1, math.radians(b[1] - a[1])
    h = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * R_QGEO * math.asin(math.sqrt(h))


def offset_polyline(pts: np.ndarray, d: float) -> np.ndarray:
    """QGCMapPolyline::offsetPolyline on the plane: each edge moved `d` to its left, the first and
    last vertices so moved, the inner ones where consecutive moved edges meet (mitred)."""
    edges = []
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        t = (b - a) / float(np.hypot(*(b - a)))
        left = np.array([-t[1], t[0]])
        edges.append((a + d * left, b + d * left))
    out = [edges[0][0]]
    for (a0, a1), (b0, b1) in zip(edges[:-1], edges[1:], strict=True):
        da, db = a1 - a0, b1 - b0
        den = da[0] * db[1] - da[1] * db[0]
        out.append(a1 if den == 0 else a0 + ((b0[0] - a0[0]) * db[1] - (b0[1] - a0[1]) * db[0]) / den * da)
    out.append(edges[-1][1])
    return np.array(out)


def regenerate_corridor(item: dict[str, Any], frame: str = "sphere") -> tuple[list[np.ndarray], int, tuple[float, float]]:
    """CorridorScanComplexItem::_rebuildTransectsPhase1: the transects (on the plane at the
    polyline's first vertex, flight order), the camera shots (_recalcCameraShots, no trigger in
    turns: ⌈polyline length / trigger⌉ per transect) and the plane's origin."""
    line = item["polyline"]
    lat0, lon0 = line[0]
    pts = to_plane(np.array([p[0] for p in line]), np.array([p[1] for p in line]), lat0, lon0, frame)
    pts[0] = (0.0, 0.0)
    cam = item["TransectStyleComplexItem"]["CameraCalc"]
    spacing = float(cam["AdjustedFootprintSide"])
    spacing = FORCED_SPACING if spacing < MIN_SPACING else spacing
    width = float(item["CorridorWidth"])
    count = math.ceil(width / spacing) if width > 0 else 1
    transects = [offset_polyline(pts, 0.0 if count == 1 else width / 2.0 - spacing / 2.0 - k * spacing) for k in range(count)]
    entry = int(item["EntryPoint"])
    if entry in (1, 3):
        transects = transects[::-1]
    if entry in (2, 3):
        transects = [t[::-1] for t in transects]
    transects = [t[::-1] if i % 2 else t for i, t in enumerate(transects)]
    length = sum(sphere_distance(tuple(a), tuple(b)) for a, b in zip(line[:-1], line[1:], strict=True))
    trigger = float(cam["AdjustedFootprintFrontal"])
    return transects, (math.ceil(length / trigger) * count if trigger > 0 else 0), (lat0, lon0)


# ------------------------------------------------------------------ our lines, read from the items


def flown_lines(items: list[dict[str, Any]]) -> list[list[tuple[float, float]]]:
    """Each photo run of a list of .plan items, by the items' aerosurveyTag: [(lat, lon) of the
    waypoint after a run's lead-in (its first station), (lat, lon) of the run's end waypoint]."""
    out, start, after_lead_in = [], None, False
    for it in items:
        if it["command"] != 16:
            continue
        tag, pos = it.get("aerosurveyTag", ""), (it["params"][4], it["params"][5])
        if after_lead_in:
            start = pos
        elif tag.endswith(":end") and start is not None:
            out.append([start, pos])
            start = None
        after_lead_in = tag.endswith(":lead-in")
    return out


def flown_paths(items: list[dict[str, Any]]) -> list[list[tuple[float, float]]]:
    """Each photo run's path, by the items' aerosurveyTag: its first station, its bends, its end."""
    out: list[list[tuple[float, float]]] = []
    path: list[tuple[float, float]] | None = None
    after_lead_in = False
    for it in items:
        if it["command"] != 16:
            continue
        tag, pos = it.get("aerosurveyTag", ""), (it["params"][4], it["params"][5])
        if after_lead_in:
            path = [pos]
        elif path is not None and tag.endswith(":bend"):
            path.append(pos)
        elif path is not None and tag.endswith(":end"):
            out.append(path + [pos])
            path = None
        after_lead_in = tag.endswith(":lead-in")
    return out


def compare_corridor(item: dict[str, Any], ours: list[list[tuple[float, float]]], lines: int,
                     frame: str = "sphere") -> dict[str, float]:
    """How QGroundControl's regenerated corridor transects differ from our runs (each line's
    runs flown one after another): transects against lines, and the largest distance of our
    runs' points from the QGC transect of the same rank (and back)."""
    import shapely

    transects, shots, origin = regenerate_corridor(item, frame)
    per_line = len(ours) // lines if lines else 0
    worst, worst_back = 0.0, 0.0
    for k, t in enumerate(transects[:lines]):
        runs = ours[k * per_line:(k + 1) * per_line]
        pts = np.array([p for r in runs for p in r], float)
        xy = to_plane(pts[:, 0], pts[:, 1], *origin, frame)
        qgc_line = shapely.LineString(t)
        worst = max(worst, float(max(qgc_line.distance(shapely.Point(p)) for p in xy)))
        ours_lines = shapely.MultiLineString([to_plane(np.array([p[0] for p in r]), np.array([p[1] for p in r]), *origin, frame)
                                              for r in runs])
        worst_back = max(worst_back, float(max(ours_lines.distance(shapely.Point(p)) for p in t)))
    return {"qgc_transects": len(transects), "our_lines": lines, "our_runs": len(ours),
            "max_ours_from_qgc_m": worst, "max_qgc_vertex_from_ours_m": worst_back,
            "qgc_shots": shots, "written_shots": int(item["TransectStyleComplexItem"]["CameraShots"])}


def compare(survey: dict[str, Any], ours: list[list[tuple[float, float]]], frame: str = "sphere") -> dict[str, float]:
    """How QGroundControl's regenerated transects differ from our runs, on the plane at the polygon's
    first vertex: counts, spacings, the largest distance across the lines between each of QGC's
    lines and our nearest line, and the largest distance of a QGC line end from our line ends."""
    gen = regenerate(survey, frame)
    lat0, lon0 = survey["polygon"][0]
    a = math.radians(gen.angle_deg)
    along, across = np.array([math.sin(a), math.cos(a)]), np.array([math.cos(a), -math.sin(a)])

    def plane(segs):
        flat = np.array([p for s in segs for p in s], float)
        return to_plane(flat[:, 0], flat[:, 1], lat0, lon0, frame).reshape(-1, 2, 2)

    q, o = plane(gen.transects), plane(ours)
    q_off, o_off = q.mean(axis=1) @ across, o.mean(axis=1) @ across
    lines = np.unique(np.round(o_off, 1))
    merged = [o_off[np.abs(o_off - v) < 1.0].mean() for v in lines]
    merged = np.unique(np.round(merged, 3))
    o_spacing = float(np.median(np.diff(merged))) if len(merged) > 1 else float("nan")
    cross = [float(np.min(np.abs(merged - v))) for v in q_off]
    # line ends: per QGC line, its ends against the farthest ends of our runs on the nearest line
    ends = []
    for seg, v in zip(q, q_off, strict=True):
        mine = o[np.abs(o_off - merged[int(np.argmin(np.abs(merged - v)))]) < 1.0]
        s = mine.reshape(-1, 2) @ along
        t = np.sort(seg @ along)
        ends.append(max(abs(t[0] - s.min()), abs(t[1] - s.max())))
    # flown in the same order and directions: QGC's i-th transect against our i-th run, end for end
    same = len(q) == len(o)
    order = max(float(np.abs(qq - oo).max()) for qq, oo in zip(q, o, strict=True)) if same else float("nan")
    return {
        "same_order_m": order,
        "qgc_transects": len(gen.transects), "our_lines": len(merged), "our_runs": len(ours),
        "qgc_spacing_m": gen.spacing_m, "our_spacing_m": o_spacing,
        "max_across_m": max(cross), "median_across_m": float(np.median(cross)),
        "max_end_m": max(ends), "median_end_m": float(np.median(ends)),
        "qgc_shots": gen.camera_shots, "written_shots": int(survey["TransectStyleComplexItem"]["CameraShots"]),
    }


# ------------------------------------------------------------------ the Structure Scan generator


def _qt_line_angle(p1: tuple[float, float], p2: tuple[float, float]) -> float:
    """QLineF::angle: degrees counter-clockwise from +x with y pointing down."""
    a = math.degrees(math.atan2(-(p2[1] - p1[1]), p2[0] - p1[0]))
    return a + 360.0 if a < 0 else a


def _qt_set_length(p1, p2, length):
    d = math.hypot(p2[0] - p1[0], p2[1] - p1[1])
    return p1, (p1[0] + (p2[0] - p1[0]) * length / d, p1[1] + (p2[1] - p1[1]) * length / d)


def _qt_set_angle(p1, p2, angle):
    length = math.hypot(p2[0] - p1[0], p2[1] - p1[1])
    r = math.radians(angle)
    return p1, (p1[0] + math.cos(r) * length, p1[1] - math.sin(r) * length)


def _qt_intersect(a, b):
    (x1, y1), (x2, y2) = a
    (x3, y3), (x4, y4) = b
    den = (x1 - x2) * (y3 - y4) - (y1 - y2) * (x3 - x4)
    if den == 0:
        return None
    t = ((x1 - x3) * (y3 - y4) - (y1 - y3) * (x3 - x4)) / den
    return (x1 + t * (x2 - x1), y1 + t * (y2 - y1))


def qgc_offset(poly: list[tuple[float, float]], distance: float, frame: str) -> list[tuple[float, float]]:
    """QGCMapPolygon::offset of (lat, lon) vertices: the offset polygon's (lat, lon) vertices."""
    lat0, lon0 = poly[0]
    ned = [(0.0, 0.0)] + [tuple(map(float, to_plane(np.array([a]), np.array([b]), lat0, lon0, frame)[0]))
                          for a, b in poly[1:]]  # QPointF(x east, y north); vertex 0 set to 0, 0
    edges = []
    for i in range(len(ned)):
        p1, p2 = ned[i], ned[0 if i == len(ned) - 1 else i + 1]
        w = _qt_set_length(p1, p2, distance)
        w = _qt_set_angle(*w, _qt_line_angle(*w) - 90.0)
        start = w[1]
        w = _qt_set_length(p2, p1, distance)
        w = _qt_set_angle(*w, _qt_line_angle(*w) + 90.0)
        edges.append((start, w[1]))
    out = []
    for i in range(len(edges)):
        v = _qt_intersect(edges[i - 1], edges[i])
        assert v is not None, "QGroundControl stops offsetting here (parallel edges)"
        out.append(from_plane(v[0], v[1], lat0, lon0, frame))  # convertNedToGeo(y north, x east)
    return out


@dataclass
class StructureScan:
    ring: list[tuple[float, float]]  # the flight polygon, (lat, lon)
    layers: list[float]  # the layers' altitudes above home, in flight order
    trigger_m: float
    camera_shots: int
    items: list[tuple[int, float, float, float, float, float, float, float]]  # (command, p1..p4, x, y, z) as uploaded


def regenerate_structure_scan(item: dict[str, Any], frame: str = "ellipsoid") -> StructureScan:
    """What QGroundControl makes of a Structure Scan item it loads (`frame`: its plane, FRAMES)."""
    cam = item["CameraCalc"]
    ring = qgc_offset([tuple(p) for p in item["polygon"]], float(cam["DistanceToSurface"]), frame)
    frontal, side = float(cam["AdjustedFootprintFrontal"]), float(cam["AdjustedFootprintSide"])
    layers = max(math.ceil(max(float(item["StructureHeight"]) - float(item["ScanBottomAlt"]), 0.0) / frontal), 1)
    top = bool(item["StartFromTop"])
    alt = float(item["StructureHeight"]) - frontal / 2.0 if top else float(item["ScanBottomAlt"]) + frontal / 2.0
    alts = [alt - k * frontal if top else alt + k * frontal for k in range(layers)]
    nan = float("nan")
    entrance = float(item["EntranceAltitude"])
    items = [(16, 0.0, 0.0, 0.0, nan, ring[0][0], ring[0][1], entrance),
             (196, 0.0, 0.0, 0.0, 0.0, float(item["GimbalPitch"]), 0.0, 90.0)]
    for z in alts:
        for j, (a, b) in enumerate(ring + [ring[0]]):
            items.append((16, 0.0, 0.0, 0.0, nan, a, b, z))
            if j == 0:
                items.append((206, side, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0))
        items.append((206, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    items += [(197, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), (16, 0.0, 0.0, 0.0, nan, ring[0][0], ring[0][1], entrance)]
    perimeter = sum(sphere_distance(ring[i], ring[(i + 1) % len(ring)]) for i in range(len(ring)))
    return StructureScan(ring, alts, side, int(perimeter / side) * layers, items)
