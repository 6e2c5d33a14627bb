"""A flight log's result folder (`aerosurvey log ingest` output) as map layers: the flown
camera positions and the flown-coverage raster, in the plan's map frame."""

from __future__ import annotations

import base64
import csv
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.web.mapproj import MapFrame

#: Colours for photo counts 1, 2, 3 … (0 stays transparent); the last repeats beyond.
_RAMP = np.array([[215, 48, 39], [244, 109, 67], [253, 174, 97], [254, 224, 139], [217, 239, 139],
                  [166, 217, 106], [102, 189, 99], [26, 152, 80], [0, 104, 55]], dtype=np.uint8)


def flown_layers(files: dict[str, Path], frame: MapFrame) -> dict[str, Any]:
    """Layers from the uploaded files: events.csv (required), coverage.tif and log_report.json (optional)."""
    if "events.csv" not in files:
        raise InputError(f"flight results: events.csv is missing among {sorted(files) or 'no files'}; choose the folder "
                         "written by `aerosurvey log ingest`", key="flight")
    out: dict[str, Any] = {"events": _events(files["events.csv"], frame)}
    if "coverage.tif" in files:
        out["coverage"] = _coverage(files["coverage.tif"], frame)
    if "log_report.json" in files:
        try:
            report = json.loads(files["log_report.json"].read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError) as exc:
            raise InputError(f"flight results: log_report.json is not valid JSON: {exc}", key="flight") from None
        out["report"] = {k: report.get(k) for k in ("log", "events", "planned", "matched", "missed_stations", "extra_triggers",
                                                  "far_triggers", "coverage", "realized") if k in report}
    return out


def _events(path: Path, frame: MapFrame) -> dict[str, Any]:
    try:
        rows = list(csv.DictReader(io.StringIO(path.read_text(encoding="utf-8"))))
    except UnicodeDecodeError as exc:
        raise InputError(f"flight results: events.csv is not text: {exc}", key="flight") from None
    if rows and not {"lat", "lon"} <= set(rows[0]):
        raise InputError(f"flight results: events.csv has columns {list(rows[0])}; lat and lon are needed", key="flight")
    try:
        lat = np.array([float(r["lat"]) for r in rows])
        lon = np.array([float(r["lon"]) for r in rows])
    except (TypeError, ValueError) as exc:
        raise InputError(f"flight results: events.csv holds a position that is not a number: {exc}", key="flight") from None
    x, y = frame.from_lonlat(lon, lat)
    return {"x": np.round(x, 2).tolist(), "y": np.round(y, 2).tolist(),
            "station": [r.get("station", "") for r in rows], "event": [r.get("event", "") for r in rows]}


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

