"""Flown footprints over a DEM: heights above ground = AMSL altitude − ground under the photo.

The expected heights, GSDs and photo counts are computed here from the ramp's own formula
and an independent footprint count (tests/independent_coverage.py), not from the code under test.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyproj
import pytest
import rasterio
import shapely
from click.testing import CliRunner
from csvrows import event_rows
from dfwriter import camera_log
from rasterio.transform import from_origin

import independent_coverage as ic
from aerosurvey.cli import main
from aerosurvey.flight.coverage import flown_photos
from aerosurvey.flight.events import Events
from conftest import make_spec

RING = [[15.000, 49.400], [15.006, 49.400], [15.006, 49.4035], [15.000, 49.4035], [15.000, 49.400]]
HOME_AMSL = 400.0  # the log's home altitude; the ramps put the DEM's ground there at the plan's home too


@pytest.fixture(scope="module")
def plan(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("plan")
    spec = make_spec(tmp, {"flight": {"heading": 0.0}})
    out = tmp / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)]).exit_code == 0
    return out


class Ramp:
    """Ground = HOME_AMSL + offset + slope·(X − X_home), X the DEM CRS's easting (degrees or metres)."""

    def __init__(self, crs: str, manifest: dict, slope_per_m: float, offset: float = 0.0):
        self.crs = crs
        self.to_dem = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
        self.x_home, _ = self.to_dem.transform(manifest["home"]["lon"], manifest["home"]["lat"])
        geographic = pyproj.CRS(crs).is_geographic
        m_per_unit = 111_320.0 * math.cos(math.radians(49.4)) if geographic else 1.0
        self.slope = slope_per_m * m_per_unit
        self.offset = offset
        self.res = 0.0001 if geographic else 5.0
        pad = 0.01 if geographic else 800.0
        xs, ys = self.to_dem.transform([r[0] for r in RING], [r[1] for r in RING])
        self.west, self.north = min(xs) - pad, max(ys) + pad
        self.width = int((max(xs) - min(xs) + 2 * pad) / self.res)
        self.height = int((max(ys) - min(ys) + 2 * pad) / self.res)

    def ground(self, lon: np.ndarray, lat: np.ndarray) -> np.ndarray:
        x, _ = self.to_dem.transform(lon, lat)
        return HOME_AMSL + self.offset + self.slope * (np.asarray(x) - self.x_home)

    def write(self, path: Path, west_limit_lon: float | None = None, nodata_lon: tuple[float, float] | None = None) -> Path:
        """The ramp as a GeoTIFF; optionally starting east of some photos and with a nodata band (geographic only)."""
        first = 0 if west_limit_lon is None else int(math.ceil((west_limit_lon - self.west) / self.res))
        west = self.west + first * self.res
        cols = west + (np.arange(self.width - first) + 0.5) * self.res
        z = np.tile(HOME_AMSL + self.offset + self.slope * (cols - self.x_home), (self.height, 1))
        if nodata_lon is not None:
            z[:, (cols > nodata_lon[0]) & (cols < nodata_lon[1])] = -9999.0
        with rasterio.open(path, "w", driver="GTiff", width=len(cols), height=self.height, count=1, dtype="float64",
                           crs=self.crs, transform=from_origin(west, self.north, self.res, self.res),
                           nodata=-9999.0) as ds:
            ds.write(z, 1)
        return path


def _flight(tmp: Path, manifest: dict) -> tuple[Path, np.ndarray, np.ndarray, np.ndarray]:
    """Nadir photos at every planned station, flown at a constant AMSL altitude (as a barometer holds it)."""
    rows, lats, lons, alts = [], [], [], []
    for i, s in enumerate(manifest["stations"]):
        rows.append((float(i), s["lat"], s["lon"], HOME_AMSL + s["alt_rel_m"], s["alt_rel_m"]))
        lats.append(round(s["lat"] * 1e7) / 1e7)
        lons.append(round(s["lon"] * 1e7) / 1e7)
        alts.append(float(np.float32(HOME_AMSL + s["alt_rel_m"])))  # as the log stores them
    log = tmp / "flight.bin"
    log.write_bytes(camera_log(rows))
    return log, np.array(lats), np.array(lons), np.array(alts)


def _ingest(log: Path, plan: Path, out: Path, *extra: str):
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), *extra, "-o", str(out)])
    assert res.exit_code == 0, res.output
    rows = event_rows(out / "events.csv")
    return res, json.loads((out / "log_report.json").read_text()), rows


