"""A flight log's result folder (`aerosurvey log ingest` output) as map layers: the flown
camera positions and the flown-coverage raster, in the plan's map frame."""

from __future__ import annotations

import base64
import io
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.flight import MIN_GAP_DEFAULT_M2, records
from aerosurvey.flight.ingest import distance_text, far_from_plan
from aerosurvey.manifest import Manifest
from aerosurvey.rules.flown import PLACES_FILE
from aerosurvey.web.mapproj import MapFrame

if TYPE_CHECKING:
    from aerosurvey.rules.planview import PlanView

#: Gaps smaller than this are left out, on the map and in the page's re-fly (as `aerosurvey refly` by default).
MIN_GAP_M2 = MIN_GAP_DEFAULT_M2

#: Colours for photo counts 1, 2, 3 … (0 stays transparent); the last repeats beyond.
_RAMP = np.array([[215, 48, 39], [244, 109, 67], [253, 174, 97], [254, 224, 139], [217, 239, 139],
                  [166, 217, 106], [102, 189, 99], [26, 152, 80], [0, 104, 55]], dtype=np.uint8)


def flown_layers(files: dict[str, Path], frame: MapFrame, plan: Manifest | None = None,
                 plan_view: PlanView | None = None) -> dict[str, Any]:
    """Layers from the uploaded files: events.csv (required), coverage.tif, log_report.json and
    failing_places.geojson (`aerosurvey check FOLDER`: where the rules fail on what was flown), optional.
    With the plan as the rules see it (`plan_view`), `gaps` is the ground of the area fewer flown
    photos see than the plan needs (what `aerosurvey refly` would re-fly), in WGS84.

    Results of another mission are refused as `log ingest` refuses a log of another plan:
    with the page's plan (`plan`: its manifest) when the events lie a median of more than one
    footprint from its stations or the report names another mission; without it, when they lie
    outside the plan's map frame.
    """
    if "events.csv" not in files:
        raise InputError(f"flight results: events.csv is missing among {sorted(files) or 'no files'}; choose the folder "
                         "written by `aerosurvey log ingest`", key="flight")
    try:
        rows = records.read_events_csv(files["events.csv"])
        report = records.read_report(files["log_report.json"]) if "log_report.json" in files else None
    except InputError as exc:
        raise InputError(f"flight results: {exc}", key="flight") from None
    _same_plan(rows, report, frame, plan)
    out: dict[str, Any] = {"events": _events(rows, frame)}
    if "coverage.tif" in files:
        out["coverage"] = _coverage(files["coverage.tif"], frame)
    if PLACES_FILE in files:
        out["failing"], out["rules"] = _failing_places(files[PLACES_FILE])
    if "coverage.tif" in files and plan_view is not None:
        out["gaps"] = _gaps(files["coverage.tif"], plan_view)
    if report is not None:
        out["report"] = {k: report.get(k) for k in ("log", "events", "planned", "matched", "missed_stations", "extra_triggers",
                                                  "far_triggers", "coverage", "realized") if k in report}
    return out


def _same_plan(rows: records.EventRows, report: dict[str, Any] | None, frame: MapFrame, doc: Manifest | None) -> None:
    flown = ((report or {}).get("plan") or {}).get("mission")
    of = f" of mission {flown!r}" if flown else ""
    if doc is not None:
        med, limit = far_from_plan(rows.lon, rows.lat, doc)
        if flown is not None and flown != doc.mission.name:
            where = f" (their camera events lie a median {distance_text(med)} from its stations)" if math.isfinite(med) else ""
            raise InputError(f"flight results of mission {flown!r} are not of this plan, mission {doc.mission.name!r}{where}: "
                             "load the results of a flight of this plan", key="flight")
        if math.isfinite(med) and med > limit:
            raise InputError(f"flight results{of} are not of this plan, mission {doc.mission.name!r}: their camera events "
                             f"lie a median {distance_text(med)} from the nearest planned station, more than one footprint "
                             f"({limit:.0f} m)", key="flight")
        return
    x, y = frame.from_lonlat(rows.lon, rows.lat)
    d = np.hypot(x, y)
    d = d[np.isfinite(d)]
    if d.size and float(np.median(d)) > frame.half:
        raise InputError(f"flight results{of} are not of this plan: their camera events lie a median "
                         f"{distance_text(float(np.median(d)))} from the plan's area, outside its map; load the results "
                         "of a flight of this plan", key="flight")


def _events(rows: records.EventRows, frame: MapFrame) -> dict[str, Any]:
    x, y = frame.from_lonlat(rows.lon, rows.lat)
    return {"x": np.round(x, 2).tolist(), "y": np.round(y, 2).tolist(),
            "station": [s or "" for s in rows.station], "event": [str(int(e)) for e in rows.event]}


def _coverage(path: Path, frame: MapFrame) -> dict[str, Any]:
    """The count raster warped to Web Mercator and coloured, as a PNG with its frame bounds."""
    import rasterio
    from PIL import Image
    from rasterio.errors import RasterioIOError
    from rasterio.warp import Resampling, calculate_default_transform, reproject

    try:
        src = rasterio.open(path)
    except RasterioIOError as exc:
        raise InputError(f"flight results: coverage.tif cannot be read: {exc}", key="flight") from None
    with src:
        if src.crs is None:
            raise InputError("flight results: coverage.tif has no CRS", key="flight")
        transform, width, height = calculate_default_transform(src.crs, "EPSG:3857", src.width, src.height, *src.bounds)
        scale = max(1.0, max(width, height) / 2048)  # a browser image of at most 2048 px a side
        width, height = int(width / scale), int(height / scale)
        transform = transform * transform.scale(scale, scale)
        dst = np.zeros((height, width), dtype=np.uint16)
        reproject(rasterio.band(src, 1), dst, dst_transform=transform, dst_crs="EPSG:3857", resampling=Resampling.nearest)
    rgba = np.zeros((height, width, 4), dtype=np.uint8)
    seen = dst > 0
    rgba[seen, :3] = _RAMP[np.minimum(dst[seen], len(_RAMP)) - 1]
    rgba[seen, 3] = 170
    buf = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(buf, format="PNG")
    x0, y1 = transform * (0, 0)
    x1, y0 = transform * (width, height)
    return {"png": "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii"),
            "bounds": [round(x0 - frame.ox, 2), round(y0 - frame.oy, 2), round(x1 - frame.ox, 2), round(y1 - frame.oy, 2)],
            "max_count": int(dst.max()) if dst.size else 0}



def _failing_places(path: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """failing_places.geojson's features with a geometry (WGS84), and one line per rule that fails as flown."""
    from aerosurvey.rules.flown import read_places

    places = read_places(path)
    rules = [{"rule": r.rule, "status": r.status, "statement": r.statement, "places": r.places,
              "evidence": [f"{r.places} failing place(s) on the map"], "measured": f"planned {r.planned} / flown {r.flown}",
              "required": r.required} for r in places.rules]
    return {"type": "FeatureCollection", "features": places.drawn}, rules


def _gaps(coverage: Path, view: PlanView) -> dict[str, Any]:
    """The area's ground seen by fewer flown photos than the plan needs, as `aerosurvey refly` finds it, in WGS84."""
    from aerosurvey.flight.refly import gap_area, gaps_layer

    need = view.document.derived.images_per_point
    return gaps_layer(gap_area(coverage, need, view.area, MIN_GAP_M2), view, need)
