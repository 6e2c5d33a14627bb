"""The plan as GeoJSON features in WGS84: area, exclusion zones, lines, stations, footprints.

Every feature has a `role` and an `id` that matches the manifest, so a GIS user can join
the layers with the manifest and later with flight logs.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import shapely

from aerosurvey import ids
from aerosurvey.jsontext import Column, dumps_compact, join_rows, pair_texts, quoted_as_is, string_texts
from aerosurvey.manifest import StationTable, run_stations, station_table
from aerosurvey.mission.formats.points import PointLayer
from aerosurvey.plan.capture import MIN_DEPRESSION_DEG, Optics, Photos, bounded_footprint_corners
from aerosurvey.plan.planner import Plan

#: the `footprint` property of a photo with no ground footprint (`capture.bounded_footprints`):
#: its feature (role "no-footprint", so each role stays of one geometry type) is the photo's point
NO_FOOTPRINT = f"none: the image reaches the horizon (a corner less than {MIN_DEPRESSION_DEG:g}° below it)"

#: the photos' footprint corners in WGS84 (`footprint_lonlat`): longitudes, latitudes (four a
#: photo that has a footprint) and which photos have one
FootprintLonLat = tuple[np.ndarray, np.ndarray, np.ndarray]


def _r(v: float, nd: int = 8) -> float:
    return round(float(v), nd)


def _coords(geom: shapely.Geometry) -> Any:
    m = shapely.geometry.mapping(geom)
    return _round_nested(m["coordinates"])


def _round_nested(c: Any) -> Any:
    if isinstance(c, (list, tuple)) and c and isinstance(c[0], (int, float)):
        return [_r(v) for v in c]
    return [_round_nested(x) for x in c]


def _finite(what: str, *arrays: np.ndarray) -> None:
    for a in arrays:
        if not np.isfinite(a).all():
            raise ValueError(f"a {what} position or height is not finite")


def plan_features(plan: Plan, with_footprints: bool = True) -> dict[str, Any]:
    """The plan's FeatureCollection as JSON data (with every footprint as a feature if asked)."""
    table = station_table(plan)
    fc, stations, at = _features(plan, table)
    more = stations.features()
    if with_footprints:
        more += json.loads("[" + _footprints_text(plan) + "]")
    fc["features"][at:at] = more
    return fc


def plan_geojson(plan: Plan, table: StationTable | None = None,
                 corners: FootprintLonLat | None = None) -> tuple[dict[str, Any], PointLayer, str]:
    """The FeatureCollection without stations and footprints, the stations as a PointLayer
    (what the rules read), and the text of plan.geojson: `plan_features`
    as `jsontext.dumps_compact` writes it, and a newline (a test checks it).

    The stations and footprints, one of each per photo, are most of the file: they are
    written straight from their columns and arrays, never made into JSON data. Measured on the
    1,000 ha benchmark (7,309 photos): making and encoding the footprints as data ~35 ms, this
    way ~10 ms. `table`, the manifest's stations if the caller has them, gives the columns
    they share (ids, positions, heights); `corners`, `footprint_lonlat(plan)` if the caller
    has them (plan.gpkg's footprints are made from them too)."""
    table = table or station_table(plan)
    fc, stations, at = _features(plan, table)
    feats = fc["features"]
    head = dumps_compact({"type": fc["type"], "name": fc["name"]})[:-1]
    parts = [dumps_compact(feats[:at])[1:-1], stations.geojson(), _footprints_text(plan, corners), dumps_compact(feats[at:])[1:-1]]
    # one join, the parts comma-separated in it: the stations' and footprints' texts (megabytes) copied once
    pieces = [head, ',"features":[']
    for p in (p for p in parts if p):
        if len(pieces) > 2:
            pieces.append(",")
        pieces.append(p)
    pieces.append("]}\n")
    return fc, stations, "".join(pieces)


