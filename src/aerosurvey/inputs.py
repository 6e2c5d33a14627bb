"""The loader: the files a mission spec names (area, exclusion zones, DEM) read into
`PlanInputs`, the plain data `plan_mission` plans from.

This module is the edge between files and planning; `plan_from_files` is the one call a
command makes to plan a spec as it stands on disk.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely

from aerosurvey.area import read_area, transformer
from aerosurvey.errors import InputError
from aerosurvey.plan.inputs import DemGrid, PlanInputs
from aerosurvey.spec import MissionSpec

if TYPE_CHECKING:
    from shapely.geometry.base import BaseGeometry

    from aerosurvey.airspace.model import Airspace, Geozone
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
        extra += [shapely.Point(p) for p in spec.flight.rally_points]
        dem = read_dem_window(spec.terrain.dem, shapely.union_all([area, *extra]), reach_beyond_area_m(spec))
    return PlanInputs(area, zones, dem, load_airspace(spec, area), load_structure(spec))


#: the sides of a round structure's footprint (`structure.centre`, `structure.radius_m`): a polygon round the circle,
#: so the structure the plan keeps off and covers holds the round one (its sides 0.12 % of the radius outside it)
CIRCLE_SIDES = 64


def load_structure(spec: MissionSpec) -> BaseGeometry | None:
    """[structure]'s footprint (WGS84), one polygon; None without [structure]. A round structure's is the
    regular polygon of CIRCLE_SIDES whose sides touch its circle, laid in an azimuthal equidistant projection
    about its centre."""
    if spec.structure is None:
        return None
    if spec.structure.file is None:
        assert spec.structure.centre is not None and spec.structure.radius_m is not None
        lon, lat = spec.structure.centre
        k = np.arange(CIRCLE_SIDES) * 2.0 * math.pi / CIRCLE_SIDES
        r = spec.structure.radius_m / math.cos(math.pi / CIRCLE_SIDES)
        local = f"+proj=aeqd +lat_0={lat} +lon_0={lon} +datum=WGS84 +units=m"
        x, y = transformer(local, "EPSG:4326").transform(r * np.sin(k), r * np.cos(k))
        return shapely.Polygon(np.column_stack([x, y]))
    shape = read_area(spec.structure.file, None, "EPSG:4326", "structure.file")
    if shape.geom_type != "Polygon":
        raise InputError(f"structure.file {spec.structure.file.name!r} holds a {shape.geom_type} of "
                         f"{len(shapely.get_parts(shape))} parts; allowed: one polygon (the structure's footprint)",
                         key="structure.file")
    return shape


def load_airspace(spec: MissionSpec, area_wgs84: BaseGeometry) -> Airspace | None:
    """The official zone files of [airspace] zones, each read whole (airspace/read.py), with the authorisations and
    the planned window; None without zone files. A file whose zones all lie far from the area but would lie over it
    read latitude first is refused: its coordinates are in the wrong order."""
    if not spec.airspace.zones:
        if spec.airspace.authorisations:
            raise InputError("airspace.authorisations is given but airspace.zones names no zone file", key="airspace.authorisations")
        return None
    from aerosurvey.airspace.model import Airspace
    from aerosurvey.airspace.read import read_zone_file

    zones: list[Geozone] = []
    for path in spec.airspace.zones:
        read = read_zone_file(path)
        _check_order(read, path, area_wgs84)
        zones.extend(read)
    known = {z.identifier for z in zones}
    unknown = [a for a in spec.airspace.authorisations if a not in known]
    if unknown:
        raise InputError(f"airspace.authorisations names {', '.join(repr(a) for a in unknown)}, no zone of the zone files "
                         f"({', '.join(p.name for p in spec.airspace.zones)}): give the identifiers of the zones you are "
                         "authorised for", key="airspace.authorisations")
    c = spec.conditions
    window = (c.start, c.end) if c.start is not None and c.end is not None else None
    return Airspace(tuple(zones), tuple(str(p) for p in spec.airspace.zones), spec.airspace.authorisations, window)


#: a zone file none of whose zones lies within this many degrees of the area is checked for swapped coordinates
_ORDER_REACH_DEG = 1.0


def _check_order(zones: Sequence[Geozone], path: Path, area_wgs84: BaseGeometry) -> None:
    pts = np.array([shapely.get_coordinates(z.outline).mean(axis=0) for z in zones])
    near = shapely.dwithin(shapely.points(pts), area_wgs84, _ORDER_REACH_DEG)
    swapped = shapely.dwithin(shapely.points(pts[:, ::-1]), area_wgs84, _ORDER_REACH_DEG)
    if not near.any() and swapped.any():
        raise InputError(f"zone file {path.name!r}: none of its {len(zones)} zones lies near the area, but read latitude "
                         "first they would: its coordinates seem to be [latitude, longitude]; ED-269 and ED-318 (GeoJSON) "
                         "give [longitude, latitude]", key="airspace.zones")


def planned_spec(plan_dir: Path, given: Path | None, recorded: dict[str, str]) -> Path:
    """The spec the plan was made from: --spec, else the manifest's path beside the plan folder or here; its sha256
    must be the manifest's (a brief or an upload's zone check is of that plan, not of a spec changed since)."""
    from aerosurvey.manifest import sha256_file

    candidates = [given] if given is not None else [plan_dir.parent / recorded["path"], Path(recorded["path"])]
    for path in candidates:
        if path is not None and path.is_file():
            if sha256_file(path) != recorded["sha256"]:
                raise InputError(f"{path} is not the spec {plan_dir} was planned from (its sha256 differs from the "
                                 "manifest's): re-plan it, or give the spec it was made from with --spec")
            return path
    raise InputError(f"the spec {plan_dir} was planned from ({recorded['path']!r}) is not found beside it or here: "
                     "give it with --spec")


def plan_from_files(spec: MissionSpec, progress: Progress | None = None) -> Plan:
    """Load the spec's files and plan: what `aerosurvey plan` and the other commands call."""
    from aerosurvey.plan.planner import plan_mission

    return plan_mission(spec, load_inputs(spec), progress)


