"""[structure]: the planner proves the coverage of a structure's walls and roof, and `check`
reports it; judged from the exported mission alone.

A 10 × 14 m tower, 30 m high, in the middle of the test area is mapped by the ordinary nadir
grid. The photos are replayed from `mission.waypoints` (tests/independent_coverage.py: the
distance trigger as ArduPilot fires it), the tower is sampled on its own grid, and the ray
caster of tests/independent_faces.py counts the photos seeing each sample: the area seen by
fewer than two is the planner's within 3 % of the faces' area, and so is the faces' area.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import shapely
from click.testing import CliRunner
from tests.conftest import REPO, make_spec, write_geojson

import independent_coverage as ic
from aerosurvey.camera import get_camera
from aerosurvey.cli import main
from independent_faces import caster, prism_samples

CENTRE = (15.003, 49.40175)
HALF = (0.00007, 0.000063)  # about 5 × 7 m


def _tower(tmp: Path) -> None:
    (cx, cy), (dx, dy) = CENTRE, HALF
    write_geojson(tmp / "tower.geojson", [[[cx - dx, cy - dy], [cx + dx, cy - dy], [cx + dx, cy + dy], [cx - dx, cy + dy],
                                           [cx - dx, cy - dy]]])


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


def _faces_rule(manifest: dict) -> dict:
    return next(r for r in manifest["rules"] if r["rule"] == "structure-faces")


def test_the_faces_seen_are_those_the_exported_mission_photographs(tmp_path: Path) -> None:
    _tower(tmp_path)
    spec = make_spec(tmp_path, {"structure": {"file": "tower.geojson", "top_m": 30.0}})
    out = tmp_path / "out"
    code, text = _run("plan", spec, "-o", out)
    assert code in (0, 1), text
    rule = _faces_rule(json.loads((out / "manifest.json").read_text()))
    short, total = (float(v) for v in re.match(r"([\d.]+) m² of ([\d.]+) m²", rule["measured"]).groups())
    assert rule["status"] == ("pass" if short == 0 else "fail")
    assert any(e.startswith("forward overlap on the faces") for e in rule["evidence"])
    code, text = _run("check", out)
    assert "structure-faces" in text

    home, rows = ic.read_wpl(out / "mission.waypoints")
    to_xy = ic.local_projection(*CENTRE)
    photos = ic.replay_triggers(rows, to_xy, None, home[2])
    ring = np.array(to_xy.transform(*np.asarray(json.loads((tmp_path / "tower.geojson").read_text())["features"][0]
                                                ["geometry"]["coordinates"][0]).T)).T
    tower = shapely.Polygon(ring)
    pts, nrm, area = prism_samples(tower, 0.0, 30.0, 2.0)
    assert area.sum() == pytest.approx(total, rel=0.03)
    cam = get_camera("sony-a6000-16mm")
    sensor = (cam.sensor_width_mm, cam.sensor_height_mm, cam.focal_mm)  # landscape: the long side across the flight
    near = np.hypot(photos.x, photos.y) < 200.0
    cams = [(x, y, z, (90.0 - math.degrees(h)) % 360.0, -90.0)
            for x, y, z, h in zip(photos.x[near], photos.y[near], photos.agl[near], photos.heading[near])]
    vis, _ = caster(tower, 0.0, 30.0, sensor, cams, pts, nrm)
    counts = vis.sum(axis=0)
    theirs = float(area[counts < 2].sum())
    assert theirs == pytest.approx(short, abs=0.03 * total), (theirs, short, total)


def test_photos_that_never_see_the_structure_fail_the_rule(tmp_path: Path) -> None:
    """A structure outside every photo: the rule fails and says that no photo sees it."""
    (cx, cy), (dx, dy) = (15.05, 49.43), HALF
    write_geojson(tmp_path / "far.geojson", [[[cx - dx, cy - dy], [cx + dx, cy - dy], [cx + dx, cy + dy], [cx - dx, cy + dy],
                                              [cx - dx, cy - dy]]])
    spec = make_spec(tmp_path, {"structure": {"file": "far.geojson", "top_m": 10.0}})
    code, text = _run("plan", spec, "-o", tmp_path / "out")
    assert code == 1, text
    rule = _faces_rule(json.loads((tmp_path / "out" / "manifest.json").read_text()))
    assert rule["status"] == "fail" and "no photo sees the structure" in rule["measured"]


def test_photos_coarser_than_the_faces_limit_do_not_count(tmp_path: Path) -> None:
    _tower(tmp_path)
    spec = make_spec(tmp_path, {"structure": {"file": "tower.geojson", "top_m": 30.0, "max_gsd_cm": 0.5}})
    code, _ = _run("plan", spec, "-o", tmp_path / "out")
    assert code == 1
    rule = _faces_rule(json.loads((tmp_path / "out" / "manifest.json").read_text()))
    short, total = (float(v) for v in re.match(r"([\d.]+) m² of ([\d.]+) m²", rule["measured"]).groups())
    assert short == total and "at most 0.5 cm a pixel" in rule["statement"]


@pytest.mark.parametrize(("table", "words"), [
    ({"file": "tower.geojson", "top_m": 120.0}, "inside the structure"),
    ({"file": "tower.geojson"}, "structure.top_m"),
    ({"file": "tower.geojson", "top_m": 5.0, "base_m": 6.0}, "structure.top_m"),
    ({"top_m": 5.0}, "structure.file"),
    ({"file": "tower.geojson", "top_m": 30.0, "min_images": 0}, "structure.min_images"),
    ({"file": "tower.geojson", "top_m": 30.0, "colour": "red"}, "[structure]: colour"),
])
def test_a_bad_structure_is_refused_naming_it(tmp_path: Path, table: dict, words: str) -> None:
    _tower(tmp_path)
    code, text = _run("plan", make_spec(tmp_path, {"structure": table}), "-o", tmp_path / "out")
    assert code == 2 and words in text, text


def test_the_summary_gives_the_faces_beside_the_ground_and_alone_without_a_nadir_photo(tmp_path: Path) -> None:
    """The manifest's `faces` record is the structure-faces rule's figures; the summary prints it
    beside the nadir height and GSD of a grid, and in their place for a facade (no photo straight
    down), whose photos' heights lie within the mission's waypoint heights (flat ground)."""
    _tower(tmp_path)
    spec = make_spec(tmp_path, {"structure": {"file": "tower.geojson", "top_m": 30.0}})
    code, text = _run("plan", spec, "-o", tmp_path / "grid")
    assert code in (0, 1), text
    m = json.loads((tmp_path / "grid" / "manifest.json").read_text())
    short, total = (float(v) for v in re.match(r"([\d.]+) m² of ([\d.]+) m²", _faces_rule(m)["measured"]).groups())
    f = m["faces"]
    assert f["short_m2"] == pytest.approx(short, abs=0.01) and f["area_m2"] == pytest.approx(total, abs=0.01)
    assert f["nadir_photos"] == m["estimates"]["photos"] and f["gsd_cm"][0] <= f["gsd_cm"][1]
    assert "  height AGL " in text and "  faces " in text and "  GSD on faces " in text

    code, text = _run("plan", REPO / "missions" / "long-wall.toml", "-o", tmp_path / "wall")
    assert code == 0, text
    m = json.loads((tmp_path / "wall" / "manifest.json").read_text())
    f = m["faces"]
    assert f["nadir_photos"] == 0 and f["short_m2"] == 0 and f["fewest_images"] >= f["min_images"]
    assert "  height AGL " not in text and "none straight down" in text
    _, rows = ic.read_wpl(tmp_path / "wall" / "mission.waypoints")
    alts = [r[10] for r in rows if r[3] == 16]
    assert min(alts) - 0.01 <= f["station_agl_m"][0] <= f["station_agl_m"][1] <= max(alts) + 0.01

    code, text = _run("plan", REPO / "missions" / "obratan-72ha.toml", "-o", tmp_path / "ground")
    assert "faces" not in json.loads((tmp_path / "ground" / "manifest.json").read_text())
    assert "  faces " not in text
