"""True north and the planning grid: the flight as the autopilot logs it (true-north yaw) against
the plan laid in a projected CRS, where the two norths differ by the meridian convergence.

Every check here is independent of the code it checks: true bearings come from geodesic azimuths
between the planned stations' longitudes and latitudes (pyproj.Geod), footprints and pixels from a
local east-north plane around each photo (geodesic offsets), never from `Planar`, `capture` or the
rules' footprints. The CRSs are where the convergence is large: S-JTSK / Krovak (about 7°), UTM near
the edge of its zone (about 2°), a polar stereographic grid (55°).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pyproj
import pytest
import shapely
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from lxml import etree
from tests.conftest import make_spec
from tests.flight.dfwriter import camera_log

from aerosurvey.camera import get_camera
from aerosurvey.cli import main
from aerosurvey.reproject import planar

GEOD = pyproj.Geod(ellps="WGS84")

#: (name, CRS, centre lon, lat, convergence there to a tenth of a degree as PROJ reports it)
PLACES = [
    ("s-jtsk", "EPSG:5514", 15.05, 49.45, -7.4),
    ("utm-zone-edge", "EPSG:32633", 17.9, 49.4, 2.2),
    ("polar-stereographic", "EPSG:3413", 10.0, 75.0, 55.0),
]


def _ring(lon: float, lat: float, half_m: float = 200.0) -> list[list[float]]:
    """A square of 2·half_m on the ground, its sides along the meridian and the parallel."""
    _, n, _ = GEOD.fwd(lon, lat, 0.0, half_m)
    _, s, _ = GEOD.fwd(lon, lat, 180.0, half_m)
    e, _, _ = GEOD.fwd(lon, lat, 90.0, half_m)
    w, _, _ = GEOD.fwd(lon, lat, 270.0, half_m)
    return [[w, s], [e, s], [e, n], [w, n], [w, s]]


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


@pytest.mark.parametrize("name,crs,lon,lat,expected", PLACES, ids=[p[0] for p in PLACES])
def test_convergence_is_the_true_bearing_of_grid_north(name, crs, lon, lat, expected):
    p = planar(crs)
    x, y = p.xy(np.array([lon]), np.array([lat]))
    # a 1 m step towards grid north, its true bearing by the geodesic between its ends
    lon1, lat1 = p.lonlat(x, y - 1.0)
    lon2, lat2 = p.lonlat(x, y + 1.0)
    az, _, _ = GEOD.inv(float(lon1[0]), float(lat1[0]), float(lon2[0]), float(lat2[0]))
    assert float(p.convergence_deg(x, y)[0]) == pytest.approx(az, abs=1e-4)
    assert float(p.convergence_deg(x, y)[0]) == pytest.approx(expected, abs=0.1)
    # PROJ's own figure agrees (on the CRS's datum: within the S-JTSK shift's rotation)
    factors = pyproj.Proj(pyproj.CRS(crs)).get_factors(lon, lat)
    assert float(p.convergence_deg(x, y)[0]) == pytest.approx(factors.meridian_convergence, abs=0.005)


@settings(max_examples=60, deadline=None)
@given(place=st.sampled_from(PLACES), grid=st.floats(0.0, 359.999), de=st.floats(-3000, 3000), dn=st.floats(-3000, 3000))
def test_bearings_cross_both_ways_as_the_geodesic_does(place, grid, de, dn):
    _, crs, lon, lat, _ = place
    p = planar(crs)
    x0, y0 = p.xy(np.array([lon]), np.array([lat]))
    x, y = x0 + de, y0 + dn
    true = p.true_bearing(np.array([grid]), x, y)
    # a short step along the grid bearing, measured on the ellipsoid
    a, b = p.lonlat(x, y)
    h = math.radians(grid)
    c, d = p.lonlat(x + 0.5 * math.sin(h), y + 0.5 * math.cos(h))
    az, _, _ = GEOD.inv(float(a[0]), float(b[0]), float(c[0]), float(d[0]))
    assert (float(true[0]) - az + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-3)
    assert float(p.grid_bearing(true, x, y)[0]) == pytest.approx(grid % 360.0, abs=1e-9) or \
        abs((float(p.grid_bearing(true, x, y)[0]) - grid + 180.0) % 360.0 - 180.0) < 1e-9


def _plan(tmp: Path, crs: str, lon: float, lat: float, **flight: object) -> Path:
    spec = make_spec(tmp, {"mission": {"name": "north", "crs": crs},
                           "targets": {"images_beyond_boundary": 8},
                           "flight": {"heading": 30.0, **flight},
                           "rules": {"profiles": ["cz-land-consolidation"]}}, area=_ring(lon, lat))
    out = tmp / "plan"
    code, text = _run("plan", spec, "-o", out)
    assert code in (0, 1), text
    code, text = _run("gcp", out)  # control_points.geojson: the GCP rules judge the same layout planned and flown
    assert code in (0, 1), text
    return out


def _true_headings(lon: np.ndarray, lat: np.ndarray, line: list[str]) -> np.ndarray:
    """Each station's direction of flight as a true bearing: the geodesic azimuth to the next
    station of its line (from the previous one for the last)."""
    out = np.zeros(len(lon))
    for i in range(len(lon)):
        j = i + 1 if i + 1 < len(lon) and line[i + 1] == line[i] else i
        k = i if j != i else i - 1
        az, _, _ = GEOD.inv(lon[k], lat[k], lon[k + 1], lat[k + 1])
        out[i] = az % 360.0
    return out


def _stations(plan: Path) -> dict[str, np.ndarray | list[str]]:
    m = json.loads((plan / "manifest.json").read_text())
    cols = m["stations"]
    get = {k: np.array([s[k] for s in cols], float) for k in ("lon", "lat", "alt_rel_m", "pitch_deg")}
    return {**get, "line": [s["line"] for s in cols], "id": [s["id"] for s in cols], "home": m["home"]["ground_amsl_m"]}


def _perfect_log(plan: Path, path: Path) -> Path:
    """A flight that took every photo at its station, level, the nose along the line as a true bearing."""
    s = _stations(plan)
    yaw = _true_headings(s["lon"], s["lat"], s["line"])
    rows = [(10.0 + i, float(la), float(lo), float(s["home"] + a), float(a))
            for i, (lo, la, a) in enumerate(zip(s["lon"], s["lat"], s["alt_rel_m"]))]
    path.write_bytes(camera_log(rows, yaw.tolist()))
    return path


def _measured(result: dict) -> float:
    return float(re.match(r"\s*(-?[\d.]+)", result["measured"]).group(1))


@pytest.mark.parametrize("name,crs,lon,lat,expected", PLACES, ids=[p[0] for p in PLACES])
def test_a_perfect_flight_flies_every_rule_as_planned(tmp_path, name, crs, lon, lat, expected):
    plan = _plan(tmp_path, crs, lon, lat)
    log = _perfect_log(plan, tmp_path / "flight.bin")
    flight = tmp_path / "flight"
    code, text = _run("log", "ingest", log, "--plan", plan, "-o", flight)
    assert code == 0, text
    code, text = _run("check", flight, "--json")
    results = json.loads(text)["results"]
    planned_fail = {r["rule"] for r in results if r["planned"]["status"] == "fail" and r["severity"] == "error"}
    assert set(json.loads(text)["failed"]) == planned_fail
    assert results
    for r in results:
        assert r["status"] == r["planned"]["status"], (r["rule"], r["measured"], r["planned"]["measured"])
        if r["rule"] in ("cz-forward-overlap", "cz-side-overlap"):
            assert _measured(r) == pytest.approx(_measured(r["planned"]), abs=0.5), r
        if r["rule"] == "cz-gsd":
            assert _measured(r) == pytest.approx(_measured(r["planned"]), abs=0.1), r
    assert code == (1 if planned_fail else 0), text
    # the flown coverage raster against footprints laid independently: each photo a rectangle in its own
    # east-north plane, the image's top to the true yaw logged, each cell centre placed by the geodesic
    agree, cells = _coverage_agreement(flight / "coverage.tif", plan, crs)
    assert agree >= 0.98 * cells, (agree, cells)


def _coverage_agreement(tif: Path, plan: Path, crs: str) -> tuple[int, int]:
    """(cells whose count equals the independent count, cells seen by a photo), over the raster."""
    import rasterio

    with rasterio.open(tif) as ds:
        counts = ds.read(1)
        rows, cols = np.indices(counts.shape)
        cx, cy = rasterio.transform.xy(ds.transform, rows.ravel(), cols.ravel())
    to_wgs = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
    lon, lat = to_wgs.transform(np.asarray(cx), np.asarray(cy))
    s = _stations(plan)
    yaw = _true_headings(s["lon"], s["lat"], s["line"])
    cam = _camera()
    mine = np.zeros(len(lon), int)
    for i in range(len(yaw)):
        h = float(s["alt_rel_m"][i])
        width, height = (min(px * cam.sensor_width_mm / cam.image_width_px, mm) * h / cam.focal_mm
                         for px, mm in ((cam.image_width_px, cam.sensor_width_mm), (cam.image_height_px, cam.sensor_height_mm)))
        e, n = _local_en(float(s["lon"][i]), float(s["lat"][i]), lon, lat)
        a = math.radians(yaw[i])
        right, ahead = e * math.cos(a) - n * math.sin(a), e * math.sin(a) + n * math.cos(a)
        mine += (np.abs(right) <= width / 2) & (np.abs(ahead) <= height / 2)
    theirs = counts.ravel().astype(int)
    seen = (mine > 0) | (theirs > 0)
    return int(np.sum((mine == theirs) & seen)), int(np.sum(seen))


def _local_en(lon0: float, lat0: float, lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """East and north metres of points from (lon0, lat0) along the geodesic (a local plane)."""
    az, _, d = GEOD.inv(np.full(len(lon), lon0), np.full(len(lat), lat0), lon, lat)
    a = np.radians(az)
    return d * np.sin(a), d * np.cos(a)


def _camera():
    return get_camera("sony-a6000-16mm")


@pytest.mark.parametrize("name,crs,lon,lat,expected", PLACES, ids=[p[0] for p in PLACES])
def test_gcp_predictions_are_where_a_pinhole_puts_them(tmp_path, name, crs, lon, lat, expected):
    """geo.txt poses of the perfect flight; a point on the ground under the area; each predicted
    pixel against a pinhole camera in a local east-north plane (true north, ground metres)."""
    from aerosurvey.flight.handoff import CameraPoses, GroundPoint, predict_marks
    from aerosurvey.plan.capture import Optics

    plan = _plan(tmp_path, crs, lon, lat)
    s = _stations(plan)
    yaw = _true_headings(s["lon"], s["lat"], s["line"])
    n = len(yaw)
    alt = s["home"] + s["alt_rel_m"]
    poses = CameraPoses(tuple(f"IMG_{i:04d}.JPG" for i in range(n)), s["lon"], s["lat"], alt, yaw, np.zeros(n), np.zeros(n))
    cam = _camera()
    m = json.loads((plan / "manifest.json").read_text())
    p = planar(crs)
    gx, gy = p.xy(np.array([lon + 0.0004]), np.array([lat - 0.0003]))
    ground = float(s["home"])
    marks = predict_marks(poses, [GroundPoint("G1", float(gx[0]), float(gy[0]), ground)], Optics.of(cam, "landscape"), crs,
                          float(m["derived"]["grid_scale"]))
    assert len(marks) >= 6
    glon, glat = p.lonlat(gx, gy)
    pitch_mm = cam.sensor_width_mm / cam.image_width_px
    worst = 0.0
    for mk in marks:
        i = int(mk.image[4:8])
        e, nn = _local_en(float(s["lon"][i]), float(s["lat"][i]), glon, glat)
        h = math.radians(yaw[i])
        right = float(e[0]) * math.cos(h) - float(nn[0]) * math.sin(h)
        ahead = float(e[0]) * math.sin(h) + float(nn[0]) * math.cos(h)
        depth = float(alt[i]) - ground
        col = cam.image_width_px / 2 + right / depth * cam.focal_mm / pitch_mm
        row = cam.image_height_px / 2 - ahead / depth * cam.focal_mm / pitch_mm
        worst = max(worst, math.hypot(col - mk.col, row - mk.row))
    assert worst <= 2.0, worst


def _rect(cx: float, cy: float, across: float, along: float, yaw_deg: float) -> shapely.Polygon:
    h = math.radians(yaw_deg)
    ux, uy = math.sin(h), math.cos(h)  # the image's top
    rx, ry = math.cos(h), -math.sin(h)  # its right
    pts = [(cx + a * rx * across / 2 + b * ux * along / 2, cy + a * ry * across / 2 + b * uy * along / 2)
           for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return shapely.Polygon(pts)


@pytest.mark.parametrize("name,crs,lon,lat,expected", PLACES[:2], ids=[p[0] for p in PLACES[:2]])
def test_a_fixed_yaw_keeps_the_overlaps_with_the_camera_turned_against_the_lines(tmp_path, name, crs, lon, lat, expected):
    """flight.fixed_yaw_deg = 0 (true north) on lines at 80° grid, the camera turned nearly square to
    them: every point of the area is seen by at least 4 × 2 photos (75 % forward, 60 % side),
    footprints turned to true north."""
    plan = _plan(tmp_path, crs, lon, lat, fixed_yaw_deg=0.0, cross_hatch=False, heading=80.0)
    s = _stations(plan)
    cam = _camera()
    h = s["home"] + s["alt_rel_m"] - s["home"]
    lon0, lat0 = lon, lat
    ex, ny = _local_en(lon0, lat0, s["lon"], s["lat"])
    gsd = cam.sensor_width_mm / cam.image_width_px * h / cam.focal_mm
    polys = [_rect(x, y, g * cam.image_width_px, g * cam.image_height_px, 0.0) for x, y, g in zip(ex, ny, gsd)]
    tree = shapely.STRtree(polys)
    area = shapely.Polygon(list(zip(*_local_en(lon0, lat0, *(np.array(c) for c in zip(*_ring(lon, lat)))))))
    xs, ys = np.meshgrid(np.linspace(*area.bounds[0::2], 40), np.linspace(*area.bounds[1::2], 40))
    pts = shapely.points(xs.ravel(), ys.ravel())
    pts = pts[shapely.contains(area, pts)]
    counts = np.bincount(tree.query(pts, predicate="within")[0], minlength=len(pts))
    assert counts.min() >= 8, int(counts.min())
    # the exported mission holds the nose at true north
    wpl = (plan / "mission.waypoints").read_text().splitlines()
    yaw_items = [line.split("\t") for line in wpl[1:] if line.split("\t")[3] == "115"]
    assert yaw_items and all(float(r[4]) == pytest.approx(0.0) for r in yaw_items)


def test_the_mission_holds_a_fixed_yaw_as_the_true_bearing_asked(tmp_path):
    """Obrataň's grid lies 7.4° off true north: a fixed yaw of 30° goes into ArduPilot's
    CONDITION_YAW, PX4's waypoint yaw and DJI's waypointHeadingAngle as 30°, and the plan's camera
    faces 30° true (37.4° grid) at every station."""
    _, crs, lon, lat, _ = PLACES[0]
    plan = _plan(tmp_path, crs, lon, lat, fixed_yaw_deg=30.0, cross_hatch=False)
    wpl = [r.split("\t") for r in (plan / "mission.waypoints").read_text().splitlines()[1:]]
    assert [float(r[4]) for r in wpl if r[3] == "115"] == [30.0]
    m = json.loads((plan / "manifest.json").read_text())
    assert m["derived"]["fixed_yaw_deg"] == 30.0
    st_ = m["stations"]
    p = planar(crs)
    grid = np.array([s["camera_yaw_deg"] for s in st_])
    conv = p.convergence_deg(np.array([s["x"] for s in st_]), np.array([s["y"] for s in st_]))
    assert np.allclose((grid + conv) % 360.0, 30.0, atol=1e-3)
    assert m["crs"]["convergence_deg"] == pytest.approx(-7.4, abs=0.1)


def test_a_dji_five_direction_oblique_turns_its_gimbal_to_true_bearings(tmp_path):
    """The five-direction oblique's sideways passes: WPML's absolute gimbalYawRotateAngle is the
    true bearing the camera looks to, read off the kmz as DJI Pilot reads it, against the geodesic
    direction of the pass's lines plus the look."""
    import zipfile

    _, crs, lon, lat, _ = PLACES[0]
    spec = make_spec(tmp_path, {"mission": {"name": "north", "crs": crs},
                                "camera": {"model": "dji-mavic-3-enterprise"},
                                "pattern": {"kind": "oblique", "scheme": "five-direction", "pitch_deg": -45.0},
                                "flight": {"heading": 30.0}}, area=_ring(lon, lat, 150.0))
    out = tmp_path / "plan"
    code, text = _run("plan", spec, "-o", out, "--dji", "waypoint")
    assert code in (0, 1), text
    with zipfile.ZipFile(out / "mission.kmz") as z:
        name = next(n for n in z.namelist() if n.endswith("waylines.wpml"))
        root = etree.fromstring(z.read(name))
    ns = {"wpml": root.nsmap.get("wpml", "http://www.dji.com/wpmz/1.0.2"), "kml": root.nsmap.get(None)}
    placemarks = root.findall(".//kml:Placemark", ns)
    pts = [tuple(float(v) for v in pm.find(".//kml:coordinates", ns).text.split(",")[:2]) for pm in placemarks]
    checked = 0
    for i, pm in enumerate(placemarks):
        for rot in pm.findall(".//wpml:actionActuatorFuncParam", ns):
            on = rot.find("wpml:gimbalYawRotateEnable", ns)
            if on is None or on.text != "1" or i + 1 >= len(pts):
                continue
            yaw = float(rot.find("wpml:gimbalYawRotateAngle", ns).text)
            track, _, _ = GEOD.inv(*pts[i], *pts[i + 1])
            rel = (yaw - track + 180.0) % 360.0 - 180.0
            # the camera looks along, left, right or back of the line it flies, to within the line's own curvature
            assert min(abs(rel - k) for k in (-180.0, -90.0, 0.0, 90.0, 180.0)) < 0.05, (yaw, track)
            checked += 1
    assert checked >= 4
