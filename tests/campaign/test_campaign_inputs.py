"""The blocks file and the campaign's options: damaged input gets one line naming it; a GeoPackage in a projected CRS plans."""

from __future__ import annotations

import json
from pathlib import Path

import campaigncase as cc
import numpy as np
import pyogrio
import pyproj
import pytest
import shapely
from click.testing import CliRunner

from aerosurvey.cli import main

RING = [[15.0, 49.4], [15.0015, 49.4], [15.0015, 49.401], [15.0, 49.401], [15.0, 49.4]]


def features(path: Path, *feats: dict) -> Path:
    path.write_text(json.dumps({"type": "FeatureCollection", "features": list(feats)}))
    return path


def feature(props: dict | None = None, geometry: dict | None = None) -> dict:
    return {"type": "Feature", "properties": props or {},
            "geometry": geometry if geometry is not None else {"type": "Polygon", "coordinates": [RING]}}


def plan_error(tmp_path: Path, blocks: Path, *more: str) -> str:
    template = cc.write_template(tmp_path)
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(tmp_path / "c"), "--spec", str(template), *more])
    assert res.exit_code == 2, res.output + repr(res.exception)
    lines = res.output.strip().splitlines()
    assert len(lines) == 1, res.output
    return lines[0]


@pytest.mark.parametrize("feats, expected", [
    ([], "holds no feature"),
    ([feature(geometry={"type": "Point", "coordinates": [15.0, 49.4]})], "feature 1 has a Point: each block is a polygon"),
    ([feature({"name": "a"}), feature({"name": "a"})], "feature 2: name = 'a' is used by an earlier feature"),
    ([feature({"name": "a/b"})], "name = 'a/b' is not allowed"),
    ([feature({"gsd_cm": "fine"})], "gsd_cm = 'fine' is not allowed: a number"),
    ([feature({"launch_lon": 15.0})], "launch_lon and launch_lat are given together or not at all"),
])
def test_damaged_blocks_file(tmp_path, feats, expected):
    assert expected in plan_error(tmp_path, features(tmp_path / "blocks.geojson", *feats))


def test_missing_and_unreadable_blocks_file(tmp_path):
    assert "blocks file" in plan_error(tmp_path, tmp_path / "none.geojson") and "does not exist" in plan_error(
        tmp_path, tmp_path / "none.geojson")
    bad = tmp_path / "bad.geojson"
    bad.write_text('{"type": "FeatureCollection", "features": [')
    assert "cannot be read as a vector file" in plan_error(tmp_path, bad)


def test_bad_options(tmp_path):
    blocks = features(tmp_path / "blocks.geojson", feature())
    assert "--workers = 0 is not allowed" in plan_error(tmp_path, blocks, "--workers", "0")
    assert "--scheduler = 'localhost' is not allowed" in plan_error(tmp_path, blocks, "--scheduler", "localhost")
    assert "given together" in plan_error(tmp_path, blocks, "--dask", "local", "--scheduler", "tcp://127.0.0.1:1")
    template = tmp_path / "t.toml"
    template.write_text("[mission\n")
    res = CliRunner().invoke(main, ["campaign", "plan", str(blocks), "-o", str(tmp_path / "c"), "--spec", str(template)])
    assert res.exit_code == 2 and "cannot be read as TOML" in res.output


def test_status_of_a_folder_without_register(tmp_path):
    res = CliRunner().invoke(main, ["campaign", "status", str(tmp_path)])
    assert res.exit_code == 2 and "holds no register.gpkg" in res.output


def test_geopackage_in_a_projected_crs(tmp_path):
    """A GeoPackage in UTM 33N with attributes: planned where the polygons are, named by them."""
    to_utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)
    polys = [shapely.Polygon(np.column_stack(to_utm.transform(*np.array(RING).T)) + [dx, 0]) for dx in (0.0, 200.0)]
    path = tmp_path / "blocks.gpkg"
    pyogrio.raw.write(path, np.array(shapely.to_wkb(polys), dtype=object),
                      [np.array(["east", "west"], dtype=object), np.array([2.2, np.nan])], ["name", "gsd_cm"],
                      layer="blocks", driver="GPKG", geometry_type="Polygon", crs="EPSG:32633")
    template = cc.write_template(tmp_path)
    out = tmp_path / "c"
    res = CliRunner().invoke(main, ["campaign", "plan", str(path), "-o", str(out), "--spec", str(template), "--workers", "1"])
    assert res.exit_code == 0, res.output
    folders = cc.block_folders(out)
    east = json.loads((folders["east"] / "manifest.json").read_text())
    west = json.loads((folders["west"] / "manifest.json").read_text())
    assert east["targets"]["gsd_cm"] == pytest.approx(2.2) and west["targets"]["gsd_cm"] == pytest.approx(2.5)
    rows, _ = cc.register(out)
    back = pyproj.Transformer.from_crs("EPSG:32633", "EPSG:4326", always_xy=True)
    for row, poly in zip(rows, polys):
        got = shapely.from_wkb(bytes.fromhex(row["wkb"]))
        want = shapely.Polygon(np.column_stack(back.transform(*np.array(poly.exterior.coords).T)))
        assert got.symmetric_difference(want).area < 1e-6 * want.area
        assert row["area_ha"] == pytest.approx(poly.area / 1e4, rel=0.01)


@pytest.mark.parametrize("damage", ["not-gpkg", "empty", "no-events", "field-missing"])
def test_damaged_register(tmp_path, damage):
    from aerosurvey.campaign.register import BlockRow, Event, write_register

    row = BlockRow("a", "k", "a.k", "planned", shapely.to_wkb(shapely.box(15, 49, 15.01, 49.01)))
    write_register(tmp_path, [row], [Event("a", "k", "planned", "2026-01-01T00:00:00Z")])
    path = tmp_path / "register.gpkg"
    if damage == "not-gpkg":
        path.write_text("not a geopackage")
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "no-events":
        import sqlite3

        with sqlite3.connect(path) as db:
            db.execute("DROP TABLE events")
    else:
        import sqlite3

        with sqlite3.connect(path) as db:
            db.execute("ALTER TABLE blocks DROP COLUMN photos")
    res = CliRunner().invoke(main, ["campaign", "status", str(tmp_path)])
    assert res.exit_code == 2, res.output
    assert res.output.count("\n") == 1 and "register.gpkg" in res.output and "Traceback" not in res.output


def test_status_order_and_next_steps():
    from aerosurvey.campaign.register import NEXT, Event, status_of

    ev = [Event("a", "k", "planned", "2026-01-01T00:00:00Z"), Event("a", "k", "flown", "2026-01-02T00:00:00Z"),
          Event("a", "k", "qa", "2026-01-03T00:00:00Z"), Event("a", "k", "accepted", "2026-01-03T00:00:00Z")]
    assert status_of("planned", ev[:1]) == "planned"
    assert status_of("planned", ev[:2]) == "flown"
    assert status_of("planned", ev) == "accepted"  # the same second: the later event of the lifecycle
    assert status_of("rules-fail", []) == "rules-fail"
    assert NEXT["accepted"] == "" and all(NEXT[s] for s in NEXT if s != "accepted")
