"""The battery split costs sorties by parts (heads, tails, the route's stretches timed once): the
same floats as timing each sortie's whole polyline (the costing before, tests/sorties_reference.py)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import aerosurvey.plan.planner as planner
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.plan.route import CopterTime, Kinematics, RouteSegments, kept_segments, path_time
from aerosurvey.plan.sorties import Splitter, split
from aerosurvey.spec import load_spec
from conftest import REPO, make_spec, write_geojson
from sorties_reference import ReferenceSplitter, reference_split

sys.path.insert(0, str(REPO / "missions" / "tools"))
from synthetic_dem import write_dem  # noqa: E402

KIN = Kinematics("copter", 9.5, 2.5, 0.0, 1.0)

# a polyline as moves: (length, turn in degrees); zero and sub-1e-9 lengths are dropped by path_time,
# turns near 30° sit at its corner test, straight moves build long stretches
_move = st.tuples(st.one_of(st.just(0.0), st.just(5e-10), st.floats(0.01, 400.0)),
                  st.one_of(st.just(0.0), st.floats(-40.0, 40.0), st.sampled_from([29.999999, 30.0, 30.000001, 90.0, 180.0]),
                            st.floats(-180.0, 180.0)))


def _polyline(x0: float, y0: float, moves: list[tuple[float, float]]) -> np.ndarray:
    pts, h = [(x0, y0)], 0.0
    for length, turn in moves:
        h += turn
        x, y = pts[-1]
        pts.append((x + length * math.cos(math.radians(h)), y + length * math.sin(math.radians(h))))
    return np.asarray(pts)


@settings(max_examples=300, deadline=None)
@given(start=st.tuples(st.floats(-1e6, 1e6), st.floats(-1e6, 6e6)), moves=st.lists(_move, min_size=1, max_size=40),
       cut=st.tuples(st.floats(0, 0.999), st.floats(0, 0.999)), pad=st.tuples(st.lists(_move, max_size=5), st.lists(_move, max_size=5)),
       speed=st.floats(2.0, 20.0), accel=st.floats(0.5, 5.0), jerk=st.sampled_from([0.0, 1.0, 5.0]))
def test_copter_time_by_parts_is_path_time(start, moves, cut, pad, speed, accel, jerk):
    """Head, a slice of a longer route and tail summed by CopterTime: path_time of the whole, bit for bit."""
    kin = Kinematics("copter", speed, accel, 0.0, jerk)
    p = _polyline(*start, moves)
    n = len(p)
    i = int(cut[0] * (n - 2))  # the route holds points i..j, 0 <= i < j <= n - 1
    j = i + 1 + int(cut[1] * (n - 2 - i))
    # the route the slice is taken from starts and ends elsewhere (its own corners before and after)
    before = _polyline(*start, pad[0])[::-1]
    after = _polyline(*p[j], pad[1])
    route = np.vstack([before - before[-1] + p[i], p[i + 1:j], after])
    o = len(before) - 1
    rs = RouteSegments(route, kin)
    t = CopterTime(kin)
    t.feed(kept_segments(p[:i + 1]))
    t.route(rs, rs.kept_before[o], rs.kept_before[o + j - i])
    t.feed(kept_segments(p[j:]))
    assert t.time() == path_time(p, kin)
    # and the whole in one feed
    whole = CopterTime(kin)
    whole.feed(kept_segments(p))
    assert whole.time() == path_time(p, kin)


def test_a_turn_of_exactly_30_degrees_is_no_corner():
    """A turn of exactly 30° (45° then 75.0°, as numpy computes the directions) is flown through, as in path_time."""
    p = np.array([[-100.0, -100.0], [0.0, 0.0], [0.5, 1.8660254037844388], [200.0, 0.0]])
    lengths, angles = kept_segments(p)
    assert angles[:2] == [45.0, 75.0]
    t = CopterTime(KIN)
    t.feed(kept_segments(p))
    assert t.time() == path_time(p, KIN)
    rs = RouteSegments(p, KIN)
    assert rs.corners == [2]  # the second segment continues the first stretch
    by_route = CopterTime(KIN)
    by_route.route(rs, 0, 3)
    assert by_route.time() == path_time(p, KIN)


def test_segments_are_path_timeskept_segments():
    """_segments keeps and measures what path_time does (a zero-length and a sub-1e-9 segment dropped)."""
    p = np.array([[0.0, 0.0], [0.0, 0.0], [3.0, 4.0], [3.0 + 1e-10, 4.0], [3.0, 10.0]])
    lengths, angles = kept_segments(p)
    assert lengths == [5.0, pytest.approx(6.0, abs=1e-9)]
    assert angles == pytest.approx([math.degrees(math.atan2(4, 3)), 90.0])


def _split_args(spec_path: Path) -> tuple:
    """The arguments the planner gives the battery split for a spec."""
    got: list[tuple] = []
    real = planner.split

    def spy(*args, **progress):  # the progress callback passed by keyword: not compared
        got.append(args)
        return real(*args, **progress)

    planner.split = spy
    try:
        plan_from_files(load_spec(spec_path))
    finally:
        planner.split = real
    assert got, "no battery split"
    assert got[0][6:] in ((), (0,)), "a whole route is split from its first station"
    return got[0][:6]  # the reference takes the whole route's arguments


def _same_split(args: tuple) -> int:
    """The split and every cost the reference computed are the same (values and types: repr); returns
    how many candidate sorties were compared."""
    assert repr(split(*args)) == repr(reference_split(*args))
    ref = ReferenceSplitter(*args)
    new = Splitter(*args)
    # the candidates the bisection asks for: re-run the reference's greedy searches on its own splitter
    budget = args[2]
    ref.greedy(budget.usable)
    for frac in (0.5, 0.7, 0.9):
        ref.greedy(budget.usable * frac)
    for (a, b), (used, li, horiz, vert, dist, wps, items) in ref._evaluated.items():
        assert repr(new.cost(a, b)) == repr((used, li, horiz, vert, items)), (a, b)
        assert repr(new.evaluate(a, b)) == repr((used, li, horiz, vert, dist, wps, items)), (a, b)
    return len(ref._evaluated)


def test_obratan_costs_are_the_references():
    assert _same_split(_split_args(REPO / "missions" / "obratan-72ha.toml")) > 300


@pytest.mark.parametrize("name", ["forest-dem", "kubad-abad-fixed-wing"])
def test_example_costs_are_the_references(name):
    assert _same_split(_split_args(REPO / "missions" / f"{name}.toml")) > 0


# a zone in the middle of the default test area, and launch points west and east of it
ZONE = [[15.0026, 49.4012], [15.0034, 49.4012], [15.0034, 49.4022], [15.0026, 49.4022], [15.0026, 49.4012]]
SITES = [[14.9985, 49.4017], [15.0075, 49.4017]]


@settings(max_examples=14, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(vehicle=st.sampled_from(["copter", "plane"]), zone=st.booleans(), sites=st.sampled_from([0, 1, 2]),
       terrain=st.sampled_from(["none", "fixed", "follow"]), camera=st.booleans(), minutes=st.floats(5, 16),
       heading=st.one_of(st.just("auto"), st.floats(0, 179)), wind=st.floats(0, 4))
def test_random_plans_split_as_the_reference(tmp_path_factory, vehicle, zone, sites, terrain, camera, minutes, heading, wind):
    tmp = tmp_path_factory.mktemp("exact")
    battery: dict = {"usable_min": minutes, "wind_ms": wind}
    if sites:
        battery["launch_points"] = SITES[:sites] if sites == 2 else SITES[1:]
    table: dict = {"battery": battery, "flight": {"heading": heading},
                   "vehicle": {"type": vehicle, "cruise_speed_ms": 10.0 if vehicle == "copter" else 16.0}}
    if camera and vehicle == "copter":
        table["camera"] = {"trigger": "camera", "interval_s": 2.0}
    if zone:
        write_geojson(tmp / "zone.geojson", [ZONE])
        table["area"] = {"exclusions": ["zone.geojson"]}
    if terrain != "none":
        write_dem(str(tmp / "dem.tif"), 32633, 499500.0, 5472600.0, 180, 180, 10.0, 400.0, 25.0)
        table["terrain"] = {"dem": "dem.tif", "mode": terrain}
        table["vehicle"]["max_height_agl_m"] = 120
    spec = make_spec(tmp, table)
    try:
        args = _split_args(spec)
    except InputError:  # battery too small, a launch point a plane cannot use, terrain mode refused
        assume(False)
    _same_split(args)


def _every_last_station(args: tuple, firsts: int) -> int:
    """Sorties from a few first stations to every later station (the copter's last pieces ending
    mid-run are costed from per-run tables): the reference's costs, values and types."""
    ref, new = ReferenceSplitter(*args), Splitter(*args)
    n = new.n
    compared = 0
    for a in sorted({0, n // 3, n // 2, *range(0, n, max(1, n // firsts))}):
        for b in range(a, n, max(1, n // 400)):
            used, li, horiz, vert, _, _, items = ref.evaluate(a, b)
            assert repr(new.cost(a, b)) == repr((used, li, horiz, vert, items)), (a, b)
            compared += 1
    return compared


def test_forest_follow_every_last_station_is_the_references():
    """Terrain-following copter (terrain waypoints inside runs)."""
    assert _every_last_station(_split_args(REPO / "missions" / "forest-dem.toml"), 4) > 400


def test_zone_and_two_sites_every_last_station_is_the_references(tmp_path):
    """Ways home round a zone, two launch sites, terrain following."""
    write_geojson(tmp_path / "zone.geojson", [ZONE])
    write_dem(str(tmp_path / "dem.tif"), 32633, 499500.0, 5472600.0, 180, 180, 10.0, 400.0, 25.0)
    spec = make_spec(tmp_path, {"battery": {"usable_min": 9.0, "launch_points": SITES}, "area": {"exclusions": ["zone.geojson"]},
                                "terrain": {"dem": "dem.tif", "mode": "follow"},
                                "vehicle": {"type": "copter", "cruise_speed_ms": 10.0, "max_height_agl_m": 120}})
    assert _every_last_station(_split_args(spec), 6) > 100
