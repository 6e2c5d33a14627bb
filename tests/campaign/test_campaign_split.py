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
    """Split a 13 ha area at 8 ha, plan the blocks as a campaign; from the .waypoints alone: every point of
    the area seen by as many photos as one area's plan guarantees, and on each band two blocks share,
    by that many photos of each."""
    rings = random_polygon("concave", 7, 380.0)
    area_file = write_geojson(tmp_path / "area.geojson", rings)
    template = cc.write_template(tmp_path)
    blocks_file = tmp_path / "blocks.gpkg"
    res = CliRunner().invoke(main, ["campaign", "split", str(area_file), "-o", str(blocks_file), "--max-ha", "8",
                                    "--spec", str(template), "--heading", "35"])
    assert res.exit_code == 0, res.output
    _, _, wkb, (names, headings, _cuts) = pyogrio.raw.read(blocks_file)
    assert len(names) >= 2 and np.allclose(headings, 35.0, atol=0.05)  # 13 ha at 8 ha: several blocks
    out = tmp_path / "campaign"
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks_file), "-o", str(out), "--spec", str(template),
                                    "--workers", "2"])
    assert res.exit_code == 0, res.output
    for folder in cc.block_folders(out).values():
        assert json.loads((folder / "block.json").read_text())["area_ha"] <= 8.0 * 1.01
    shared = cc.prove_union_coverage(out, dict(zip(names, shapely.from_wkb(wkb))), shapely.Polygon(rings[0]))
    assert shared >= len(names) - 1  # the blocks are connected through their bands


def test_abutting_blocks_grown_into_their_neighbours(tmp_path):
    """A grid of blocks that only touch, planned with --overlap: the same proof over their union."""
    feats = []
    for i in range(3):
        for j in range(2):
            x, y = 15.0 + i * 0.004, 49.4 + j * 0.0028
            ring = [[x, y], [x + 0.004, y], [x + 0.004, y + 0.0028], [x, y + 0.0028], [x, y]]
            feats.append({"type": "Feature", "properties": {"name": f"g{i}{j}", "heading": 20.0},
                          "geometry": {"type": "Polygon", "coordinates": [ring]}})
    blocks_file = tmp_path / "grid.geojson"
    blocks_file.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    template = cc.write_template(tmp_path)
    out = tmp_path / "campaign"
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks_file), "-o", str(out), "--spec", str(template),
                                    "--workers", "2", "--overlap"])
    assert res.exit_code == 0, res.output
    rows, _ = cc.register(out)
    grown = {r["name"]: shapely.from_wkb(bytes.fromhex(r["wkb"])) for r in rows}
    given = {f["properties"]["name"]: shapely.geometry.shape(f["geometry"]) for f in feats}
    for name in given:
        assert grown[name].contains(given[name].buffer(-1e-9)) and grown[name].area > given[name].area
    union = shapely.union_all(list(given.values()))
    assert shapely.union_all(list(grown.values())).symmetric_difference(union).area < 1e-6 * union.area
    shared = cc.prove_union_coverage(out, grown, union)
    assert shared >= 7  # the grid's 7 shared edges, each a band (and corners where four meet)


def _sorties_of_blocks(tmp_path, name: str, feats: list, template) -> dict[str, int]:
    """Each feature planned by `campaign plan` (the default outputs): name → the sorties its manifest lists."""
    blocks_file = tmp_path / f"{name}.geojson"
    blocks_file.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    out = tmp_path / name
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks_file), "-o", str(out), "--spec", str(template),
                                    "--workers", "1"])
    assert res.exit_code == 0, res.output
    return {n: len(json.loads((f / "manifest.json").read_text())["sorties"]) for n, f in cc.block_folders(out).items()}


