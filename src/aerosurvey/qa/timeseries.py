"""Time series QA: the quality mask of pixels reproducible at every date, and the shift of
objects digitised at each date (Remote Sensing 12 (2020) 3831, sections 2.7 and 3.4).

Shifts are in metres: a projected CRS's unit is converted to metres (its axis unit
factor); in a geographic CRS the shift is measured on the CRS's ellipsoid (pyproj.Geod,
east and north components from the geodesic's azimuth). Without a CRS the shifts are in
the files' own units, and the result says so.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import rasterio
import rasterio.shutil  # used below; importing rasterio alone does not load it
import shapely
from rasterio.enums import Resampling
from rasterio.vrt import WarpedVRT
from rasterio.windows import Window

from aerosurvey.errors import InputError
from aerosurvey.qa.repro_core import NODATA


def quality_mask(dirs: list[Path], stage: Path, block: int = 1024) -> dict[str, Any]:
    """1 where every date's layer says 'reproducible in all pairs', 0 where judged and not, 255 elsewhere."""
    layers = []
    for d in dirs:
        tif, summ = d / "reproducibility.tif", d / "summary.json"
        if not tif.exists() or not summ.exists():
            raise InputError(f"{d}: needs reproducibility.tif and summary.json from `aerosurvey qa reproducibility`")
        layers.append((tif, int(json.loads(summ.read_text())["pairs"])))
    with rasterio.open(layers[0][0]) as first:
        profile = first.profile.copy()
        grid = (first.crs, first.transform, first.width, first.height)
    profile.update(driver="GTiff", tiled=True, blockxsize=512, blockysize=512, compress="deflate", nodata=NODATA)
    counts = np.zeros(2, np.int64)
    tmp = stage / ".mask.tif"
    with rasterio.open(tmp, "w", **profile) as dst:
        srcs = []
        for tif, _ in layers:
            ds = rasterio.open(tif)
            srcs.append(ds if (ds.crs, ds.transform, ds.width, ds.height) == grid else
                        WarpedVRT(ds, crs=grid[0], transform=grid[1], width=grid[2], height=grid[3],
                                  resampling=Resampling.nearest, nodata=NODATA))
        try:
            for r in range(0, grid[3], block):
                for c in range(0, grid[2], block):
                    win = Window(c, r, min(block, grid[2] - c), min(block, grid[3] - r))
                    ok = np.ones((win.height, win.width), bool)
                    judged = np.ones_like(ok)
                    for src, (_, n) in zip(srcs, layers):
                        a = src.read(1, window=win)
                        judged &= a != NODATA
                        ok &= a == n
                    out = np.where(judged, ok.astype(np.uint8), NODATA).astype(np.uint8)
                    counts += np.array([int((out == 1).sum()), int((out == 0).sum())], np.int64)
                    dst.write(out, 1, window=win)
        finally:
            for s in srcs:
                s.close()
    rasterio.shutil.copy(tmp, stage / "quality_mask.tif", driver="COG", compress="DEFLATE")
    tmp.unlink()
    n_judged = int(counts.sum())
    return {"dates": [str(d) for d in dirs], "judged_pixels": n_judged,
            "reproducible_in_every_date_share": float(counts[0] / n_judged) if n_judged else float("nan")}


def _objects(path: Path, id_field: str) -> tuple[dict[str, shapely.Geometry], Any]:
    import pyogrio

    if not path.exists():
        raise InputError(f"{path}: does not exist")
    try:
        meta, _, wkb, fields = pyogrio.raw.read(path)
    except Exception as exc:
        raise InputError(f"{path}: cannot be read as a vector file: {exc}") from None
    names = list(meta["fields"])
    if id_field not in names:
        raise InputError(f"{path}: no field {id_field!r} (fields: {', '.join(names)}); give --id-field")
    ids = [str(v) for v in fields[names.index(id_field)]]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise InputError(f"{path}: duplicate {id_field} value(s) {', '.join(dup[:5])}")
    return dict(zip(ids, shapely.from_wkb(wkb))), meta.get("crs")


def _metric(crs_text: str | None) -> tuple[str, Any]:
    """(unit, converter): a function of (x0, y0, x1, y1) arrays giving east, north in metres."""
    if not crs_text or crs_text == "None":
        return "CRS units (no CRS stated)", lambda x0, y0, x1, y1: (x1 - x0, y1 - y0)
    try:
        crs = pyproj.CRS.from_user_input(crs_text)
    except pyproj.exceptions.CRSError:
        raise InputError(f"the object files' CRS {crs_text!r} is not one pyproj knows") from None
    if crs.is_geographic:
        geod = crs.get_geod() or pyproj.Geod(ellps="WGS84")

        def geodesic(x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            az, _, d = geod.inv(x0, y0, x1, y1)
            az = np.radians(np.asarray(az, float))
            return np.asarray(d) * np.sin(az), np.asarray(d) * np.cos(az)

        return "m", geodesic
    f = float(crs.axis_info[0].unit_conversion_factor) if crs.axis_info else 1.0
    return "m", lambda x0, y0, x1, y1: ((x1 - x0) * f, (y1 - y0) * f)


def object_shift(paths: list[Path], id_field: str = "id") -> dict[str, Any]:
    """Shift (m) of each object's centroid and largest bounding-box corner shift from the first date to every later one."""
    if len(paths) < 2:
        raise InputError("give the objects of at least two dates")
    dates = [_objects(p, id_field) for p in paths]
    crs = {str(c) for _, c in dates}
    if len(crs) > 1:
        raise InputError(f"the object files are in different CRSs ({', '.join(sorted(crs))}); use one")
    unit, to_en = _metric(next(iter(crs)))
    base = dates[0][0]
    rows, per_date = [], []
    for k, (objs, _) in enumerate(dates[1:], start=1):
        common = sorted(set(base) & set(objs))
        d = []
        for oid in common:
            a, b = base[oid], objs[oid]
            ca, cb = a.centroid, b.centroid
            ba, bb = np.asarray(a.bounds), np.asarray(b.bounds)
            ex, ny = to_en(np.array([ca.x]), np.array([ca.y]), np.array([cb.x]), np.array([cb.y]))
            cx, cy = to_en(ba[[0, 2, 0, 2]], ba[[1, 1, 3, 3]], bb[[0, 2, 0, 2]], bb[[1, 1, 3, 3]])
            shift_c = float(np.hypot(ex[0], ny[0]))
            rows.append({"id": oid, "date": paths[k].name, "dx_m": float(ex[0]), "dy_m": float(ny[0]),
                         "centroid_shift_m": shift_c, "bbox_corner_shift_max_m": float(np.max(np.hypot(cx, cy)))})
            d.append(shift_c)
        per_date.append({"date": paths[k].name, "objects": len(common), "missing": sorted(set(base) - set(objs)),
                         "centroid_shift_mean_m": float(np.mean(d)) if d else float("nan"),
                         "centroid_shift_median_m": float(np.median(d)) if d else float("nan"),
                         "centroid_shift_max_m": float(np.max(d)) if d else float("nan")})
    return {"reference": paths[0].name, "id_field": id_field, "unit": unit, "crs": next(iter(crs)),
            "per_date": per_date, "objects": rows}
