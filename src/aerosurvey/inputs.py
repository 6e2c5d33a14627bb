"""The loader: the files a mission spec names (area, exclusion zones, DEM) read into
`PlanInputs`, the plain data `plan_mission` plans from.

This module is the edge between files and planning; `plan_from_files` is the one call a
command makes to plan a spec as it stands on disk.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import shapely

from aerosurvey.area import read_area, transformer
from aerosurvey.errors import InputError
from aerosurvey.plan.inputs import DemGrid, PlanInputs
from aerosurvey.spec import MissionSpec

if TYPE_CHECKING:
    from pathlib import Path

    from shapely.geometry.base import BaseGeometry

    from aerosurvey.plan.planner import Plan, Progress


def load_geometry(spec: MissionSpec) -> tuple[BaseGeometry, tuple[BaseGeometry, ...]]:
    """The area and the exclusion zones of the spec, in WGS84 (what the web page shows before it plans)."""
    from aerosurvey.plan.pattern import kind_of

    corridor = kind_of(spec.pattern.kind).area_is_centreline
    area = read_area(spec.area.file, spec.area.wkt, spec.area.wkt_crs, "area.file (the corridor)" if corridor else "area",
                     lines=corridor)
    return area, tuple(read_area(p, None, "EPSG:4326", f"exclusion zone {p.name}") for p in spec.area.exclusions)


def load_inputs(spec: MissionSpec) -> PlanInputs:
    """Read the area, the exclusion zones and the part of the DEM the plan can reach."""
    area, zones = load_geometry(spec)
    dem = None
    if spec.terrain.dem is not None:
        from aerosurvey.plan.sensor import reach_beyond_area_m

        extra = [shapely.Point(p) for p in ((spec.area.launch,) if spec.area.launch else ())]
        if spec.battery is not None:
            extra += [shapely.Point(p) for p in spec.battery.launch_points]
        dem = read_dem_window(spec.terrain.dem, shapely.union_all([area, *extra]), reach_beyond_area_m(spec))
    return PlanInputs(area, zones, dem)


def plan_from_files(spec: MissionSpec, progress: Progress | None = None) -> Plan:
    """Load the spec's files and plan: what `aerosurvey plan` and the other commands call."""
    from aerosurvey.plan.planner import plan_mission

    return plan_mission(spec, load_inputs(spec), progress)


def read_dem_window(path: Path, around_wgs84: shapely.Geometry, reach_m: float) -> DemGrid:
    """The DEM cells within `reach_m` of a geometry (WGS84), NaN for nodata, as a DemGrid."""
    import rasterio
    import rasterio.errors
    import rasterio.windows

    try:
        ds = rasterio.open(path)
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"terrain.dem: {str(path)!r} cannot be opened as a raster: {exc}") from None
    with ds:
        if ds.crs is None:
            raise InputError(f"terrain.dem: {str(path)!r} has no CRS; give the DEM a georeference (e.g. gdal_edit.py -a_srs)")
        crs_wkt = ds.crs.to_wkt()
        t = transformer("EPSG:4326", crs_wkt)
        g = shapely.transform(around_wgs84, lambda xy: np.column_stack(t.transform(xy[:, 0], xy[:, 1])))
        left, bottom, right, top = g.bounds
        # metres of reach in the DEM's units (degrees for a geographic DEM)
        c = around_wgs84.centroid
        if ds.crs.is_geographic:
            r_x = reach_m / (111_320.0 * max(0.05, math.cos(math.radians(c.y))))
            r_y = reach_m / 110_574.0
        else:
            r_x = r_y = reach_m
        win = rasterio.windows.from_bounds(left - r_x, bottom - r_y, right + r_x, top + r_y, transform=ds.transform)
        win = win.round_offsets(op="floor").round_lengths(op="ceil")
        win = rasterio.windows.Window(win.col_off - 1, win.row_off - 1, win.width + 3, win.height + 3)
        try:
            win = win.intersection(rasterio.windows.Window(0, 0, ds.width, ds.height))
        except rasterio.errors.WindowError:
            b = ds.bounds
            raise InputError(
                f"terrain.dem {path.name!r} does not cover the area: the DEM spans x {b.left:.1f}..{b.right:.1f}, "
                f"y {b.bottom:.1f}..{b.top:.1f} in its CRS, the area x {left:.1f}..{right:.1f}, y {bottom:.1f}..{top:.1f}"
            ) from None
        data = ds.read(1, window=win, masked=True).astype(np.float64).filled(np.nan)
        wt = ds.window_transform(win)
        b = ds.bounds
        return DemGrid(
            name=path.name, heights=data, transform=(wt.a, wt.b, wt.c, wt.d, wt.e, wt.f), crs_wkt=crs_wkt,
            offset=(int(win.col_off), int(win.row_off)), full_shape=(ds.height, ds.width),
            full_bounds=(b.left, b.bottom, b.right, b.top),
        )
