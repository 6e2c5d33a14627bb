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
def long_lines(tmp_path_factory) -> dict[str, Path]:
    """The long block planned for ArduPilot and for PX4 (the same spec but the firmware), and for
    PX4 with legs of at most 100 km (none cut) and of at most 40 m (PX4's photo lines have a
    waypoint every second station, about 50 m apart: each is cut once)."""
    outs = {}
    for name, vehicle in (("ardupilot", {}), ("px4", {"firmware": "px4"}),
                          ("px4-uncut", {"firmware": "px4", "max_leg_m": 100_000.0}),
                          ("px4-40m", {"firmware": "px4", "max_leg_m": 40.0})):
        tmp = tmp_path_factory.mktemp(name)
        plan(make_spec(tmp, {"vehicle": vehicle, "flight": {"heading": 0.0}}, area=LONG_AREA), tmp / "out")
        outs[name] = tmp / "out"
    return outs


def test_no_px4_leg_is_longer_than_900_m_where_the_ardupilot_mission_has_longer(long_lines):
    assert max(d for *_, d in px4_legs(long_lines["ardupilot"] / "mission.waypoints")) > 1200.0  # the case is there
    legs = px4_legs(long_lines["px4"] / "mission.waypoints")
    assert max(d for *_, d in legs) <= 900.0, [leg for leg in legs if leg[2] > 900.0]


def test_the_cut_changes_nothing_but_adds_waypoints_on_the_legs(long_lines):
    """Without the added waypoints the PX4 mission cut to 40 m legs is the uncut one item for item;
    each leg longer than 40 m has the fewest waypoints added that make its pieces fit, each on
    the straight leg between the places before and after it, at their height; the camera
    commands are where they were, so every run's photos are the same."""
    home, items = parse_wpl((long_lines["px4-40m"] / "mission.waypoints").read_text())
    _, uncut = parse_wpl((long_lines["px4-uncut"] / "mission.waypoints").read_text())
    # PX4's waypoints leave the heading to PX4 (yaw NaN: the nose along the track)
    assert all(math.isnan(it.params[3]) for it in items if it.command == 16)
    def meaning(it):  # NaN (a parameter PX4 leaves unset: the gimbal's rates) equal to itself
        return (it.command, it.frame, tuple(None if math.isnan(v) else v for v in it.params[:3]), it.lat, it.lon, it.alt)

    key = [meaning(it) for it in items]
    want = [meaning(it) for it in uncut]
    kept, added, j = [], [], 0
    for k, item in enumerate(key):
        if j < len(want) and item == want[j]:
            kept.append(item)
            j += 1
        else:
            added.append(k)
    places = [it for it in uncut if it.command in PX4_PLACES]
    needed = sum(max(0, math.ceil(haversine(a.lat, a.lon, b.lat, b.lon) / 40.0 - 1e-9) - 1) for a, b in zip(places, places[1:]))
    assert kept == want and len(added) == needed and needed >= 5 * 20  # 1.3 km lines: 26 legs of about 50 m each
    for k in added:
        it = items[k]
        assert (it.command, it.frame, it.params[:3]) == (16, 3, (0.0, 0.0, 0.0))
        before = next(items[i] for i in range(k - 1, -1, -1) if items[i].command in PX4_PLACES)
        after = next(items[i] for i in range(k + 1, len(items)) if items[i].command in PX4_PLACES)
        via = SPHERE.inv(before.lon, before.lat, it.lon, it.lat)[2] + SPHERE.inv(it.lon, it.lat, after.lon, after.lat)[2]
        assert via - SPHERE.inv(before.lon, before.lat, after.lon, after.lat)[2] < 0.01
        assert it.alt == before.alt == after.alt
    photos_uncut, photos_cut = replay(long_lines["px4-uncut"] / "mission.waypoints"), replay(long_lines["px4-40m"] / "mission.waypoints")
    assert len(photos_cut) == len(photos_uncut) > 0
    # a cut waypoint lies on its leg to 1e-8 degrees: a trigger check may then fall one step
    # (10 m/s at 50 Hz: 0.2 m) later or sooner, never a photo more or less
    for a, b in zip(photos_uncut, photos_cut):
        assert a.block == b.block
        assert haversine(a.lat, a.lon, b.lat, b.lon) < 0.21
    assert home.lat == parse_wpl((long_lines["px4-uncut"] / "mission.waypoints").read_text())[0].lat


def _offsets(plan_dir: Path, update_hz: float) -> list[float]:
    """Each replayed photo's distance from its station (in order); as many photos as stations."""
    stations = json.loads((plan_dir / "manifest.json").read_text())["stations"]
    photos = replay(plan_dir / "mission.waypoints", update_hz)
    assert len(photos) == len(stations)
    return [haversine(p.lat, p.lon, s["lat"], s["lon"]) for p, s in zip(photos, stations)]


def test_px4_checking_its_distance_every_50_ms_keeps_every_photo_on_its_station(long_lines):
    """PX4's trigger replayed on its mission (a check every 50 ms): the restarts at every second
    station keep each of the 53 photos of a 1.3 km line within two check steps (1 m at 10 m/s) of
    its station: the photo between two restarts comes at the commanded distance, the base and a
    step, or up to a step later. The ArduPilot mission, whose stations are laid for 50 Hz, drifts by
    more than 5 m along the same lines when checked every 50 ms, as PX4 would."""
    assert max(_offsets(long_lines["px4"], 20.0)) <= 1.0 + 0.01
    assert max(_offsets(long_lines["ardupilot"], 50.0)) <= 0.2  # within a 50 Hz check step
    assert max(_offsets(long_lines["ardupilot"], 20.0)) > 5.0


def test_a_lower_limit_from_the_spec_cuts_every_leg_within_it(long_lines):
    legs = px4_legs(long_lines["px4-40m"] / "mission.waypoints")
    assert max(d for *_, d in legs) <= 40.0 and max(d for *_, d in legs) > 30.0


@pytest.mark.parametrize("name,longest", [("obratan-72ha", 1498.7), ("road-corridor", 3720.9)])
def test_the_examples_sorties_fly_no_leg_over_900_m_for_px4_and_count_their_items(name, longest, tmp_path):
    """The Obrataň block (its longest sortie leg 1,499 m, in its 3 m/s wind, lines laid for it) and the road corridor
    (a 3,721 m leg) planned for PX4: every sortie's legs within 900 m; the manifest counts each sortie's items as its
    file has them."""
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
