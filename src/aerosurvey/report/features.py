"""The plan as GeoJSON features in WGS84: area, exclusion zones, lines, stations, footprints.

Every feature has a `role` and an `id` that matches the manifest, so a GIS user can join
the layers with the manifest and later with flight logs.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

from aerosurvey import ids
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


def plan_features(plan: Plan, with_footprints: bool = True) -> dict[str, Any]:
    feats: list[dict[str, Any]] = []
    feats.append({"type": "Feature", "id": "area", "properties": {"role": "area", "id": "area", "area_ha": round(plan.area.area / 1e4, 4)},
                  "geometry": {"type": plan.area_wgs84.geom_type, "coordinates": _coords(plan.area_wgs84)}})
    for i, z in enumerate(plan.exclusions_wgs84, start=1):
        feats.append({"type": "Feature", "id": f"exclusion-{i}", "properties": {"role": "exclusion", "id": f"exclusion-{i}"},
                      "geometry": {"type": z.geom_type, "coordinates": _coords(z)}})
    st = plan.stations
    from aerosurvey.mission.builder import run_id

    for i, r in enumerate(plan.route.runs):
        sel = np.flatnonzero(st.run == i)
        coords = [[_r(st.lon[j]), _r(st.lat[j])] for j in (sel[0], sel[-1])]
        rid = run_id(plan, i)
        feats.append({"type": "Feature", "id": rid, "properties": {
            "role": "line", "id": rid, "line": ids.line_id(r.pass_index, r.line), "pass": r.pass_index,
            "heading_deg": round(r.heading_deg, 3), "photos": int(len(sel)), "first_station": st.ids[sel[0]],
            "last_station": st.ids[sel[-1]]}, "geometry": {"type": "LineString", "coordinates": coords}})
    lonlat = np.round(np.column_stack([st.lon, st.lat]), 8).tolist()
    alt = np.round(st.alt_rel_m, 2).tolist()
    agl = np.round(st.agl_m, 2).tolist()
    hdg = np.round(st.heading_deg, 3).tolist()
    for j, sid in enumerate(st.ids):
        feats.append({"type": "Feature", "id": sid, "properties": {
            "role": "station", "id": sid, "seq": j + 1, "line": sid.rsplit("-", 1)[0],
            "alt_rel_m": alt[j], "agl_m": agl[j], "heading_deg": hdg[j]},
            "geometry": {"type": "Point", "coordinates": lonlat[j]}})
    if with_footprints and len(st.ids):
        cam = plan.spec.camera.camera
        across, along = pg.footprint(st.agl_m, cam, plan.spec.camera.mount)
        k = plan.grid_scale
        corners = footprint_corners(st.x, st.y, st.heading_deg, np.asarray(across, float) * k, np.asarray(along, float) * k)
        lon, lat = plan.planar.lonlat(corners[..., 0].ravel(), corners[..., 1].ravel())
        ring = np.round(np.stack([lon.reshape(-1, 4), lat.reshape(-1, 4)], axis=-1), 8)
        rings = np.concatenate([ring, ring[:, :1]], axis=1).tolist()
        for j, sid in enumerate(st.ids):
            feats.append({"type": "Feature", "id": f"{sid}-fp", "properties": {"role": "footprint", "id": f"{sid}-fp", "station": sid},
                          "geometry": {"type": "Polygon", "coordinates": [rings[j]]}})
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