def footprint_lonlat(plan: Plan) -> FootprintLonLat:
    """The footprint corners in WGS84 of the photos that have one (`capture.bounded_footprints`),
    four a photo in ring order, as flat longitude and latitude arrays (not checked: `plan_geojson`
    says which is not finite), each on flat ground at the station's height above ground; and the
    mask of those photos."""
    st = plan.stations
    photos = Photos.looking(st.x, st.y, st.agl_m, st.camera_yaw_deg, st.pitch_deg)
    optics = Optics.of(plan.camera.camera, plan.camera.mount)
    corners, bounded = bounded_footprint_corners(photos, optics, 0.0, plan.site.grid_scale)
    return (*plan.site.planar.lonlat(corners[..., 0].ravel(), corners[..., 1].ravel()), bounded)


def _footprints_text(plan: Plan, corners: FootprintLonLat | None = None) -> str:
    """The GeoJSON Features of the photos' footprints (`footprint_lonlat`), comma-separated, in
    WGS84, corners rounded to 8 decimals, the ring closed; after them, for each photo with no
    ground footprint, a feature of role "no-footprint": its point, the property `footprint`
    giving the reason (`NO_FOOTPRINT`)."""
    st = plan.stations
    if not len(st.ids):
        return ""
    clon, clat, bounded = corners if corners is not None else footprint_lonlat(plan)
    _finite("footprint", clon, clat)
    # "x,y" of each corner, four a footprint in order; the ring closes on its first corner
    pairs = pair_texts(np.round(clon, 8), np.round(clat, 8))
    c0, c1, c2, c3 = (pairs[j::4] for j in range(4))
    ring: list[str | list[str]] = ['},"geometry":{"type":"Polygon","coordinates":[[[', c0, "],[", c1, "],[", c2, "],[", c3,
                                   "],[", c0, "]]]}}"]
    none = np.flatnonzero(~bounded)
    point: list[str | list[str]] = [f',"footprint":{dumps_compact(NO_FOOTPRINT)}}},"geometry":{{"type":"Point","coordinates":[',
                                    pair_texts(np.round(st.lon[none], 8), np.round(st.lat[none], 8)), "]}}"]
    sids = list(st.ids)
    texts = [_footprint_rows(sids, np.flatnonzero(bounded), "footprint", ring), _footprint_rows(sids, none, "no-footprint", point)]
    return ",".join(t for t in texts if t)


def _footprint_rows(station_ids: list[str], which: np.ndarray, role: str, geometry: list[str | list[str]]) -> str:
    """Footprint Features of the stations `which`, comma-separated: id, `role`, station, then
    `geometry` (the rest of each feature's text: texts, and columns of one text a station)."""
    sids = [station_ids[i] for i in which.tolist()]
    if not sids:
        return ""
    if quoted_as_is(sids):  # station ids as they are (no JSON text made for each, nor a "-fp" id)
        return join_rows(['{"type":"Feature","id":"', sids, '-fp","properties":{"role":"' + role + '","id":"', sids,
                          '-fp","station":"', sids, '"', *geometry], len(sids), ",")
    fids = string_texts([f"{sid}-fp" for sid in sids])
    return join_rows(['{"type":"Feature","id":', fids, ',"properties":{"role":"' + role + '","id":', fids, ',"station":',
                      string_texts(sids), *geometry], len(sids), ",")


def _line_coords(plan: Plan) -> list[list[list[float]]]:
    """Each run's line as flown with the camera on: its first station, its bends, its last station
    (the bends of every run turned to longitude and latitude in one transform)."""
    st = plan.stations
    runs = plan.route.runs
    bends = np.concatenate([r.bends_xy for r in runs]) if runs else np.zeros((0, 2))
    lon, lat = plan.site.planar.lonlat(bends[:, 0], bends[:, 1])
    corners = [[_r(a), _r(b)] for a, b in zip(lon.tolist(), lat.tolist())]
    at = np.cumsum([0, *(len(r.bends_xy) for r in runs)]).tolist()
    return [[[_r(st.lon[first]), _r(st.lat[first])], *corners[at[i]:at[i + 1]], [_r(st.lon[last]), _r(st.lat[last])]]
            for i, (first, last, _) in enumerate(run_stations(plan))]


