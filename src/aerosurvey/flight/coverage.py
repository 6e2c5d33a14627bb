"""Coverage actually flown: footprints of the logged photos, a count raster, and the
plan's rules evaluated on them with the same engine as before flight."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyproj
import rasterio
import rasterio.errors
import rasterio.features
import shapely
from affine import Affine
from rasterio.enums import MergeAlg
from rasterio.transform import from_origin

from aerosurvey import ids
from aerosurvey.area import Planar, transformer
from aerosurvey.errors import InputError
from aerosurvey.flight.events import Events, Match
from aerosurvey.flight.records import EventRows
from aerosurvey.manifest import Home
from aerosurvey.reproject import planar
from aerosurvey.rules.footprints import Footprints
from aerosurvey.rules.planview import PlanView

if TYPE_CHECKING:
    from aerosurvey.plan.terrain import Dem

#: Ground heights (metres, the DEM's vertical datum) at planning-CRS points; NaN where unknown.
GroundFn = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _centres(x: np.ndarray, y: np.ndarray, h: np.ndarray, roll: np.ndarray, pitch: np.ndarray, yaw_deg: np.ndarray,
             tilt: float) -> tuple[np.ndarray, np.ndarray]:
    """Footprint centres: the camera position, moved by h·tan(angle) when the camera tilts with the body."""
    yaw = np.radians(np.nan_to_num(yaw_deg))
    hh = np.nan_to_num(h)
    along = tilt * hh * np.tan(np.radians(np.nan_to_num(pitch)))
    across = tilt * hh * np.tan(np.radians(np.nan_to_num(roll)))
    # nose-up pitch (positive) looks ahead, right roll (positive) looks left: the footprint centre
    # moves ahead by `along` and to the left by `across` (capture.Attitudes.of_body's camera)
    return x + along * np.sin(yaw) - across * np.cos(yaw), y + along * np.cos(yaw) + across * np.sin(yaw)


def photo_heights(x: np.ndarray, y: np.ndarray, ev: Events, yaw_grid: np.ndarray, tilt: float, ground: GroundFn | None,
                  iterations: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(height above ground, ground height or NaN, centre x, centre y) of each photo; `yaw_grid`
    is each photo's logged yaw as a grid bearing (`Planar.grid_bearing`).

    Without `ground`: the height above home (flat ground). With it: AMSL altitude minus
    the ground under the footprint centre. A tilted camera's centre moves with the height,
    so height and centre are iterated to agreement (a fixed point; each step shrinks the
    error by slope·tan(tilt), so a few steps reach millimetres). Photos whose centre is off
    the DEM or on nodata, or that the DEM puts at or below its surface, keep their height
    above home and have NaN ground.
    """
    home = np.where(np.isfinite(ev.rel_alt_m), ev.rel_alt_m, np.nan)
    if ground is None:
        cx, cy = _centres(x, y, home, ev.roll, ev.pitch, yaw_grid, tilt)
        return home, np.full(len(x), np.nan), cx, cy
    alt = np.asarray(ev.alt_m, float)
    h = home.copy()
    cx, cy = x, y
    for _ in range(iterations if tilt else 1):
        g = np.asarray(ground(cx, cy), float)
        new = np.where(np.isfinite(g) & np.isfinite(alt) & (alt - g > 0), alt - g, home)
        done = np.all((np.abs(new - h) < 1e-4) | ~np.isfinite(new))
        h = new
        cx, cy = _centres(x, y, h, ev.roll, ev.pitch, yaw_grid, tilt)
        if done:
            break
    g = np.asarray(ground(cx, cy), float)
    ok = np.isfinite(g) & np.isfinite(alt) & (alt - g > 0)
    return np.where(ok, alt - g, home), np.where(ok, g, np.nan), cx, cy


@dataclass(frozen=True)
class FlownPhotos:
    """The logged photos in place of the planned stations, in the log's order."""

    ids: tuple[str, ...]  # E00001 …
    station: tuple[str | None, ...]  # the planned station each matched (None: an extra trigger)
    run: tuple[str | None, ...]  # the run of the station each matched (None: an extra on no planned line, `photo_runs`)
    x: np.ndarray  # footprint centre, planning CRS
    y: np.ndarray
    agl_m: np.ndarray
    ground_m: np.ndarray  # NaN where the height above home was used
    yaw_deg: np.ndarray  # the vehicle's logged yaw (a true bearing) turned into a grid bearing at the photo
    #: a photo flight's recorded camera pitch (gimbal convention, −90 straight down): then yaw_deg
    #: is the camera's own (Events.camera_attitude); None: the plan's aim turns with the vehicle
    camera_pitch_deg: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.ids)