def _independent_counts(cov: Path, manifest: dict, lats, lons, agl) -> tuple[np.ndarray, np.ndarray]:
    """(coverage.tif's counts, counts from independent nadir footprints) at the raster cells inside the area."""
    with rasterio.open(cov) as ds:
        counts = ds.read(1)
        rr, cc = np.mgrid[0:ds.height, 0:ds.width]
        xs, ys = rasterio.transform.xy(ds.transform, rr.ravel(), cc.ravel())
        crs = ds.crs.to_string()
    lon, lat = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(np.asarray(xs), np.asarray(ys))
    inside = shapely.contains_xy(shapely.Polygon(RING), lon, lat)
    c = shapely.Polygon(RING).centroid
    to_xy = ic.local_projection(c.x, c.y)
    px, py = to_xy.transform(lon[inside], lat[inside])
    fx, fy = to_xy.transform(lons, lats)
    photos = ic.Photos(np.asarray(fx), np.asarray(fy), np.full(len(lats), math.pi / 2), agl, np.zeros(len(lats)))
    cam = manifest["camera"]
    sensor = (*cam["sensor_mm"], *cam["image_px"], cam["focal_mm"])
    return counts.ravel()[inside], ic.footprint_counts(photos, np.asarray(px), np.asarray(py), sensor, cam["mount"])


@pytest.mark.parametrize("dem_crs", ["EPSG:4326", "EPSG:3035"])
def test_heights_above_a_sloping_dem(tmp_path, plan, dem_crs):
    manifest = json.loads((plan / "manifest.json").read_text())
    log, lats, lons, alts = _flight(tmp_path, manifest)
    ramp = Ramp(dem_crs, manifest, slope_per_m=0.09)  # rises 9 % to the east; the plan's home is on the east edge
    dem = ramp.write(tmp_path / "ramp.tif")

    _, flat, _ = _ingest(log, plan, tmp_path / "flat")
    res, rep, rows = _ingest(log, plan, tmp_path / "dem", "--dem", str(dem))

    want = alts - ramp.ground(lons, lats)
    got = np.array([float(r["agl_m"]) for r in rows])
    assert np.max(np.abs(got - want)) < 0.006  # events.csv holds centimetres
    assert np.max(np.abs(np.array([float(r["ground_m"]) for r in rows]) - ramp.ground(lons, lats))) < 0.006
    h = rep["heights"]
    assert h["source"] == "dem" and h["dem"] == "ramp.tif" and h["outside_dem"] == 0
    assert h["agl_min_m"] == pytest.approx(want.min(), abs=1e-3) and h["agl_max_m"] == pytest.approx(want.max(), abs=1e-3)
    assert abs(h["home_check"]["difference_m"]) < 0.01 and "warning" not in h
    assert "orthometric" in h["dem_vertical"]
    assert "heights above ground from ramp.tif" in res.output

    # GSD: flat ground gives one value; over the slope the range opens to the lowest and highest photo
    cam = manifest["camera"]
    gsd = want * cam["pixel_pitch_um"] / 1000.0 / cam["focal_mm"] * 100
    assert flat["heights"]["source"] == "above_home" and flat["realized"]["gsd_cm_max"] - flat["realized"]["gsd_cm_min"] < 0.01
    assert rep["realized"]["gsd_cm_min"] == pytest.approx(gsd.min(), abs=1e-3)
    assert rep["realized"]["gsd_cm_max"] == pytest.approx(gsd.max(), abs=1e-3)
    assert rep["realized"]["gsd_cm_max"] > flat["realized"]["gsd_cm_max"] + 0.5

    # coverage.tif: counted with the DEM heights (agrees with independent footprints of those heights,
    # not with the flat ones), larger footprints in the lower west, smaller in the east
    tif, indep = _independent_counts(tmp_path / "dem" / "coverage.tif", manifest, lats, lons, want)
    _, indep_flat = _independent_counts(tmp_path / "dem" / "coverage.tif", manifest, lats, lons, alts - HOME_AMSL)
    assert np.mean(tif == indep) > 0.97
    assert np.mean(indep_flat == indep) < 0.6
    flat_tif, _ = _independent_counts(tmp_path / "flat" / "coverage.tif", manifest, lats, lons, want)
    assert tif.mean() > flat_tif.mean()  # on average the ground lies below home here
    assert rep["coverage"] != flat["coverage"]