@pytest.mark.parametrize("kind,seed,heading,n", [("concave", 7, 35.0, 2), ("convex", 21, 120.0, 3), ("holed", 5, 80.0, 2)])
def test_max_sorties_blocks_each_within_n_and_cut_only_when_needed(tmp_path, kind, seed, heading, n):
    """`campaign split --max-sorties N` of a random area: every block, planned as a campaign, takes at most N sorties
    (its manifest's), together they are the area, and every cut was needed: the blocks of the cell each block was cut
    from (the blocks file's `cut` paths) merged, planned with their heading, take more than N sorties."""
    rings = random_polygon(kind, seed, 800.0)
    area_file = write_geojson(tmp_path / "area.geojson", rings)
    template = cc.write_template(tmp_path, battery={"usable_min": 12.0})
    blocks_file = tmp_path / "blocks.geojson"
    res = CliRunner().invoke(main, ["campaign", "split", str(area_file), "-o", str(blocks_file), "--max-sorties", str(n),
                                    "--spec", str(template), "--heading", str(heading)])
    assert res.exit_code == 0, res.output
    blocks = json.loads(blocks_file.read_text())["features"]
    assert len(blocks) >= 2
    sorties = _sorties_of_blocks(tmp_path, "campaign", blocks, template)
    assert sorted(sorties) == sorted(f["properties"]["name"] for f in blocks)
    assert all(1 <= s <= n for s in sorties.values()), sorties
    polys = {f["properties"]["name"]: shapely.geometry.shape(f["geometry"]) for f in blocks}
    area = shapely.Polygon(rings[0], rings[1:])
    assert shapely.union_all(list(polys.values())).symmetric_difference(area).area < 1e-4 * area.area
    # the cell each block was cut from: its blocks merged, each part of it planned with their mean heading
    cuts = {f["properties"]["name"]: f["properties"]["cut"] for f in blocks}
    heads = {f["properties"]["name"]: f["properties"]["heading"] for f in blocks}
    parents = sorted({c[:-1] for c in cuts.values() if c})
    feats, of_parent = [], {}
    for k, parent in enumerate(parents):
        members = [b for b, c in cuts.items() if c.startswith(parent)]
        merged = shapely.union_all([polys[b] for b in members])
        for j, part in enumerate(shapely.get_parts(merged)):
            name = f"p{k:03d}-{j}"
            of_parent[name] = parent
            feats.append({"type": "Feature", "properties": {"name": name, "heading": float(np.mean([heads[b] for b in members]))},
                          "geometry": shapely.geometry.mapping(part)})
    merged_sorties = _sorties_of_blocks(tmp_path, "merged", feats, template)
    for parent in parents:
        most = max(s for name, s in merged_sorties.items() if of_parent[name] == parent)
        assert most > n, f"cell {parent!r} was cut though it takes {most} sorties, within {n}"


def test_max_sorties_needs_a_battery_and_one_size(tmp_path):
    area_file = write_geojson(tmp_path / "area.geojson", random_polygon("convex", 3, 300.0))
    template = cc.write_template(tmp_path)

    def split(*args: str) -> str:
        res = CliRunner().invoke(main, ["campaign", "split", str(area_file), "-o", str(tmp_path / "b.gpkg"), "--spec",
                                        str(template), *args])
        return f"{res.exit_code} {res.output}"

    assert split("--max-sorties", "2").startswith("2 ") and "--max-sorties needs the template's [battery] table" in split(
        "--max-sorties", "2")
    assert "give one of --max-ha and --max-sorties" in split()
    assert "give one of --max-ha and --max-sorties" in split("--max-ha", "5", "--max-sorties", "2")
    assert not (tmp_path / "b.gpkg").exists()


@pytest.mark.parametrize("heading", [0.0, 90.0, 30.0])
def test_a_long_area_is_cut_into_blocks_as_large_as_the_limit_allows(heading):
    """A strip 2 km by 300 m (60 ha) at 13 ha a block: each cut leaves below it the largest block that keeps the limit
    (to CUT_PRECISION of the side), so every block but one is within 2 % of 13 ha with its overlaps, and there are
    as few as the area needs: 5 (halving cells in two left 8, of 8 to 8.4 ha)."""
    from aerosurvey.campaign.split import CUT_PRECISION

    strip = shapely.affinity.rotate(shapely.box(0.0, 0.0, 300.0, 2000.0), -heading, origin=(0.0, 0.0))
    limit = 13e4
    blocks = split_area(strip, heading, limit, 40.0, 30.0)
    _check_blocks(strip, blocks, limit, 30.0)
    areas = sorted(b.area for b in blocks)
    assert len(blocks) == 5, areas
    assert all(a >= (1.0 - 4 * CUT_PRECISION) * limit for a in areas[1:]), areas
