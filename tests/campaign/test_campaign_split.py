"""`campaign split`: blocks within the size, together the area, overlapping at each cut; the blocks'
union covered as one area would be, proved from the exported missions by the independent checker."""

from __future__ import annotations

import json
import math

import campaigncase as cc
import numpy as np
import pyogrio
import pytest
import shapely
import shapely.affinity
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import independent_coverage as ic
from aerosurvey.camera import get_camera
from aerosurvey.campaign.split import split_area
from aerosurvey.cli import main
from conftest import random_polygon, write_geojson


def _check_blocks(area, blocks, max_m2, reach_m):
    """Every block within the size; together exactly the area; around every point of a block's edge
    inside the area (not on its outline), the other blocks cover a disc of `reach_m`."""
    assert blocks
    for b in blocks:
        assert b.area <= max_m2 * (1 + 1e-9) + 1e-6
        assert b.geom_type == "Polygon" and b.is_valid
    union = shapely.union_all(blocks)
    assert union.symmetric_difference(area).area < 1e-6 * area.area
    for i, b in enumerate(blocks):
        others = shapely.union_all([o for j, o in enumerate(blocks) if j != i])
        edge = b.exterior
        pts = [edge.interpolate(d) for d in np.linspace(0, edge.length, 200, endpoint=False)]
        for p in pts:
            if area.boundary.distance(p) < 2 * reach_m:
                continue  # on or near the area's own outline: no neighbour there
            disc = p.buffer(reach_m * 0.98, quad_segs=8)
            assert disc.difference(others).area < 1e-6 * disc.area, (i, p.wkt)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kind=st.sampled_from(["convex", "concave", "holed"]), seed=st.integers(0, 10_000),
       heading=st.floats(0, 180), max_ha=st.floats(3, 20), ov=st.floats(10, 60))
def test_split_blocks_cover_the_area_and_overlap(kind, seed, heading, max_ha, ov):
    rings = random_polygon(kind, seed, 500.0)
    k_lat, k_lon = 111_320.0, 111_320.0 * math.cos(math.radians(49.4))
    area = shapely.Polygon(*[[((x - 15.0) * k_lon, (y - 49.4) * k_lat) for x, y in r] for r in rings[:1]],
                           [[((x - 15.0) * k_lon, (y - 49.4) * k_lat) for x, y in r] for r in rings[1:]])
    blocks = split_area(area, heading, max_ha * 1e4, ov, ov * 0.8)
    _check_blocks(area, blocks, max_ha * 1e4, ov * 0.8)
    # the cuts are straight and along or across the lines: each block's cut edges run at the heading or across it
    for b in blocks:
        coords = np.array(b.exterior.coords)
        for (x0, y0), (x1, y1) in zip(coords[:-1], coords[1:]):
            mid = shapely.Point((x0 + x1) / 2, (y0 + y1) / 2)
            if area.boundary.distance(mid) < 1e-6 or math.hypot(x1 - x0, y1 - y0) < 1e-6:
                continue
            bearing = math.degrees(math.atan2(x1 - x0, y1 - y0)) % 180.0
            off = min(abs(bearing - heading), 180 - abs(bearing - heading))
            assert min(off, abs(off - 90)) < 1e-4, (bearing, heading)


def test_max_ha_too_small_for_the_overlap():
    from aerosurvey.errors import InputError

    with pytest.raises(InputError, match="--max-ha 0.1 is too small"):
        split_area(shapely.box(0, 0, 1000, 1000), 0.0, 0.1e4, 60, 50)


def test_union_of_the_blocks_covered_as_one_area(tmp_path):
    """Split a 30 ha area at 8 ha, plan the blocks as a campaign; from the .waypoints alone: every point of
    the area seen by as many photos as one area's plan guarantees, and on each band two blocks share,
    by that many photos of each."""
    rings = random_polygon("concave", 7, 380.0)
    area_file = write_geojson(tmp_path / "area.geojson", rings)
    template = cc.write_template(tmp_path)
    blocks_file = tmp_path / "blocks.gpkg"
    res = CliRunner().invoke(main, ["campaign", "split", str(area_file), "-o", str(blocks_file), "--max-ha", "8",
                                    "--spec", str(template), "--heading", "35"])
    assert res.exit_code == 0, res.output
    _, _, wkb, (names, headings) = pyogrio.raw.read(blocks_file)
    assert len(names) >= 4 and np.allclose(headings, 35.0, atol=0.05)
    out = tmp_path / "campaign"
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks_file), "-o", str(out), "--spec", str(template),
                                    "--workers", "2"])
    assert res.exit_code == 0, res.output

    area_ll = shapely.Polygon(rings[0])
    to_xy = ic.local_projection(area_ll.centroid.x, area_ll.centroid.y)

    def proj(g):
        return shapely.transform(g, lambda a: np.column_stack(to_xy.transform(a[:, 0], a[:, 1])))

    cam = get_camera("sony-a6000-16mm")
    sensor = (cam.sensor_width_mm, cam.sensor_height_mm, cam.image_width_px, cam.image_height_px, cam.focal_mm)
    k = math.floor(1 / (1 - 0.6) + 1e-9) * math.floor(1 / (1 - 0.75) + 1e-9)
    folders = cc.block_folders(out)
    photos, polys = {}, {}
    for name, g in zip(names, shapely.from_wkb(wkb)):
        home, rows = ic.read_wpl(folders[name] / "mission.waypoints")
        photos[name] = ic.replay_triggers(rows, to_xy, None, home[2])
        polys[name] = proj(g)
        assert json.loads((folders[name] / "block.json").read_text())["area_ha"] <= 8.0 * 1.01
    area = proj(area_ll)
    gx, gy = ic.grid_inside(area, 80)
    total = sum(ic.footprint_counts(p, gx, gy, sensor, "landscape") for p in photos.values())
    assert total.min() >= k, f"a point of the area seen by {total.min()} photos of all blocks, need {k}"
    shared = 0
    for a in polys:
        for b in polys:
            band = shapely.intersection(polys[a], polys[b])
            if a >= b or band.area < 1.0:
                continue
            shared += 1
            bx, by = ic.grid_inside(band, 40)
            for name in (a, b):
                seen = ic.footprint_counts(photos[name], bx, by, sensor, "landscape")
                assert seen.min() >= k, f"on the band {a}/{b}, a point seen by {seen.min()} photos of {name}, need {k}"
    assert shared >= len(polys) - 1  # the blocks are connected through their bands
