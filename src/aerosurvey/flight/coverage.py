"""Coverage actually flown: footprints of the logged photos, a count raster, and the
plan's rules evaluated on them with the same engine as before flight."""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import rasterio
import rasterio.features
import shapely
from rasterio.enums import MergeAlg
from rasterio.transform import from_origin

from aerosurvey.flight.events import Events, Match
from aerosurvey.report.features import footprint_corners


def flown_manifest(manifest: dict[str, Any], ev: Events, match: Match | None, fixed_camera: bool = False) -> dict[str, Any]:
    """The plan's manifest with the logged photos in place of the planned stations.

    Each photo keeps the run of the station it matched (unmatched photos form runs of
    their own by order), its height above home as its height above ground (flat ground;
    DEM heights are not applied here), and its logged yaw as heading. A camera on a nadir
    gimbal (the default) looks straight down; with `fixed_camera` the body's roll and
    pitch move the footprint's centre by h·tan(angle).
    """
    crs = manifest["crs"]["planning"]
    t = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
    x, y = t.transform(ev.lon, ev.lat)
    h = np.where(np.isfinite(ev.rel_alt_m), ev.rel_alt_m, np.nan)
    yaw = np.radians(np.nan_to_num(ev.yaw))
    tilt = 1.0 if fixed_camera else 0.0
    along = tilt * h * np.tan(np.radians(np.nan_to_num(ev.pitch)))
    across = tilt * h * np.tan(np.radians(np.nan_to_num(ev.roll)))
    # nose-down pitch looks backwards, right roll looks left: the footprint centre moves against them
    cx = np.asarray(x) - along * np.sin(yaw) + across * np.cos(yaw)
    cy = np.asarray(y) - along * np.cos(yaw) - across * np.sin(yaw)
    run_of = {s["id"]: s["line"] for s in manifest["stations"]}
    stations = []
    for i in range(len(ev)):
        st = match.station[i] if match is not None else None
        run = run_of.get(st, f"unmatched-{i}") if st else f"unmatched-{i}"
        stations.append({"id": f"E{i + 1:05d}", "seq": i + 1, "line": run, "x": float(cx[i]), "y": float(cy[i]),
                         "lon": float(ev.lon[i]), "lat": float(ev.lat[i]), "agl_m": float(h[i]),
                         "heading_deg": float(np.degrees(yaw[i]) % 360.0)})
    flown = copy.deepcopy(manifest)
    flown["stations"] = stations
    return flown


def count_raster(path: Path, view, cell_m: float) -> dict[str, Any]:
    """GeoTIFF of how many flown photos see each cell, over the area's bounds (planning CRS)."""
    from aerosurvey.rules.footprints import footprints

    fp = footprints(view)
    corners = footprint_corners(fp.x, fp.y, np.degrees(fp.heading_rad), fp.across, fp.along)
    polys = shapely.polygons(corners)
    x0, y0, x1, y1 = view.area.bounds
    pad = cell_m * 2
    width = int(math.ceil((x1 - x0 + 2 * pad) / cell_m))
    height = int(math.ceil((y1 - y0 + 2 * pad) / cell_m))
    transform = from_origin(x0 - pad, y1 + pad, cell_m, cell_m)
    counts = rasterio.features.rasterize(((p, 1) for p in polys), out_shape=(height, width), transform=transform,
                                         fill=0, merge_alg=MergeAlg.add, dtype="uint16")
    inside = rasterio.features.geometry_mask([view.area], out_shape=(height, width), transform=transform, invert=True)
    with rasterio.open(path, "w", driver="GTiff", width=width, height=height, count=1, dtype="uint16",
                       crs=view.crs, transform=transform, compress="deflate", tiled=True) as ds:
        ds.write(counts, 1)
    vals = counts[inside]
    return {"cell_m": cell_m, "min_images_in_area": int(vals.min()) if vals.size else 0,
            "median_images_in_area": float(np.median(vals)) if vals.size else 0.0,
            "uncovered_share": float(np.mean(vals == 0)) if vals.size else 0.0}