def test_terrain_following_flight_narrows_the_gsd_range(tmp_path, plan):
    """A flight that followed the ground: heights above home vary with the slope, heights above the DEM do not."""
    manifest = json.loads((plan / "manifest.json").read_text())
    ramp = Ramp("EPSG:4326", manifest, slope_per_m=0.09)
    st = manifest["stations"]
    ground = ramp.ground(np.array([s["lon"] for s in st]), np.array([s["lat"] for s in st]))
    agl = 102.13
    rows = [(float(i), s["lat"], s["lon"], g + agl, g + agl - HOME_AMSL) for i, (s, g) in enumerate(zip(st, ground))]
    log = tmp_path / "follow.bin"
    log.write_bytes(camera_log(rows))
    _, flat, _ = _ingest(log, plan, tmp_path / "flat")
    _, rep, out = _ingest(log, plan, tmp_path / "dem", "--dem", str(ramp.write(tmp_path / "ramp.tif")))
    assert flat["realized"]["gsd_cm_max"] - flat["realized"]["gsd_cm_min"] > 0.8
    assert rep["realized"]["gsd_cm_max"] - rep["realized"]["gsd_cm_min"] < 0.01
    assert rep["heights"]["agl_min_m"] == pytest.approx(agl, abs=0.01) and rep["heights"]["agl_max_m"] == pytest.approx(agl, abs=0.01)
    assert all(abs(float(r["agl_m"]) - agl) < 0.006 for r in out)


def test_photos_off_the_dem_or_on_nodata_fall_back(tmp_path, plan):
    manifest = json.loads((plan / "manifest.json").read_text())
    log, lats, lons, alts = _flight(tmp_path, manifest)
    ramp = Ramp("EPSG:4326", manifest, slope_per_m=0.05, offset=45.0)  # heights 45 m too high, as ellipsoidal ones would be
    runs = sorted({round(x, 4) for x in lons})  # the lines' longitudes, about 0.0008 degrees apart
    gap = (runs[4] - 0.0002, runs[4] + 0.0002)  # nodata around the fifth line
    edge = (runs[1] + runs[2]) / 2  # the DEM starts east of the first two lines
    dem = ramp.write(tmp_path / "part.tif", west_limit_lon=edge, nodata_lon=gap)
    res, rep, rows = _ingest(log, plan, tmp_path / "o", "--dem", str(dem))

    off = (lons < edge) | ((lons > gap[0]) & (lons < gap[1]))
    assert 0 < off.sum() < len(lons)
    h = rep["heights"]
    assert h["outside_dem"] == int(off.sum()) and h["outside_dem_events"] == [int(i) + 1 for i in np.flatnonzero(off)]
    agl = np.array([float(r["agl_m"]) for r in rows])
    rel = np.array([s["alt_rel_m"] for s in manifest["stations"]])
    assert np.allclose(agl[off], rel[off], atol=0.006) and all(r["ground_m"] == "" for r, o in zip(rows, off) if o)
    assert np.max(np.abs(agl[~off] - (alts - ramp.ground(lons, lats))[~off])) < 0.006
    assert f"{int(off.sum())} photo(s) off the DEM, on nodata" in res.output
    # the datum check: the log's home is 45 m below the DEM's ground at the plan's home
    assert h["home_check"]["difference_m"] == pytest.approx(-45.0, abs=0.01) and "vertical datum" in h["warning"]
    assert "warning:" in res.output


def test_without_dem_the_report_says_above_home(tmp_path, plan):
    manifest = json.loads((plan / "manifest.json").read_text())
    log, *_ = _flight(tmp_path, manifest)
    res, rep, rows = _ingest(log, plan, tmp_path / "o")
    assert rep["heights"]["source"] == "above_home" and rep["heights"]["dem"] is None
    assert "flat ground" in rep["heights"]["note"] and "flat ground assumed" in res.output
    assert all(r["ground_m"] == "" for r in rows)


def test_dem_errors_name_the_option(tmp_path, plan):
    manifest = json.loads((plan / "manifest.json").read_text())
    log, *_ = _flight(tmp_path, manifest)
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--dem", str(tmp_path / "x.tif"), "-o", str(tmp_path / "o")])
    assert res.exit_code == 2 and "--dem" in res.output and "--plan" in res.output
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "--dem", str(tmp_path / "x.tif"),
                                    "-o", str(tmp_path / "o")])
    assert res.exit_code == 2 and f"--dem {str(tmp_path / 'x.tif')!r}" in res.output
    (tmp_path / "bad.tif").write_text("not a raster")
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "--dem", str(tmp_path / "bad.tif"),
                                    "-o", str(tmp_path / "o")])
    assert res.exit_code == 2 and "cannot be opened as a raster" in res.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("pitch,roll,yaw", [(8.0, 0.0, 0.0), (0.0, -12.0, 30.0), (10.0, 6.0, 250.0)])
