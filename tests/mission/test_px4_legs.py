"""PX4 missions have no leg longer than PX4 v1.13 accepts (MIS_DIST_WPS, 900 m by default): longer
legs get waypoints on them, and the lines, photos and everything else stay as they were.

The checks read the exported files the way PX4 reads a mission (its places: the items whose
command MissionBlock::item_contains_position names, at MAVLink's 1e-7 degrees; its distance:
the haversine on a 6,371 km sphere), with this file's own code; the photos with the
independent trigger replay (tests/independent_trigger.py); the pieces of a cut leg with
pyproj's geodesic on that sphere.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Geod

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.mission.legs import leg_cuts
from aerosurvey.spec import load_spec
from conftest import REPO, example_for_px4, make_spec
from independent_legs import parse_wpl
from independent_trigger import replay

#: PX4's places (MissionBlock::item_contains_position): WAYPOINT, LOITER_UNLIM, LOITER_TIME, LAND,
#: TAKEOFF, LOITER_TO_ALT, VTOL_TAKEOFF, VTOL_LAND
PX4_PLACES = {16, 17, 19, 21, 22, 31, 84, 85}
SPHERE = Geod(a=6_371_000.0, b=6_371_000.0)
#: a 220 m x 1,220 m block flown north-south: its lines are about 1,300 m long
LONG_AREA = [[15.000, 49.400], [15.003, 49.400], [15.003, 49.411], [15.000, 49.411], [15.000, 49.400]]


def haversine(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """PX4's get_distance_to_next_waypoint."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    h = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(math.radians(lon2 - lon1) / 2) ** 2
    return 2 * 6_371_000.0 * math.asin(math.sqrt(h))


def px4_legs(waypoints: Path) -> list[tuple[int, int, float]]:
    """(seq, seq, metres) of each leg between consecutive places as PX4 reads the mission: the
    file's items without its home line (PX4 numbers them from 0), positions at 1e-7 degrees."""
    _, items = parse_wpl(waypoints.read_text())
    places = [(k, round(it.lat * 1e7) / 1e7, round(it.lon * 1e7) / 1e7) for k, it in enumerate(items)
              if it.command in PX4_PLACES]
    return [(a[0], b[0], haversine(a[1], a[2], b[1], b[2])) for a, b in zip(places, places[1:])]


def plan(spec: Path, out: Path) -> dict:
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return json.loads((out / "manifest.json").read_text())


@pytest.fixture(scope="module")
def long_lines(tmp_path_factory) -> tuple[Path, Path]:
    """The long block planned for ArduPilot and for PX4 (the same spec but the firmware)."""
    outs = []
    for firmware in ("ardupilot", "px4"):
        tmp = tmp_path_factory.mktemp(firmware)
        plan(make_spec(tmp, {"vehicle": {"firmware": firmware}, "flight": {"heading": 0.0}}, area=LONG_AREA), tmp / "out")
        outs.append(tmp / "out")
    return outs[0], outs[1]


def test_no_px4_leg_is_longer_than_900_m_where_the_ardupilot_mission_has_longer(long_lines):
    ardupilot, px4 = long_lines
    assert max(d for *_, d in px4_legs(ardupilot / "mission.waypoints")) > 1200.0  # the case is there
    legs = px4_legs(px4 / "mission.waypoints")
    assert max(d for *_, d in legs) <= 900.0, [leg for leg in legs if leg[2] > 900.0]


def test_the_cut_changes_nothing_but_adds_waypoints_on_the_legs(long_lines):
    """Without the added waypoints the PX4 mission is the ArduPilot one item for item; each added
    waypoint lies on the straight leg between the places before and after it, at their height;
    the camera commands are where they were, so every run's photos are the same."""
    ardupilot, px4 = long_lines
    _, ap = parse_wpl((ardupilot / "mission.waypoints").read_text())
    home, items = parse_wpl((px4 / "mission.waypoints").read_text())
    # PX4's waypoints leave the heading to PX4 (yaw NaN: the nose along the track), ArduPilot's say 0, which it ignores
    assert all(math.isnan(it.params[3]) for it in items if it.command == 16)
    key = [(it.command, it.frame, it.params[:3], it.lat, it.lon, it.alt) for it in items]
    want = [(it.command, it.frame, it.params[:3], it.lat, it.lon, it.alt) for it in ap]
    kept, added, j = [], [], 0
    for k, item in enumerate(key):
        if j < len(want) and item == want[j]:
            kept.append(item)
            j += 1
        else:
            added.append(k)
    assert kept == want and len(added) == 5  # one waypoint on each of the five 1.3 km lines
    for k in added:
        it = items[k]
        assert (it.command, it.frame, it.params[:3]) == (16, 3, (0.0, 0.0, 0.0))
        before = next(items[i] for i in range(k - 1, -1, -1) if items[i].command in PX4_PLACES)
        after = next(items[i] for i in range(k + 1, len(items)) if items[i].command in PX4_PLACES)
        via = SPHERE.inv(before.lon, before.lat, it.lon, it.lat)[2] + SPHERE.inv(it.lon, it.lat, after.lon, after.lat)[2]
        assert via - SPHERE.inv(before.lon, before.lat, after.lon, after.lat)[2] < 0.01
        assert it.alt == before.alt == after.alt
        # it is on the photo run: the camera was switched on before it and off after it
        on = [i for i in range(k) if items[i].command == 206 and items[i].params[0] > 0]
        off = [i for i in range(k) if items[i].command == 206 and items[i].params[0] == 0]
        assert len(on) == len(off) + 1
    photos_ap, photos_px4 = replay(ardupilot / "mission.waypoints"), replay(px4 / "mission.waypoints")
    assert len(photos_px4) == len(photos_ap) == len(json.loads((px4 / "manifest.json").read_text())["stations"])
    for a, b in zip(photos_ap, photos_px4):
        assert a.block == b.block
        assert haversine(a.lat, a.lon, b.lat, b.lon) < 0.05
    assert home.lat == parse_wpl((ardupilot / "mission.waypoints").read_text())[0].lat


