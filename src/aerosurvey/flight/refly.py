"""Re-fly mission for the gaps: where the flown coverage is below what the plan needs."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import rasterio
import rasterio.features
import shapely


def gap_area(coverage_tif: Path, need: int, area_plan: shapely.Geometry, min_area_m2: float) -> shapely.Geometry:
    """Polygons (planning CRS) of the area's cells seen by fewer than `need` photos."""
    with rasterio.open(coverage_tif) as ds:
        counts = ds.read(1)
        transform = ds.transform
    short = (counts < need).astype(np.uint8)
    polys = [shapely.geometry.shape(g) for g, v in rasterio.features.shapes(short, mask=short == 1, transform=transform) if v == 1]
    if not polys:
        return shapely.Polygon()
    gaps = shapely.intersection(shapely.union_all(polys), area_plan)
    parts = [p for p in shapely.get_parts(gaps) if p.area >= min_area_m2]
    return shapely.union_all(parts) if parts else shapely.Polygon()


def refly_spec(spec_path: Path, gaps_plan: shapely.Geometry, crs: str) -> dict[str, Any]:
    """The original spec with the gaps (in WGS84 WKT) as its area."""
    data = tomllib.loads(spec_path.read_text(encoding="utf-8"))
    t = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    gaps_ll = shapely.transform(gaps_plan, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
    area = dict(data.get("area", {}))
    area.pop("file", None)
    area["wkt"] = gaps_ll.wkt
    area["wkt_crs"] = "EPSG:4326"
    data["area"] = area
    base = spec_path.parent
    for key in ("exclusions",):
        if key in area:
            area[key] = [str((base / p).resolve()) for p in area[key]]
    if "terrain" in data and "dem" in data["terrain"]:
        data["terrain"]["dem"] = str((base / data["terrain"]["dem"]).resolve())
    data.setdefault("mission", {})["name"] = data.get("mission", {}).get("name", spec_path.stem) + "-refly"
    return data


def needed_images(manifest: dict[str, Any]) -> int:
    d = manifest["derived"]
    return int(d["side_images_per_point"]) * int(d["forward_images_per_point"])