def outline_features(plan: Plan) -> list[dict[str, Any]]:
    """plan.geojson's first features: the area (role "area") and each exclusion zone (role "exclusion"),
    WGS84; what the rules' PlanView reads of a plan besides its manifest."""
    area = plan.site.area_wgs84
    area_ha = round(plan.site.area.area / 1e4, 4)
    feats: list[dict[str, Any]] = [{"type": "Feature", "id": "area", "properties": {"role": "area", "id": "area", "area_ha": area_ha},
                                    "geometry": {"type": area.geom_type, "coordinates": _coords(area)}}]
    for i, z in enumerate(plan.site.exclusions_wgs84, start=1):
        feats.append({"type": "Feature", "id": f"exclusion-{i}", "properties": {"role": "exclusion", "id": f"exclusion-{i}"},
                      "geometry": {"type": z.geom_type, "coordinates": _coords(z)}})
    return feats


def _features(plan: Plan, table: StationTable) -> tuple[dict[str, Any], PointLayer, int]:
    """Every feature but the stations and footprints, the stations as columns (those the
    manifest's `table` also has taken from it), and the index of the features where the
    stations (and after them the footprints) belong."""
    feats = outline_features(plan)
    st = plan.stations
    from aerosurvey.mission.builder import run_id

    lines = _line_coords(plan)
    for i, (r, (first, last, photos)) in enumerate(zip(plan.route.runs, run_stations(plan))):
        rid = run_id(plan, i)
        feats.append({"type": "Feature", "id": rid, "properties": {
            "role": "line", "id": rid, "line": ids.line_id(r.pass_index, r.line), "pass": r.pass_index,
            "heading_deg": round(r.heading_deg, 3), "photos": photos,
            "first_station": st.ids[first], "last_station": st.ids[last]},
            "geometry": {"type": "LineString", "coordinates": lines[i]}})
    _finite("station", st.lon, st.lat, st.alt_rel_m, st.agl_m, st.heading_deg)  # the GeoJSON writer writes NaN as null
    n = len(st.ids)
    line_of_run = [ids.line_id(r.pass_index, r.line) for r in plan.route.runs]
    at = len(feats)  # the stations (and after them the footprints) go after the lines
    # the table's columns are rounded as these were (lon, lat 8 decimals, heights 2, heading 3), and finite (above)
    col = table.column
    stations = PointLayer(col("id"), (
        ("role", Column.of_codes(("station",), np.zeros(n, np.intp))), ("id", col("id")), ("seq", col("seq")),
        ("line", Column.of_codes(line_of_run, st.run)),
        ("alt_rel_m", col("alt_rel_m")), ("agl_m", col("agl_m")), ("heading_deg", col("heading_deg"))),
        col("lon"), col("lat"))
    for i, part in enumerate(plan.coverage.polygons(), start=1):
        feats.append({"type": "Feature", "id": f"uncovered-{i}", "properties": {
            "role": "uncovered", "id": f"uncovered-{i}", "area_m2": round(part.area / plan.site.grid_scale ** 2, 2),
            "min_images": 2}, "geometry": {"type": "Polygon", "coordinates": _coords(plan.site.planar.inverse(part))}})
    hlon, hlat, _ = plan.launch.home
    feats.append({"type": "Feature", "id": "home", "properties": {"role": "home", "id": "home"},
                  "geometry": {"type": "Point", "coordinates": [_r(hlon), _r(hlat)]}})
    if not all(math.isfinite(v) for v in (hlon, hlat)):
        raise ValueError("home position is not finite")
    return {"type": "FeatureCollection", "name": plan.name, "features": feats}, stations, at
