"""Control point files for the field crew: GeoJSON, CSV (with an empty `elevation` column for
the surveyed height: `aerosurvey log gcp-list --surveyed` reads it back), GPX.

The CSV's last column `WKT` is each point in WGS84 longitude/latitude, the column GDAL's CSV
driver makes the geometry without being told, and control_points.prj beside it (GDAL reads a
.prj of the same name) gives that CRS, so QGIS and ogr2ogr place the points as they open it.

OpenDroneMap's gcp_list.txt names images and pixel positions measured in them, so it is made
after the flight from image marks (flight/handoff.py), never from planned stations."""

from __future__ import annotations

import csv
import io
import json
from html import escape

import numpy as np
import pyproj

from aerosurvey.errors import InputError
from aerosurvey.reproject import planar
from aerosurvey.rules.control_points import ControlPoint, Role, seen_by
from aerosurvey.rules.footprints import FloatArray, coarsest_gsd_m, footprints
from aerosurvey.rules.planview import PlanView


def _lonlat(view: PlanView, pts: list[ControlPoint]) -> tuple[FloatArray, FloatArray]:
    lon, lat = planar(view.crs).lonlat(np.array([p.x for p in pts], float), np.array([p.y for p in pts], float))
    return np.atleast_1d(lon), np.atleast_1d(lat)


def target_size_cm(view: PlanView, factor: float = 3.5) -> float:
    """Side of a GCP target: `factor` times the coarsest photo's GSD, in cm to 1 mm."""
    return round(factor * coarsest_gsd_m(view) * 100, 1)


def to_geojson(view: PlanView, pts: list[ControlPoint]) -> str:
    lon, lat = _lonlat(view, pts)
    size = target_size_cm(view)
    feats = [{"type": "Feature", "id": p.id, "properties": {
        "id": p.id, "role": p.role, "images": p.images, "target_size_cm": size, "easting": round(p.x, 3),
        "northing": round(p.y, 3), "crs": view.crs, "note": p.note},
        "geometry": {"type": "Point", "coordinates": [round(float(lo), 8), round(float(la), 8)]}}
        for p, lo, la in zip(pts, lon, lat)]
    return json.dumps({"type": "FeatureCollection", "name": "control_points", "features": feats}, indent=1) + "\n"


def to_csv(view: PlanView, pts: list[ControlPoint]) -> str:
    lon, lat = _lonlat(view, pts)
    size = target_size_cm(view)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["id", "role", "easting", "northing", "elevation", "lat", "lon", "crs", "target_size_cm", "images", "note",
                "WKT"])
    for p, lo, la in zip(pts, lon, lat):
        w.writerow([p.id, "GCP" if p.role == "gcp" else "CP", f"{p.x:.3f}", f"{p.y:.3f}", "", f"{la:.8f}", f"{lo:.8f}",
                    view.crs, size, p.images, p.note, f"POINT ({lo:.8f} {la:.8f})"])
    return buf.getvalue()


def to_gpx(view: PlanView, pts: list[ControlPoint]) -> str:
    lon, lat = _lonlat(view, pts)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<gpx version="1.1" creator="aerosurvey" xmlns="http://www.topografix.com/GPX/1/1">']
    for p, lo, la in zip(pts, lon, lat):
        kind = "ground control point" if p.role == "gcp" else "check point"
        lines.append(f'  <wpt lat="{la:.8f}" lon="{lo:.8f}"><name>{escape(p.id)}</name>'
                     f'<desc>{escape(kind)}, target {target_size_cm(view)} cm, seen by {p.images} planned photos</desc>'
                     f'<sym>{"Flag, Red" if p.role == "gcp" else "Flag, Blue"}</sym></wpt>')
    lines.append("</gpx>")
    return "\n".join(lines) + "\n"


def control_point_files(view: PlanView, pts: list[ControlPoint]) -> dict[str, str]:
    return {
        "control_points.geojson": to_geojson(view, pts),
        "control_points.csv": to_csv(view, pts),
        "control_points.gpx": to_gpx(view, pts),
        "control_points.prj": pyproj.CRS("EPSG:4326").to_wkt("WKT1_ESRI") + "\n",
    }


def _layout_point(f: object, i: int, where: str) -> tuple[str, Role, float, float, str]:
    """(id, role, longitude, latitude, note) of feature `i` of a control point GeoJSON."""
    props = f.get("properties", {}) if isinstance(f, dict) else None
    if not isinstance(props, dict):
        raise InputError(f"{where}: feature {i + 1} is not a GeoJSON feature with properties")
    role: Role
    if props.get("role") == "gcp":
        role = "gcp"
    elif props.get("role") == "check":
        role = "check"
    else:
        raise InputError(f"{where}: feature {i + 1} has role {props.get('role')!r}; allowed: gcp, check")
    geometry = f.get("geometry") if isinstance(f, dict) else None
    coords = geometry.get("coordinates") if isinstance(geometry, dict) else None
    if not isinstance(coords, list) or len(coords) < 2 or not all(isinstance(c, (int, float)) for c in coords[:2]):
        raise InputError(f"{where}: feature {i + 1} has no point coordinates [longitude, latitude]")
    return str(props.get("id", f"P{i + 1}")), role, coords[0], coords[1], str(props.get("note", ""))


def read_layout(text: str, view: PlanView, where: str) -> list[ControlPoint]:
    """Control points from a control_points.geojson; images per point are measured again on the view's photos."""
    return seen_by(footprints(view), layout_points(text, view, where))


def layout_points(text: str, view: PlanView, where: str) -> list[ControlPoint]:
    """Control points from a control_points.geojson, in the view's CRS, their images not counted (0)."""
    try:
        feats = json.loads(text)["features"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise InputError(f"{where}: not a control point GeoJSON ({exc})") from None
    if not isinstance(feats, list):
        raise InputError(f"{where}: not a control point GeoJSON (features is not a list)")
    pts = []
    for i, f in enumerate(feats):
        pid, role, lon, lat, note = _layout_point(f, i, where)
        x, y = planar(view.crs).xy(np.array([lon], float), np.array([lat], float))
        pts.append(ControlPoint(pid, role, float(x[0]), float(y[0]), 0, note))
    return pts
