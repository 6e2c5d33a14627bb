"""Photos flown = photos planned, per line: the exported mission replayed with an independent model
of ArduPilot's distance trigger (tests/independent_trigger.py) against the manifest's runs.

Why the 50 Hz check matters: the planner commands half a check step less than the spacing it
lays the stations at (photogrammetry.distance_trigger). A replay that takes a picture exactly
every commanded distance (a continuous check, not ArduPilot's) finds one photo more on every
run with more stations than the photo base has check steps; with ArduPilot's 50 Hz check
(AP_Camera_Backend::update, scheduled at 50 Hz by Copter and Plane) the count is the manifest's.

ArduPilot measures distances (and flies its speed) on its own sphere (Location::get_distance),
whose metre differs from the ground's by up to 0.7 % with the direction and the latitude
(0.19 % east-west at 49° N). Stations laid in ground metres drifted from the photos by that
share of the way along a run, and runs of more than about 250 photos took one photo fewer
(5.8 km east-west runs of 372 photos took 371): the planner lays them in the autopilot's metres.
The random areas keep runs under some 70 photos; `test_long_runs_take_their_planned_photos`
flies 5.8 km runs east-west and north-south at 49° N and 70° N.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import independent_trigger as it
from aerosurvey.cli import main
from conftest import make_spec, random_polygon

_HEAD = "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t{lat}\t{lon}\t100\t1\n"


def _mission(tmp: Path, rows: list[tuple[int, float, float, float, float, float]]) -> Path:
    """A WPL file from (command, p1, p2, p3, lat, lon) rows, home at 49.4 N 15 E."""
    text = _HEAD.format(lat=49.4, lon=15.0)
    for k, (cmd, p1, p2, p3, lat, lon) in enumerate(rows, start=1):
        text += f"{k}\t0\t{3 if cmd == 16 else 2}\t{cmd}\t{p1}\t{p2}\t{p3}\t0\t{lat}\t{lon}\t50\t1\n"
    p = tmp / "m.waypoints"
    p.write_text(text)
    return p


def _north(m: float) -> float:
    return 49.4 + m / (it._M_PER_DEG)


def test_model_takes_one_picture_at_once_then_one_each_distance(tmp_path: Path) -> None:
    # a 290 m line north at 10 m/s, camera on with 20 m and a picture at once, off at the end:
    # pictures at 0, 20 … 280 m (15), none in the legs before and after
    p = _mission(tmp_path, [(178, 1, 10.0, -1, 0, 0), (16, 0, 0, 0, _north(-50), 15.0), (16, 0, 0, 0, _north(0), 15.0),
                            (206, 20.0, 0, 1, 0, 0), (16, 0, 0, 0, _north(290), 15.0), (206, 0, 0, 0, 0, 0),
                            (16, 0, 0, 0, _north(400), 15.0)])
    photos = it.replay(p)
    north = [(ph.lat - 49.4) * it._M_PER_DEG for ph in photos]
    assert len(photos) == 15
    assert north[0] == pytest.approx(0.0, abs=1e-6)
    # each picture at the first 50 Hz check (0.2 m apart) at 20 m or more from the last one
    assert all(20.0 <= b - a < 20.0 + 0.2 + 1e-6 for a, b in zip(north, north[1:]))


def test_model_checks_at_50_hz_not_continuously(tmp_path: Path) -> None:
    # 19.9 m commanded at 10 m/s: the checks fall every 0.2 m, so pictures are 20.0 m apart, 15 on
    # 290 m; a continuous check would take one every 19.9 m, and 15 of them reach 278.6 m only
    p = _mission(tmp_path, [(178, 1, 10.0, -1, 0, 0), (16, 0, 0, 0, _north(0), 15.0), (206, 19.9, 0, 1, 0, 0),
                            (16, 0, 0, 0, _north(290), 15.0), (206, 0, 0, 0, 0, 0), (16, 0, 0, 0, _north(300), 15.0)])
    north = [(ph.lat - 49.4) * it._M_PER_DEG for ph in it.replay(p)]
    assert len(north) == 15
    assert north[-1] == pytest.approx(280.0, abs=0.01)


def _plan(tmp: Path, overrides: dict, rings: list) -> dict:
    spec = make_spec(tmp, overrides, rings=rings)
    out = tmp / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    manifest: dict = json.loads((out / "manifest.json").read_text())
    manifest["_out"] = out
    return manifest


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["convex", "concave", "holed"]), seed=st.integers(0, 10_000), size=st.floats(150, 500),
       vehicle=st.sampled_from(["copter", "plane"]), speed=st.floats(0.0, 1.0), gsd=st.floats(1.5, 2.8),
       forward=st.floats(0.6, 0.85), side=st.floats(0.5, 0.8), cross=st.booleans(), beyond=st.sampled_from([0, 2, 8]))
def test_every_run_takes_its_planned_photos(tmp_path_factory: pytest.TempPathFactory, kind: str, seed: int, size: float,
                                            vehicle: str, speed: float, gsd: float, forward: float, side: float,
                                            cross: bool, beyond: int) -> None:
    tmp = tmp_path_factory.mktemp("counts")
    cruise = 6 + 8 * speed if vehicle == "copter" else 14 + 8 * speed
    m = _plan(tmp, {"vehicle": {"type": vehicle, "cruise_speed_ms": cruise},
                    "targets": {"gsd_cm": gsd, "forward_overlap": forward, "side_overlap": side,
                                "images_beyond_boundary": beyond},
                    "flight": {"cross_hatch": cross}}, random_polygon(kind, seed, size))
    photos = it.replay(m["_out"] / "mission.waypoints")
    flown = [0] * len(m["lines"])
    for ph in photos:
        assert 0 <= ph.block < len(flown), "a picture outside the runs"
        flown[ph.block] += 1
    planned = [line["photos"] for line in m["lines"]]
    wrong = [(line["id"], p, f) for line, p, f in zip(m["lines"], planned, flown) if p != f]
    assert not wrong, f"runs whose photo count differs (id, planned, flown): {wrong[:5]}"
    assert len(photos) == len(m["stations"])
    _photos_at_stations(m, photos)
    _forward_overlap_on_the_ground(m, photos)


def _photos_at_stations(m: dict, photos: list[it.Photo]) -> None:
    """Each photo lies as far along its run as its station, as ArduPilot measures: within one
    50 Hz check step (and the positions' rounding), however far along the run it is. (Across
    the run they may differ by a few decimetres on long lines: the stations lie on the planning
    grid's straight line, the autopilot flies straight in longitude and latitude.)"""
    assert len(photos) == len(m["stations"])
    step = m["derived"]["speed_ms"] / it.UPDATE_HZ
    first: dict[int, tuple[it.Photo, dict]] = {}
    for ph, st_ in zip(photos, m["stations"]):
        ph0, st0 = first.setdefault(ph.block, (ph, st_))
        flown = it.distance_m(ph0.lat, ph0.lon, ph.lat, ph.lon)
        planned = it.distance_m(st0["lat"], st0["lon"], st_["lat"], st_["lon"])
        assert abs(flown - planned) <= step + 0.02, (st_["id"], flown, planned, step)


@pytest.mark.parametrize("lat", [49.4, 70.0])
@pytest.mark.parametrize("heading", [0.0, 90.0])
def test_long_runs_take_their_planned_photos(tmp_path: Path, lat: float, heading: float) -> None:
    # 5.8 km x 1.1 km, near the edge of UTM zone 34 (the grid's north 2.6° off true north at 70° N)
    kx = 111_320.0 * math.cos(math.radians(lat))
    w, h = 5800.0 / kx, 1100.0 / 111_320.0
    ring = [[23.0, lat], [23.0 + w, lat], [23.0 + w, lat + h], [23.0, lat + h], [23.0, lat]]
    spec = make_spec(tmp_path, {"targets": {"gsd_cm": 2.0, "forward_overlap": 0.8, "side_overlap": 0.6},
                                "flight": {"heading": heading}, "limits": {"max_photos": 500_000}}, area=ring)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    m = json.loads((out / "manifest.json").read_text())
    photos = it.replay(out / "mission.waypoints")
    assert max(line["photos"] for line in m["lines"]) > 250 or heading == 0.0
    flown = [0] * len(m["lines"])
    for ph in photos:
        flown[ph.block] += 1
    assert flown == [line["photos"] for line in m["lines"]]
    _photos_at_stations(m, photos)
    _forward_overlap_on_the_ground(m, photos)


def _forward_overlap_on_the_ground(m: dict, photos: list[it.Photo]) -> None:
    """The photos the autopilot takes lie at most along × (1 − forward overlap) apart on the
    ground (the ellipsoid's metres, pyproj's geodesic), in whichever direction the run goes: the
    autopilot measures in its own metres, up to 0.7 % shorter than the ground's. After a run's
    first picture the gaps are equal (whole 50 Hz check steps), so their mean from the second
    picture to the last is the gap, free of the positions' 1e-7° rounding. The first gap may be
    half a step longer: the first picture is taken when the trigger is switched on
    (DO_SET_CAM_TRIGG_DIST's param3), out of step with the checks that take the next."""
    from pyproj import Geod

    cam, t = m["camera"], m["targets"]
    side_mm = cam["sensor_mm"][1] if cam["mount"] == "landscape" else cam["sensor_mm"][0]
    along = side_mm * m["derived"]["lowest_agl_m"] / cam["focal_mm"]
    allowed = along * (1.0 - t["forward_overlap"])
    half_step = m["derived"]["speed_ms"] / it.UPDATE_HZ / 2.0
    geod = Geod(ellps="WGS84")
    runs: dict[int, list[it.Photo]] = {}
    for ph in photos:
        runs.setdefault(ph.block, []).append(ph)
    checked = 0
    for run in runs.values():
        if len(run) >= 2:
            first = geod.inv(run[0].lon, run[0].lat, run[1].lon, run[1].lat)[2]
            assert first <= allowed + half_step * 1.01 + 0.02, (first, allowed, half_step)
        if len(run) >= 4:
            a, b = run[1], run[-1]
            gap = geod.inv(a.lon, a.lat, b.lon, b.lat)[2] / (len(run) - 2)
            assert gap <= allowed + 0.02 / (len(run) - 2), (gap, allowed, len(run))
            checked += 1
    assert checked > 0