def flown_photos(crs: str, run_of: Mapping[str, str], ev: Events, match: Match | None, fixed_camera: bool = False,
                 ground: GroundFn | None = None) -> FlownPhotos:
    """The logged photos with the footprint geometry the rules measure.

    Each photo keeps the run of the station it matched (see :func:`photo_runs`) and its
    logged yaw, a true bearing, as a grid bearing at its place. Its height above ground is the height above home (flat ground)
    unless `ground` gives the terrain, see :func:`photo_heights`. A camera on a nadir gimbal
    (the default) looks straight down; with `fixed_camera` the body's roll and pitch move the
    footprint's centre by h·tan(angle).
    """
    grid = planar(crs)
    x, y = grid.xy(ev.lon, ev.lat)
    yaw = grid.grid_bearing(np.nan_to_num(ev.yaw), x, y)
    h, g, cx, cy = photo_heights(x, y, ev, yaw, 1.0 if fixed_camera and not ev.camera_attitude else 0.0, ground)
    stations = match.station if match is not None else [None] * len(ev)
    return FlownPhotos(tuple(ids.event_id(i + 1) for i in range(len(ev))), tuple(stations), photo_runs(stations, run_of),
                       np.asarray(cx, float), np.asarray(cy, float), np.asarray(h, float), np.asarray(g, float), yaw,
                       np.asarray(ev.pitch, float) if ev.camera_attitude else None)


def recorded_photos(crs: str, run_of: Mapping[str, str], rows: EventRows, fixed_camera: bool,
                    camera_attitude: bool = False) -> FlownPhotos:
    """The photos events.csv records, with the heights above ground `log ingest` gave them (its
    agl_m column: above the DEM or above home) and the footprint centres :func:`flown_photos`
    makes from them; `camera_attitude`: its roll, pitch and yaw are the camera's (a photo
    flight's, Events.camera_attitude). Rows without a position or a height are left out: no
    footprint is known."""
    keep = np.flatnonzero(np.isfinite(rows.lon) & np.isfinite(rows.lat) & np.isfinite(rows.agl_m))
    grid = planar(crs)
    x, y = grid.xy(rows.lon[keep], rows.lat[keep])
    h, yaw = rows.agl_m[keep], grid.grid_bearing(np.nan_to_num(rows.yaw[keep]), x, y)
    cx, cy = _centres(x, y, h, rows.roll[keep], rows.pitch[keep], yaw, 1.0 if fixed_camera and not camera_attitude else 0.0)
    station = [rows.station[i] or None for i in keep]
    return FlownPhotos(tuple(ids.event_id(int(rows.event[i])) for i in keep), tuple(station), photo_runs(station, run_of),
                       np.asarray(cx, float), np.asarray(cy, float), h, rows.ground_m[keep], yaw,
                       rows.pitch[keep] if camera_attitude else None)


def photo_runs(stations: Sequence[str | None], run_of: Mapping[str, str]) -> tuple[str | None, ...]:
    """The run of each photo, in the log's order: the run of the station it matched (`run_of`:
    station id → run id). A photo matched to no station (an extra trigger) between two photos
    of one run is part of that run; any other belongs to no planned line (a turn, a line's end,
    a test shot on the ground): None, an extra, in no run (its footprint still counts)."""
    runs: list[str | None] = [run_of.get(s) if s else None for s in stations]
    known = [i for i, r in enumerate(runs) if r is not None]
    out = []
    for i, r in enumerate(runs):
        if r is None:
            k = int(np.searchsorted(known, i))
            before, after = (runs[known[k - 1]] if k > 0 else None), (runs[known[k]] if k < len(known) else None)
            r = before if before == after else None
        out.append(r)
    return tuple(out)


#: metres above home under which a photo is taken on the ground (a test shot before take-off or
#: after landing; the barometer drifts a metre or two on the ground)
ON_GROUND_M = 5.0


