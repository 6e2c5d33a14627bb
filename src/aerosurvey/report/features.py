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
from aerosurvey.gcpause import collector_paused
from aerosurvey.jsontext import dumps_compact, string_texts
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.footprints import footprint_corners
from aerosurvey.plan.planner import Plan


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
    with collector_paused():
        fc = _features(plan)
        if with_footprints:
            at = _footprints_at(fc)
            fc["features"][at:at] = [json.loads(t) for t in _footprint_texts(plan)]
        return fc


def plan_geojson(plan: Plan) -> tuple[dict[str, Any], str]:
    """The FeatureCollection without footprints (what the KML and the rules read) and the
    text of plan.geojson, which has the footprints too, after the stations.

    The footprints, one per photo, are most of the file; they are written straight from the
    corner arrays, never made into JSON data, and the text is what `plan_features` would give
    `jsontext.dumps_compact` (a test checks it). Measured on the 1,000 ha benchmark (7,309
    photos): making and encoding them as data ~35 ms, this way ~10 ms."""
    with collector_paused():
        fc = _features(plan)
    at = _footprints_at(fc)
    feats = fc["features"]
    head = dumps_compact({"type": fc["type"], "name": fc["name"]})[:-1]
    parts = [dumps_compact(feats[:at])[1:-1], ",".join(_footprint_texts(plan)), dumps_compact(feats[at:])[1:-1]]
    return fc, head + ',"features":[' + ",".join(p for p in parts if p) + "]}"


def _footprints_at(fc: dict[str, Any]) -> int:
    """Where the footprints go: after the last station (or the lines, the zones, the area)."""
    feats = fc["features"]
    return next((i for i in range(len(feats), 0, -1) if feats[i - 1]["properties"]["role"] in ("area", "exclusion", "line", "station")), 0)


def _footprint_texts(plan: Plan) -> list[str]:
    """One GeoJSON Feature text per photo: its footprint on flat ground at the station's height
    above ground, in WGS84, corners rounded to 8 decimals, the ring closed."""
    st = plan.stations
    if not len(st.ids):
        return []
    cam = plan.spec.camera.camera
    across, along = pg.footprint(st.agl_m, cam, plan.spec.camera.mount)
    k = plan.grid_scale
    corners = footprint_corners(st.x, st.y, st.heading_deg, np.asarray(across, float) * k, np.asarray(along, float) * k)
    clon, clat = plan.planar.lonlat(corners[..., 0].ravel(), corners[..., 1].ravel())
    _finite("footprint", clon, clat)
    ring = np.round(np.stack([clon.reshape(-1, 4), clat.reshape(-1, 4)], axis=-1), 8)
    rings = np.concatenate([ring, ring[:, :1]], axis=1)
    # "[[[x,y],…,[x,y]],[[x,y],…,[x,y]]]": split between rings (numbers hold no "]"), each piece "x,y],…,[x,y"
    each = dumps_compact(rings)[3:-3].split("]],[[")
    template = ('{"type":"Feature","id":%s,"properties":{"role":"footprint","id":%s,"station":%s},'
                '"geometry":{"type":"Polygon","coordinates":[[[%s]]]}}')
    sids = string_texts(st.ids)
    fids = string_texts([f"{sid}-fp" for sid in st.ids])
    return list(map(template.__mod__, zip(fids, fids, sids, each)))


def _features(plan: Plan) -> dict[str, Any]:
    feats: list[dict[str, Any]] = []
    feats.append({"type": "Feature", "id": "area", "properties": {"role": "area", "id": "area", "area_ha": round(plan.area.area / 1e4, 4)},
                  "geometry": {"type": plan.area_wgs84.geom_type, "coordinates": _coords(plan.area_wgs84)}})
    for i, z in enumerate(plan.exclusions_wgs84, start=1):
        feats.append({"type": "Feature", "id": f"exclusion-{i}", "properties": {"role": "exclusion", "id": f"exclusion-{i}"},
                      "geometry": {"type": z.geom_type, "coordinates": _coords(z)}})
    st = plan.stations
    from aerosurvey.mission.builder import run_id

    # each run's first and last station (stations are in flight order; a stable sort keeps it within a run)
    order = np.argsort(st.run, kind="stable")
    ends = np.cumsum(np.bincount(st.run, minlength=len(plan.route.runs)))
    lonlat = np.round(np.column_stack([st.lon, st.lat]), 8).tolist()
    for i, r in enumerate(plan.route.runs):
        first, last = int(order[ends[i - 1] if i else 0]), int(order[ends[i] - 1])
        rid = run_id(plan, i)
        feats.append({"type": "Feature", "id": rid, "properties": {
            "role": "line", "id": rid, "line": ids.line_id(r.pass_index, r.line), "pass": r.pass_index,
            "heading_deg": round(r.heading_deg, 3), "photos": int(ends[i] - (ends[i - 1] if i else 0)),
            "first_station": st.ids[first], "last_station": st.ids[last]},
            "geometry": {"type": "LineString", "coordinates": [[_r(st.lon[j]), _r(st.lat[j])] for j in (first, last)]}})
    _finite("station", st.lon, st.lat, st.alt_rel_m, st.agl_m, st.heading_deg)  # the GeoJSON writer writes NaN as null
    alt = np.round(st.alt_rel_m, 2).tolist()
    agl = np.round(st.agl_m, 2).tolist()
    hdg = np.round(st.heading_deg, 3).tolist()
    feats += [{"type": "Feature", "id": sid, "properties": {
        "role": "station", "id": sid, "seq": seq, "line": sid.rsplit("-", 1)[0], "alt_rel_m": a, "agl_m": g, "heading_deg": h},
        "geometry": {"type": "Point", "coordinates": xy}}
        for seq, sid, a, g, h, xy in zip(range(1, len(st.ids) + 1), st.ids, alt, agl, hdg, lonlat)]
    for i, part in enumerate(plan.coverage.polygons(), start=1):
        feats.append({"type": "Feature", "id": f"uncovered-{i}", "properties": {
            "role": "uncovered", "id": f"uncovered-{i}", "area_m2": round(part.area / plan.grid_scale ** 2, 2),
            "min_images": 2}, "geometry": {"type": "Polygon", "coordinates": _coords(plan.planar.inverse(part))}})
    hlon, hlat, _ = plan.home
    feats.append({"type": "Feature", "id": "home", "properties": {"role": "home", "id": "home"},
                  "geometry": {"type": "Point", "coordinates": [_r(hlon), _r(hlat)]}})
    if not all(math.isfinite(v) for v in (hlon, hlat)):
        raise ValueError("home position is not finite")
    return {"type": "FeatureCollection", "name": plan.spec.name, "features": feats}