def read_dem_window(path: Path, around_wgs84: shapely.Geometry, reach_m: float) -> DemGrid:
    """The DEM cells within `reach_m` of a geometry (WGS84), NaN for nodata, as a DemGrid: read a tile at a time and
    held compressed."""
    import rasterio

    # GDAL's block cache (5 % of the RAM by default) would keep every block read: the window is packed a tile at a time
    with rasterio.Env(GDAL_CACHEMAX=_GDAL_CACHE_MB):
        return _read_dem_window(path, around_wgs84, reach_m)


#: megabytes of GDAL's block cache while a DEM is read
_GDAL_CACHE_MB = 8


def open_dem(path: Path, name: str | None = None) -> Any:
    """The DEM at `path` opened by rasterio (close it); InputError naming it (`name`, else the path) when GDAL cannot
    open it as a raster or it has no CRS."""
    import rasterio
    import rasterio.errors

    name = str(path) if name is None else name
    try:
        ds = rasterio.open(path)
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"terrain.dem: {name!r} cannot be opened as a raster: {exc}", key="terrain.dem") from None
    if ds.crs is None:
        ds.close()
        raise InputError(f"terrain.dem: {name!r} has no CRS; give the DEM a georeference (e.g. gdal_edit.py -a_srs)",
                         key="terrain.dem")
    return ds


def _read_dem_window(path: Path, around_wgs84: shapely.Geometry, reach_m: float) -> DemGrid:
    import rasterio
    import rasterio.errors
    import rasterio.windows

    with open_dem(path) as ds:
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
        wt = ds.window_transform(win)
        b = ds.bounds
        col0, row0 = int(win.col_off), int(win.row_off)

        def read(row: int, col: int, rows: int, cols: int) -> np.ndarray:
            window = rasterio.windows.Window(col0 + col, row0 + row, cols, rows)
            cells: np.ndarray = ds.read(1, window=window, out_dtype="float32")
            cells[ds.read_masks(1, window=window) == 0] = np.nan  # nodata, or outside the file's own mask
            return cells

        try:
            return DemGrid.read_tiles(path.name, (int(win.height), int(win.width)), read,
                                      (wt.a, wt.b, wt.c, wt.d, wt.e, wt.f), crs_wkt, (col0, row0), (ds.height, ds.width),
                                      (b.left, b.bottom, b.right, b.top))
        except rasterio.errors.RasterioIOError as exc:
            raise InputError(f"terrain.dem: {str(path)!r} cannot be read: {exc}") from None