def on_the_ground(rel_alt_m: np.ndarray, planned_rel_alt_m: np.ndarray) -> np.ndarray:
    """Photos taken on the ground, which match no station however near one they lie (home is often
    under the first line): less than ON_GROUND_M above home, where every station is planned at
    least twice that high (else none: a plan that low cannot tell the ground from its stations)."""
    rel = np.asarray(rel_alt_m, float)
    planned = np.asarray(planned_rel_alt_m, float)
    if not planned.size or not (np.nanmin(planned) >= 2 * ON_GROUND_M):
        return np.zeros(len(rel), bool)
    return np.asarray(np.isfinite(rel) & (rel < ON_GROUND_M), bool)


def extras_summary(runs: Sequence[str | None], rel_alt_m: np.ndarray, lon: np.ndarray, lat: np.ndarray) -> dict[str, Any]:
    """log_report.json's `extras`: the photos on no planned line (`photo_runs` None), each with its
    place, its height above home and the runs flown before and after it."""
    rows = []
    for i, r in enumerate(runs):
        if r is not None:
            continue
        before = next((q for q in reversed(runs[:i]) if q is not None), None)
        after = next((q for q in runs[i + 1:] if q is not None), None)
        h = float(rel_alt_m[i])
        rows.append({"event": i + 1, "lon": _finite(lon[i], 8), "lat": _finite(lat[i], 8), "rel_alt_m": _finite(h, 2),
                     "on_ground": bool(math.isfinite(h) and h < ON_GROUND_M), "after_run": before, "before_run": after})
    return {"count": len(rows), "on_ground": sum(r["on_ground"] for r in rows), "photos": rows}


def _finite(v: float, nd: int) -> float | None:
    return round(float(v), nd) if math.isfinite(v) else None


@dataclass(frozen=True)
class Aim:
    """Where each photo's camera pointed on its gimbal, as planned for the station it matched:
    the pitch (gimbal convention, −90 straight down) and the yaw against the vehicle's nose
    (degrees, clockwise). A photo that matched no station: straight down along the nose."""

    pitch_deg: np.ndarray
    yaw_deg: np.ndarray


def _station_index(view: PlanView, photos: FlownPhotos) -> np.ndarray:
    """The index in the plan of the station each photo matched, −1 for none."""
    at = {sid: i for i, sid in enumerate(view.station_ids)}
    return np.array([at.get(sid, -1) if sid else -1 for sid in photos.station], np.intp)


def planned_aim(view: PlanView, photos: FlownPhotos) -> Aim:
    """The aim of each flown photo: its matched station's camera pitch and its look against the
    planned nose (the track, or the plan's fixed yaw). A photo flight recorded its camera's
    own pitch and yaw: that is its aim (the yaw already the camera's, nothing to add)."""
    if photos.camera_pitch_deg is not None:
        return Aim(photos.camera_pitch_deg, np.zeros(len(photos)))
    idx = _station_index(view, photos)
    matched = idx >= 0
    return Aim(np.where(matched, view.pitch_deg[idx], -90.0),
               np.where(matched, (view.camera_yaw_deg[idx] - view.nose_deg()[idx] + 180.0) % 360.0 - 180.0, 0.0))


def flown_view(view: PlanView, photos: FlownPhotos) -> PlanView:
    """The plan as the rules see it, with the flown photos in place of the planned stations.

    A photo that matched a station keeps that station's direction of flight, and its camera
    turns with the vehicle: it takes its planned aim (`planned_aim`) from the nose the log
    recorded. A photo that matched none looks straight down along the logged nose."""
    idx = _station_index(view, photos)
    aim = planned_aim(view, photos)
    heading = np.where(idx >= 0, view.heading_deg[idx], photos.yaw_deg)
    return dataclasses.replace(view, station_ids=list(photos.ids), run_ids=list(photos.run), x=photos.x, y=photos.y,
                               agl=photos.agl_m, heading_deg=heading, pitch_deg=aim.pitch_deg,
                               camera_yaw_deg=(np.asarray(photos.yaw_deg, float) + aim.yaw_deg) % 360.0)


