"""Coverage proved from the exported mission, on the example missions and on random areas.

The checks read `mission.waypoints`, the spec's area file, the camera database and the
DEM themselves (tests/independent_coverage.py); the planner's spacing and stations are
never used to decide whether coverage holds.
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
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import independent_coverage as ic
from aerosurvey.camera import get_camera
from aerosurvey.cli import main
from aerosurvey.spec import load_spec
from conftest import REPO, make_spec, random_polygon, write_geojson


def run_plan(spec: Path, out: Path) -> dict:
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output + repr(res.exception)
    return json.loads((out / "manifest.json").read_text())


def dem_sampler(path: Path, to_lonlat: pyproj.Transformer):
    ds = rasterio.open(path)
    to_dem = pyproj.Transformer.from_crs("EPSG:4326", ds.crs.to_wkt(), always_xy=True)
    band = ds.read(1)

    def ground(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        lon, lat = to_lonlat.transform(x, y)
        dx, dy = to_dem.transform(lon, lat)
        rows, cols = rasterio.transform.rowcol(ds.transform, dx, dy)
        return band[np.asarray(rows), np.asarray(cols)].astype(float)

    return ground


def check_mission(spec_path: Path, out: Path, samples: int = 50) -> dict:
    """Plan, then prove coverage, overlaps, boundary photos, heights and zones from the files."""
    manifest = run_plan(spec_path, out)
    spec = load_spec(spec_path)
    cam = get_camera(spec.camera.camera.id) if spec.camera.camera.id != "inline" else spec.camera.camera
    sensor = (cam.sensor_width_mm, cam.sensor_height_mm, cam.image_width_px, cam.image_height_px, cam.focal_mm)
    home, rows = ic.read_wpl(out / "mission.waypoints")
    area_ll = shapely.from_geojson((spec.area.file).read_text()) if spec.area.file else shapely.from_wkt(spec.area.wkt)
    area_ll = shapely.union_all(shapely.get_parts(area_ll))
    c = area_ll.centroid
    to_xy = ic.local_projection(c.x, c.y)
    to_ll = pyproj.Transformer.from_crs(to_xy.target_crs, "EPSG:4326", always_xy=True)

    def proj(g):
        return shapely.transform(g, lambda a: np.column_stack(to_xy.transform(a[:, 0], a[:, 1])))

    area = proj(area_ll)
    ground = dem_sampler(spec.terrain.dem, to_ll) if spec.terrain.dem is not None else None
    own_interval = manifest["derived"]["trigger_interval_s"] if spec.camera.trigger == "camera" else None
    photos = ic.replay_triggers(rows, to_xy, ground, home[2], own_interval)

    # photos flown = photos planned (a camera on its own intervalometer also shoots in turns)
    if spec.camera.trigger == "camera":
        assert len(photos.x) >= len(manifest["stations"])
    else:
        assert len(photos.x) == len(manifest["stations"])
    # no photo twice: same place and same heading (a cross-hatch photo over a first-pass one is another photo)
    pts = np.round(np.column_stack([photos.x, photos.y, np.degrees(photos.heading) % 180.0]), 2)
    assert len(np.unique(pts, axis=0)) == len(pts), "duplicate photo stations"
    assert len({s["id"] for s in manifest["stations"]}) == len(manifest["stations"])

    # heights: never above the cap, never below the clearance
    assert photos.agl.max() <= spec.vehicle.max_height_agl_m + 0.05
    assert photos.agl.min() > 0

    k_side = math.floor(1 / (1 - spec.targets.side_overlap) + 1e-9)
    k_fwd = math.floor(1 / (1 - spec.targets.forward_overlap) + 1e-9)
    required = area
    zones = None
    if spec.area.exclusions:
        zones = shapely.union_all([proj(shapely.from_geojson(p.read_text())) for p in spec.area.exclusions])
        # no waypoint inside a zone, no leg through one
        wp = [to_xy.transform(r[9], r[8]) for r in rows if int(r[3]) == 16]
        assert not shapely.intersects(zones, shapely.LineString(wp)), "the route enters an exclusion zone"
        reach = spec.flight.exclusion_margin_m + math.hypot(*(np.array([sensor[0], sensor[1]]) / sensor[4] * photos.agl.max())) / 2
        required = shapely.difference(area, shapely.buffer(zones, reach))
    gx, gy = ic.grid_inside(required, samples)
    assert len(gx) > 20
    counts = ic.footprint_counts(photos, gx, gy, sensor, spec.camera.mount)
    worst = int(np.argmin(counts))
    assert counts.min() >= k_side * k_fwd, (
        f"sample at {gx[worst]:.1f},{gy[worst]:.1f} seen by {counts[worst]} photos, need {k_side * k_fwd}")

    fwd, side = ic.realized_overlaps(photos, sensor, spec.camera.mount)
    assert fwd >= spec.targets.forward_overlap - 1e-3, fwd
    if not math.isnan(side):
        assert side >= spec.targets.side_overlap - 1e-3, side

    beyond = spec.targets.images_beyond_boundary
    if beyond:
        inside = shapely.contains_xy(area, photos.x, photos.y)
        for r in np.unique(photos.run):
            idx = np.flatnonzero(photos.run == r)
            ins = np.flatnonzero(inside[idx])
            if len(ins) == 0:
                continue
            assert ins[0] >= beyond and len(idx) - 1 - ins[-1] >= beyond, (
                f"run {r}: {ins[0]} photos before and {len(idx) - 1 - ins[-1]} after the boundary, need {beyond}")
    return {"manifest": manifest, "photos": photos, "counts": counts, "fwd": fwd, "side": side}


@pytest.mark.parametrize("name", ["obratan-72ha", "kubad-abad-fixed-wing", "forest-dem"])
def test_example_missions_cover_their_areas(name, tmp_path):
    check_mission(REPO / "missions" / f"{name}.toml", tmp_path / name)


def test_exclusion_zone_is_routed_around(tmp_path):
    ring = [[15.000, 49.400], [15.008, 49.400], [15.008, 49.405], [15.000, 49.405], [15.000, 49.400]]
    zone = [[15.0035, 49.4015], [15.0048, 49.4015], [15.0048, 49.4032], [15.0035, 49.4032], [15.0035, 49.4015]]
    write_geojson(tmp_path / "zone.geojson", [zone])
    spec = make_spec(tmp_path, {"area": {"exclusions": ["zone.geojson"]}, "flight": {"heading": 0.0}}, area=ring)
    res = check_mission(spec, tmp_path / "out")
    assert any("exclusion" in w for w in res["manifest"]["warnings"])


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["convex", "concave", "holed"]), seed=st.integers(0, 10_000),
       heading=st.one_of(st.just("auto"), st.floats(0, 179.9)), size=st.floats(150, 400),
       beyond=st.integers(0, 8), cross=st.booleans())
def test_random_areas_are_covered(tmp_path_factory, kind, seed, heading, size, beyond, cross):
    tmp = tmp_path_factory.mktemp("rand")
    spec = make_spec(tmp, {"targets": {"images_beyond_boundary": beyond},
                           "flight": {"heading": heading, "cross_hatch": cross}}, rings=random_polygon(kind, seed, size))
    check_mission(spec, tmp / "out", samples=40)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(width=st.floats(30, 145), length=st.floats(200, 700), turn=st.floats(0, 180), side=st.sampled_from([0.6, 0.7]),
       beyond=st.integers(0, 3))
# found by hypothesis: across the heading chosen the range was a hair narrower than a strip, and the two lines
# were laid on top of one another (the same stations twice)
@example(width=33.3046875, length=563.8125, turn=0.0, side=0.6, beyond=0)
def test_areas_narrower_than_a_strip_are_covered(tmp_path_factory, width, length, turn, side, beyond):
    """Narrower than the 150 m footprint: k lines closer than the spacing (plan/lines.py strip_offsets)."""
    tmp = tmp_path_factory.mktemp("narrow")
    rect = shapely.affinity.rotate(shapely.box(-length / 2, -width / 2, length / 2, width / 2), turn)
    k_lat, k_lon = 1 / 111_320.0, 1 / (111_320.0 * math.cos(math.radians(49.4)))
    ring = [[15.0 + x * k_lon, 49.4 + y * k_lat] for x, y in rect.exterior.coords]
    spec = make_spec(tmp, {"targets": {"side_overlap": side, "images_beyond_boundary": beyond}}, area=ring)
    res = check_mission(spec, tmp / "out", samples=40)
    k_side = math.floor(1 / (1 - side) + 1e-9)
    assert len({r["line"] for r in res["manifest"]["lines"]}) == k_side