def test_tilted_camera_height_and_centre_agree(pitch, roll, yaw):
    """With --fixed-camera the centre moves with the height: the result is the fixed point of both."""
    x0, slope = 500_000.0, 0.25
    ground = lambda x, y: 300.0 + slope * (np.asarray(x) - x0) + 0.1 * (np.asarray(y) - 5_472_000.0)  # noqa: E731
    t = pyproj.Transformer.from_crs("EPSG:32633", "EPSG:4326", always_xy=True)
    px = np.array([500_000.0, 500_100.0, 499_900.0])
    py = np.array([5_472_000.0, 5_472_050.0, 5_471_900.0])
    lon, lat = (np.asarray(a) for a in t.transform(px, py))
    n = len(px)
    ev = Events(np.arange(n, dtype=float), lat, lon, np.full(n, 420.0), np.full(n, 100.0), np.full(n, roll),
                np.full(n, pitch), np.full(n, yaw), "test")
    flown = flown_photos("EPSG:32633", {}, ev, None, fixed_camera=True, ground=ground)
    back = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)
    cx0, cy0 = (np.asarray(a) for a in back.transform(lon, lat))
    tilt = math.hypot(math.tan(math.radians(pitch)), math.tan(math.radians(roll)))
    assert len(flown) == n
    for i in range(n):
        x, y, agl = flown.x[i], flown.y[i], flown.agl_m[i]
        assert agl == pytest.approx(420.0 - ground(x, y), abs=1e-3)
        assert math.hypot(x - cx0[i], y - cy0[i]) == pytest.approx(agl * tilt, abs=1e-3)
        assert flown.ground_m[i] == pytest.approx(ground(x, y), abs=1e-3)
    nadir = flown_photos("EPSG:32633", {}, ev, None, fixed_camera=False, ground=ground)
    for i in range(n):
        assert (nadir.x[i], nadir.y[i]) == (pytest.approx(cx0[i]), pytest.approx(cy0[i]))
        assert nadir.agl_m[i] == pytest.approx(420.0 - ground(cx0[i], cy0[i]), abs=1e-6)


@pytest.mark.parametrize("pitch,roll,yaw", [(8.0, 0.0, 0.0), (0.0, -12.0, 30.0), (10.0, 6.0, 250.0), (-9.0, 4.0, 120.0)])
def test_tilted_camera_centre_is_where_the_capture_model_looks(pitch, roll, yaw):
    """Flat ground: the fixed camera's footprint centre is where the optical axis of a camera
    fixed to the body (capture.Attitudes.of_body, checked against scipy's rotations) meets it."""
    from aerosurvey.plan import capture

    t = pyproj.Transformer.from_crs("EPSG:32633", "EPSG:4326", always_xy=True)
    lon, lat = (np.atleast_1d(np.asarray(a)) for a in t.transform(500_000.0, 5_472_000.0))
    ev = Events(np.zeros(1), lat, lon, np.full(1, 420.0), np.full(1, 100.0), np.full(1, roll), np.full(1, pitch),
                np.full(1, yaw), "test")
    flown = flown_photos("EPSG:32633", {}, ev, None, fixed_camera=True)
    x0, y0 = (np.asarray(a) for a in pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)
              .transform(lon, lat))
    att = capture.Attitudes.of_body(np.array([yaw]), np.array([pitch]), np.array([roll]))
    optics = capture.Optics(23.5, 15.6, 16.0, 0.0039, 6000, 4000)
    hit = capture.ground_points(capture.Photos(x0, y0, np.full(1, 100.0), att), optics, np.array([[0.0, 0.0]]), 0.0)
    # _centres moves by h·tan(pitch) and h·tan(roll) separately: equal to the axis's meeting point
    # in direction, and to within a few per cent in length at these angles
    dx, dy = flown.x[0] - x0[0], flown.y[0] - y0[0]
    ex, ey = hit[0, 0, 0] - x0[0], hit[0, 0, 1] - y0[0]
    assert math.hypot(dx - ex, dy - ey) < 0.05 * math.hypot(ex, ey) + 0.01