class DemGround:
    """Ground heights under flown photos from a DEM GeoTIFF in any CRS, NaN off it or on nodata.

    Vertical sense: the log's altitudes are above mean sea level (GPS receivers report
    heights over their built-in geoid; the barometer is referenced to them at arming),
    and the DEM's heights are taken as orthometric (above the geoid, as national DEMs,
    SRTM and Copernicus DEM are). Geoid models differ by a metre or two; a DEM of
    ellipsoidal heights would be off by the geoid undulation (about 45 m in central
    Europe), which :meth:`vertical_note` and the home check of `log ingest` point out.
    """

    def __init__(self, path: Path, planning_crs: str, option: str = "--dem"):
        if not path.is_file():
            raise InputError(f"{option} {str(path)!r}: no such file; give a DEM GeoTIFF")
        try:
            with rasterio.open(path) as ds:
                has_crs = ds.crs is not None
                crs_wkt = ds.crs.to_wkt() if has_crs else ""
        except rasterio.errors.RasterioIOError as exc:
            raise InputError(f"{option} {str(path)!r} cannot be opened as a raster: {exc}") from None
        if not has_crs:
            raise InputError(f"{option} {str(path)!r} has no CRS; give the DEM a georeference (e.g. gdal_edit.py -a_srs)")
        crs = pyproj.CRS.from_user_input(planning_crs)
        self.planar = Planar(crs, transformer("EPSG:4326", planning_crs), transformer(planning_crs, "EPSG:4326"))
        self.path = path
        self.crs = pyproj.CRS.from_wkt(crs_wkt)
        self._dem: Dem | None = None

    def close(self) -> None:
        self._dem = None

    def __enter__(self) -> DemGround:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _window(self, x: np.ndarray, y: np.ndarray) -> Dem:
        """The DEM read around the points asked for (once, then reused when they lie inside)."""

        from aerosurvey.inputs import read_dem_window
        from aerosurvey.plan.terrain import Dem

        lon, lat = self.planar.lonlat(x, y)
        box = shapely.box(float(lon.min()), float(lat.min()), float(lon.max()), float(lat.max()))
        if self._dem is None or not self._covers(x, y):
            self._dem = Dem(read_dem_window(self.path, box, 50.0), self.planar)
        return self._dem

    def _covers(self, x: np.ndarray, y: np.ndarray) -> bool:
        assert self._dem is not None
        cols, rows = self._cells(self._dem, x, y)
        g = self._dem.grid
        c0, r0 = g.offset
        return bool(((cols - c0 >= 0) & (rows - r0 >= 0) & (cols - c0 <= g.shape[1] - 1)
                     & (rows - r0 <= g.shape[0] - 1)).all())

    @staticmethod
    def _cells(dem: Dem, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        dx, dy = (np.asarray(a) for a in dem.to_dem.transform(x, y))
        inv = ~dem.full
        return inv.a * dx + inv.b * dy + inv.c, inv.d * dx + inv.e * dy + inv.f

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x, y = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float))
        out = np.full(len(x), np.nan)
        idx = np.flatnonzero(np.isfinite(x) & np.isfinite(y))
        if not len(idx):
            return out
        dem = self._window(x[idx], y[idx])
        cols, rows = self._cells(dem, x[idx], y[idx])
        n_rows, n_cols = dem.grid.full_shape
        idx = idx[(cols >= 0) & (rows >= 0) & (cols <= n_cols) & (rows <= n_rows)]
        if not len(idx):
            return out
        try:
            out[idx] = dem.sample(x[idx], y[idx], "flown photos")
        except InputError:  # nodata under some of them: find which, one by one
            for i in idx:
                try:
                    out[i] = dem.sample(x[i:i + 1], y[i:i + 1], "flown photo")[0]
                except InputError:
                    pass
        return out

    def vertical_note(self) -> str:
        """What the DEM's CRS says of its heights."""
        crs = self.crs
        if crs.is_compound:
            vert = next((c for c in crs.sub_crs_list if c.is_vertical), None)
            if vert is not None:
                return f"orthometric heights, vertical CRS {vert.name}"
        if not crs.is_compound and len(crs.axis_info) == 3:
            return (f"ellipsoidal heights ({crs.name}): the log's AMSL altitudes are above the geoid, so heights "
                    "above ground are off by the geoid undulation")
        return "vertical datum not stated in the DEM's CRS; assumed orthometric (above mean sea level)"


#: Metres between the log's home altitude and the DEM's ground there beyond which the report warns.
HOME_CHECK_M = 10.0


