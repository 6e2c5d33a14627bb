"""Missed triggers and wind drift leave gaps that ingest finds and the re-fly covers."""

from __future__ import annotations

import json
import math

import numpy as np
import shapely
from click.testing import CliRunner
from dfwriter import camera_log

import independent_coverage as ic
from aerosurvey.cli import main
from conftest import make_spec


def test_gaps_found_and_reflown(tmp_path):
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    manifest = json.loads((plan / "manifest.json").read_text())
    runs = list(dict.fromkeys(s["line"] for s in manifest["stations"]))
    events = []
    for i, s in enumerate(manifest["stations"]):
        if s["line"] == runs[3] and i % 3:
            continue  # two of three triggers missed on the fourth line
        lat, lon = s["lat"], s["lon"]
        if s["line"] == runs[5]:
            lon += 25.0 / (111_320.0 * math.cos(math.radians(lat)))  # the sixth line drifted 25 m east
        events.append((float(i), lat, lon, 400.0, s["alt_rel_m"]))
    log = tmp_path / "flight.bin"
    log.write_bytes(camera_log(events))
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "-o", str(tmp_path / "log")])
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "log" / "log_report.json").read_text())
    need = manifest["derived"]["side_images_per_point"] * manifest["derived"]["forward_images_per_point"]
    assert rep["coverage"]["min_images_in_area"] < need, "the damage must leave gaps"
    # the drifted photos are too far from their stations to count as them: extra triggers, missed stations
    assert len(rep["missed_stations"]) > 0 and len(rep["far_triggers"]) + len(rep["extra_triggers"]) > 0

    res = CliRunner().invoke(main, ["refly", str(tmp_path / "log"), "--plan", str(plan), "--spec", str(spec),
                                    "-o", str(tmp_path / "refly")])
    assert res.exit_code == 0, res.output
    gaps = shapely.from_geojson((tmp_path / "refly" / "gaps.geojson").read_text())
    assert gaps.area > 0
    # the independent check: photos replayed from the re-fly mission file cover every gap sample
    c = gaps.centroid
    to_xy = ic.local_projection(c.x, c.y)
    gaps_xy = shapely.transform(gaps, lambda a: np.column_stack(to_xy.transform(a[:, 0], a[:, 1])))
    home, rows = ic.read_wpl(tmp_path / "refly" / "mission.waypoints")
    photos = ic.replay_triggers(rows, to_xy, None, home[2])
    gx, gy = ic.grid_inside(gaps_xy, 40)
    assert len(gx) > 10
    counts = ic.footprint_counts(photos, gx, gy, (23.5, 15.6, 6000, 4000, 16.0), "landscape")
    assert counts.min() >= need
    # the re-fly points the gimbal straight down, yaw along the nose, before its first photo: the mount may be
    # where another flight left it
    mount = next(i for i, r in enumerate(rows) if int(r[3]) == 205)
    assert mount < next(i for i, r in enumerate(rows) if int(r[3]) == 206 and r[4] > 0)
    assert (rows[mount][4], rows[mount][6]) == (-90.0, 0.0)
