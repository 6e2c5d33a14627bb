"""A structure on ground that is not the launch point's: with a DEM (`terrain.mode = "fixed"`) an orbit's
rings and a facade's lanes are level at heights above the ground the structure stands on (the lowest
ground under its footprint, along its toe line), and every leg is checked against the DEM.

Judged from the exported mission alone against the DEM's own formula (a tilted plane, a bank rising
beside the tower: written here, read by nobody's code but GDAL's): the same structure planned without
a DEM flies the same stations at heights a constant apart, that constant the foot's lowest ground less
the launch point's; each station's height above the ground under it (the manifest's `agl_m`) is its
altitude less that ground; a bank the rings would fly into stops the plan, where without the DEM it
plans."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyproj
import pytest
import rasterio
import shapely
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rasterio.transform import from_origin
from tests.conftest import make_spec, write_geojson
from tests.plan.test_orbit import CAMERA, CENTRE, TO_LONLAT, _box, _lonlat

import independent_coverage as ic
from aerosurvey.cli import main

UTM = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)
EC, NC = UTM.transform(*CENTRE)  # the tower's middle in UTM 33N
RES = 2.0  # metres a DEM cell
Ground = Callable[[np.ndarray, np.ndarray], np.ndarray]  # metres AMSL at UTM (E, N)


def _write_dem(path: Path, ground: Ground) -> None:
    """The DEM over the tests' area (1.6 km square round the tower): `ground` at each cell's middle."""
    n = int(1600 / RES)
    west, north = EC - 800.0, NC + 800.0
    e = west + (np.arange(n) + 0.5) * RES
    nn = north - (np.arange(n) + 0.5) * RES
    z = ground(*np.meshgrid(e, nn)).astype("float32")
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32633",
                       transform=from_origin(west, north, RES, RES), nodata=-9999.0) as ds:
        ds.write(z, 1)


def tilted(e: np.ndarray, n: np.ndarray) -> np.ndarray:
    return 400.0 + 0.06 * (e - EC) + 0.03 * (n - NC)


def _plan(tmp: Path, over: dict, ground: Ground | None, code: int = 0, line: np.ndarray | None = None) -> tuple[Path, str]:
    """The spec `over` planned; with `ground` a DEM of it in terrain.mode "fixed"; a facade's toe `line`
    (metres from the tower's middle) as the area file."""
    tmp.mkdir(parents=True, exist_ok=True)
    if ground is not None:
        _write_dem(tmp / "dem.tif", ground)
        over = {**over, "terrain": {"dem": "dem.tif", "mode": "fixed", "min_clearance_m": 2.0}}
    spec = make_spec(tmp, over)
    if line is not None:
        write_geojson(tmp / "line.geojson", _lonlat(line), "LineString")
        spec.write_text(spec.read_text().replace('file = "area.geojson"', 'file = "line.geojson"'))
    out = tmp / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == code, res.output
    return out, res.output


def _tower(tmp: Path) -> dict:
    tmp.mkdir(parents=True, exist_ok=True)
    write_geojson(tmp / "tower.geojson", [_lonlat(np.asarray(_box(10.0, 10.0).exterior.coords))])
    return {"pattern": {"kind": "orbit", "standoff_m": 12.0}, "structure": {"file": "tower.geojson", "top_m": 10.0},
            "camera": {"model": CAMERA, "trigger": "distance"}}


def _stations(out: Path) -> tuple[dict, np.ndarray, np.ndarray]:
    """The manifest, the stations' (E, N) and their altitudes above home from mission.waypoints (the
    waypoints a photo station's id tags, in the manifest's station order)."""
    m = json.loads((out / "manifest.json").read_text())
    lon = np.array([s["lon"] for s in m["stations"]])
    lat = np.array([s["lat"] for s in m["stations"]])
    return m, np.column_stack(UTM.transform(lon, lat)), np.array([s["alt_rel_m"] for s in m["stations"]])


def _home_amsl(out: Path) -> float:
    home, _ = ic.read_wpl(out / "mission.waypoints")
    return float(home[2])


def _wpl_altitudes(out: Path) -> np.ndarray:
    _, rows = ic.read_wpl(out / "mission.waypoints")
    return np.array([r[10] for r in rows if int(r[3]) == ic.NAV_WAYPOINT])


def _lifted(tmp: Path, over: dict, foot: shapely.Geometry, line: np.ndarray | None = None,
            ground: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> None:
    ground = ground or tilted
    flat_out, _ = _plan(tmp / "flat", over, None, line=line)
    dem_out, text = _plan(tmp / "dem", over, ground, line=line)
    flat_m, flat_xy, flat_alt = _stations(flat_out)
    m, xy, alt = _stations(dem_out)
    assert [s["id"] for s in m["stations"]] == [s["id"] for s in flat_m["stations"]]
    np.testing.assert_allclose(xy, flat_xy, atol=0.01)
    # the foot's lowest ground by the DEM's formula: a plane is lowest at a corner of the foot (± a cell's slope)
    fx, fy = np.asarray(shapely.get_coordinates(foot)).T
    lowest = float(ground(*UTM.transform(*TO_LONLAT.transform(fx, fy))).min())
    home = _home_amsl(dem_out)
    lift = alt - flat_alt
    assert np.ptp(lift) <= 0.02 + 1e-9, lift  # the manifest's altitudes to the centimetre
    assert lift[0] == pytest.approx(lowest - home, abs=0.1 * RES + 0.05)
    # every waypoint of the mission lifted alike (the lead-ins, the joins and the ways between the rings too)
    np.testing.assert_allclose(_wpl_altitudes(dem_out)[1:-1] - _wpl_altitudes(flat_out)[1:-1], lift[0], atol=0.01)
    # each station's height above the ground under it
    agl = np.array([s["agl_m"] for s in m["stations"]])
    np.testing.assert_allclose(agl, alt + home - ground(xy[:, 0], xy[:, 1]), atol=0.1)
    # the faces seen as without the DEM: the structure and the rings moved up together
    assert m["faces"]["short_m2"] == 0.0 and m["faces"]["fewest_images"] == flat_m["faces"]["fewest_images"]
    assert "heights above the structure's foot" in text and "clearance" in text


def test_an_orbits_rings_stand_on_the_ground_under_its_footprint(tmp_path: Path) -> None:
    over = _tower(tmp_path / "flat")
    _tower(tmp_path / "dem")
    _lifted(tmp_path, over, _box(10.0, 10.0))


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(w=st.floats(6.0, 30.0), d=st.floats(6.0, 30.0), turn=st.floats(0.0, 90.0), top=st.floats(6.0, 30.0),
       standoff=st.floats(8.0, 20.0), se=st.floats(-0.05, 0.05), sn=st.floats(-0.05, 0.05))
def test_random_towers_on_random_slopes(tmp_path_factory, w: float, d: float, turn: float, top: float, standoff: float,
                                        se: float, sn: float) -> None:
    """Random boxes and stand-offs on planes up to 5 % steep each way, launched 64 m south-west of the tower (from
    farther uphill the way out would descend through the ground to the lowest ring, which the clearance refuses):
    the rings lifted by the footprint's lowest ground less the launch point's, as above."""
    tmp = tmp_path_factory.mktemp("slope")
    box = _box(w, d, turn)
    for sub in ("flat", "dem"):
        (tmp / sub).mkdir()
        write_geojson(tmp / sub / "tower.geojson", [_lonlat(np.asarray(box.exterior.coords))])
    over = {"pattern": {"kind": "orbit", "standoff_m": standoff}, "structure": {"file": "tower.geojson", "top_m": top},
            "camera": {"model": CAMERA, "trigger": "distance"},
            "area": {"file": "area.geojson", "launch": _lonlat(np.array([[-45.0, -45.0]]))[0]}}

    def plane(e: np.ndarray, n: np.ndarray) -> np.ndarray:
        return 400.0 + se * (e - EC) + sn * (n - NC)

    _lifted(tmp, over, box, ground=plane)


def test_a_facades_lanes_stand_on_the_lowest_ground_along_its_toe_line(tmp_path: Path) -> None:
    """A toe line along the slope's contour; the lanes 10 m in front of the wall, over ground 1.3 m higher, flown at
    least 5 m above the toe line's ground."""
    toe = np.array([[-12.0, 20.0], [8.0, -20.0]])
    over = {"pattern": {"kind": "facade", "standoff_m": 10.0, "top_m": 12.0, "min_images": 2, "min_height_m": 5.0},
            "camera": {"model": CAMERA, "trigger": "distance"}}
    _lifted(tmp_path, over, shapely.LineString(toe), line=toe)


def test_a_bank_beside_the_tower_that_the_rings_would_fly_into_stops_the_plan(tmp_path: Path) -> None:
    """Flat ground at the tower, a bank rising 2 in 1 from 8 m east of its middle: the rings' east side (17 m
    east, the lowest 16 m up) would pass under 2 m above it. Without the DEM the same orbit plans."""
    def bank(e: np.ndarray, n: np.ndarray) -> np.ndarray:
        return 400.0 + 2.0 * np.maximum(0.0, e - EC - 8.0)

    over = _tower(tmp_path / "flat")
    _tower(tmp_path / "dem")
    _plan(tmp_path / "flat", over, None)
    _, text = _plan(tmp_path / "dem", over, bank, code=1)
    assert "terrain clearance under 2 m" in text and "P1-L001" in text, text


@pytest.mark.parametrize("kind", ["orbit", "facade"])
def test_a_structure_refuses_heights_that_follow_the_ground_in_one_line(tmp_path: Path, kind: str) -> None:
    over = _tower(tmp_path) if kind == "orbit" else {"pattern": {"kind": "facade", "standoff_m": 10.0, "top_m": 12.0},
                                                     "camera": {"model": CAMERA, "trigger": "distance"}}
    _write_dem(tmp_path / "dem.tif", tilted)
    spec = make_spec(tmp_path, {**over, "terrain": {"dem": "dem.tif", "mode": "follow"}})
    if kind == "facade":
        write_geojson(tmp_path / "line.geojson", _lonlat(np.array([[-30.0, -5.0], [30.0, 5.0]])), "LineString")
        spec.write_text(spec.read_text().replace('file = "area.geojson"', 'file = "line.geojson"'))
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2
    last = res.output.strip().splitlines()[-1]
    assert last.startswith("Error: terrain.mode = 'follow' is not allowed with pattern.kind") and "allowed: 'fixed'" in last
    assert not (tmp_path / "out").exists()