def heights_summary(photos: FlownPhotos, ev: Events, dem: DemGround | None, home: Home, crs: str,
                    fixed_camera: bool = False) -> dict[str, Any]:
    """The report's `heights`: where the heights above ground came from, which photos fell back,
    and whether the camera was fixed to the body (`fixed_camera`: its tilt moved the footprints).

    With a DEM it also checks the vertical sense: the log's home altitude (AMSL altitude
    minus height above home) should lie near the DEM's ground at the plan's home; a large
    difference means the altitudes and the DEM are not on the same vertical datum, or the
    GPS height was off at arming, and every DEM height above ground is off by about as much.
    """
    agl = photos.agl_m
    fin = agl[np.isfinite(agl)]
    out: dict[str, Any] = {
        "source": "dem" if dem is not None else "above_home", "dem": dem.path.name if dem is not None else None,
        "agl_min_m": round(float(fin.min()), 3) if fin.size else None,
        "agl_max_m": round(float(fin.max()), 3) if fin.size else None, "fixed_camera": fixed_camera,
    }
    if dem is None:
        out.update({"outside_dem": 0, "note": "heights above home; flat ground assumed (give --dem for the terrain)"})
        return out
    fallback = [int(i) + 1 for i in np.flatnonzero(~np.isfinite(photos.ground_m))]
    out.update({"outside_dem": len(fallback), "outside_dem_events": fallback,
                "note": "height above ground = AMSL altitude - DEM ground under the footprint centre; photos off "
                        "the DEM, on nodata or not above its surface use their height above home",
                "dem_vertical": dem.vertical_note()})
    log_home = ev.alt_m - ev.rel_alt_m
    log_home = log_home[np.isfinite(log_home)]
    home_ground_m = float("nan")
    if home.lon is not None and home.lat is not None:
        hx, hy = transformer("EPSG:4326", crs).transform(home.lon, home.lat)
        home_ground_m = float(dem(np.array([hx]), np.array([hy]))[0])
    if np.isfinite(home_ground_m) and log_home.size:
        d = float(np.median(log_home)) - home_ground_m
        out["home_check"] = {"log_home_amsl_m": round(float(np.median(log_home)), 2),
                             "dem_at_plan_home_m": round(home_ground_m, 2), "difference_m": round(d, 2)}
        if abs(d) > HOME_CHECK_M:
            out["warning"] = (f"the log's home altitude is {d:+.1f} m from the DEM's ground at the plan's home: the log "
                              "and the DEM may not share a vertical datum (ellipsoidal vs. orthometric), or home was "
                              "elsewhere; heights above ground may be off by as much")
    return out


@dataclass(frozen=True)
class CountRaster:
    """How many flown photos see each cell (planning CRS), and its summary over the area."""

    counts: np.ndarray  # uint16, rows from the north
    transform: Affine
    crs: str
    cell_m: float
    summary: dict[str, Any]


def count_raster(view: PlanView, fp: Footprints, cell_m: float) -> CountRaster:
    """Counts of the view's photo footprints (`fp`, its `rules.footprints.footprints`) on cells over the area's bounds."""
    polys = fp.polygons
    x0, y0, x1, y1 = view.area.bounds
    pad = cell_m * 2
    width = int(math.ceil((x1 - x0 + 2 * pad) / cell_m))
    height = int(math.ceil((y1 - y0 + 2 * pad) / cell_m))
    transform = from_origin(x0 - pad, y1 + pad, cell_m, cell_m)
    counts = rasterio.features.rasterize(((p, 1) for p in polys), out_shape=(height, width), transform=transform,
                                         fill=0, merge_alg=MergeAlg.add, dtype="uint16")
    inside = rasterio.features.geometry_mask([view.area], out_shape=(height, width), transform=transform, invert=True)
    vals = counts[inside]
    summary = {"cell_m": cell_m, "min_images_in_area": int(vals.min()) if vals.size else 0,
               "median_images_in_area": float(np.median(vals)) if vals.size else 0.0,
               "uncovered_share": float(np.mean(vals == 0)) if vals.size else 0.0}
    return CountRaster(counts, transform, view.crs, cell_m, summary)


def write_count_raster(path: Path, r: CountRaster) -> None:
    """coverage.tif: the counts as a deflated, tiled GeoTIFF."""
    height, width = r.counts.shape
    with rasterio.open(path, "w", driver="GTiff", width=width, height=height, count=1, dtype="uint16",
                       crs=r.crs, transform=r.transform, compress="deflate", tiled=True) as ds:
        ds.write(r.counts, 1)