def test_a_lower_limit_from_the_spec_cuts_every_leg_within_it(tmp_path):
    out = tmp_path / "out"
    plan(make_spec(tmp_path, {"vehicle": {"firmware": "px4", "max_leg_m": 300.0}, "flight": {"heading": 0.0}},
                   area=LONG_AREA), out)
    legs = px4_legs(out / "mission.waypoints")
    assert max(d for *_, d in legs) <= 300.0 and max(d for *_, d in legs) > 250.0


@pytest.mark.parametrize("name,longest", [("obratan-72ha", 1474.0), ("road-corridor", 2516.0)])
def test_the_examples_sorties_fly_no_leg_over_900_m_for_px4_and_count_their_items(name, longest, tmp_path):
    """The Obrataň block (its longest sortie leg 1,474 m, in its 3 m/s wind) and the road corridor (a 2,516 m leg) planned for PX4:
    every sortie's legs within 900 m; the manifest counts each sortie's items as its file has them."""
    ardupilot = plan(REPO / "missions" / f"{name}.toml", tmp_path / "ardupilot")
    out = tmp_path / "px4"
    manifest = plan(example_for_px4(name, tmp_path), out)
    assert [s["photos"] for s in manifest["sorties"]] == [s["photos"] for s in ardupilot["sorties"]]
    assert max(d for s in ardupilot["sorties"] for *_, d in px4_legs(tmp_path / "ardupilot" / s["files"][1])) == \
        pytest.approx(longest, abs=1.0)
    for s in manifest["sorties"]:
        waypoints = out / s["files"][1]
        assert max(d for *_, d in px4_legs(waypoints)) <= 900.0, s["id"]
        assert s["mission_items"] == len(parse_wpl(waypoints.read_text())[1]) + 1, s["id"]


@settings(max_examples=200, deadline=None)
@given(lat=st.floats(-70.0, 70.0), lon=st.floats(-180.0, 180.0), bearing=st.floats(0.0, 360.0),
       length=st.floats(1.0, 20_000.0), limit=st.floats(50.0, 5_000.0))
def test_a_leg_is_cut_into_the_fewest_equal_pieces_on_it_within_the_limit(lat, lon, bearing, length, limit):
    lon2, lat2, _ = SPHERE.fwd(lon, lat, bearing, length)
    cuts = leg_cuts(lat, lon, lat2, lon2, limit)
    points = [(lat, lon)] + [(a, b) for a, b, _ in cuts] + [(lat2, lon2)]
    pieces = [SPHERE.inv(p[1], p[0], q[1], q[0])[2] for p, q in zip(points, points[1:])]
    assert max(pieces) <= limit - 1.0 + 1e-6  # a metre under the limit, for MAVLink's 1e-7 degrees
    assert max(pieces) - min(pieces) < 1e-3
    assert sum(pieces) == pytest.approx(length, abs=1e-3)  # on the leg: no way round
    if cuts:
        assert length / len(cuts) > limit - 1.0  # one piece fewer would be too long
    assert [f for *_, f in cuts] == pytest.approx([k / (len(cuts) + 1) for k in range(1, len(cuts) + 1)])


def _spec_text(tmp_path: Path, vehicle: dict, flight: dict | None = None) -> Path:
    spec = make_spec(tmp_path, {"vehicle": vehicle, **({"flight": flight} if flight else {})})
    return spec


def test_max_leg_m_is_for_px4_and_a_px4_plane_approach_must_fit_it(tmp_path):
    with pytest.raises(InputError, match=r"vehicle.max_leg_m is set but vehicle.firmware is 'ardupilot'"):
        load_spec(_spec_text(tmp_path, {"max_leg_m": 500.0}))
    with pytest.raises(InputError, match=r"vehicle.max_leg_m = 5.0 is not allowed: a number in \[10.0, 100000.0\]"):
        load_spec(_spec_text(tmp_path, {"firmware": "px4", "max_leg_m": 5.0}))
    assert load_spec(_spec_text(tmp_path, {"firmware": "px4"})).vehicle.max_leg_m == 900.0
    assert load_spec(_spec_text(tmp_path, {"firmware": "ardupilot"})).vehicle.max_leg_m is None
    plane = {"firmware": "px4", "type": "plane", "cruise_speed_ms": 16.0, "max_leg_m": 400.0}
    with pytest.raises(InputError, match=r"flight.approach_m = 500 is longer than vehicle.max_leg_m = 400"):
        load_spec(_spec_text(tmp_path, plane, {"end": "land", "wind_from_deg": 270.0, "approach_m": 500.0}))
    assert load_spec(_spec_text(tmp_path, plane, {"end": "land", "wind_from_deg": 270.0, "approach_m": 400.0}))
