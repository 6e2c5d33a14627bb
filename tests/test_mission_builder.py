"""The MAVLink items of a plan: takeoff, speed, camera on/off per run, lead-ins, end."""

from __future__ import annotations

import math

import numpy as np
import pyproj
import pytest

from aerosurvey.inputs import plan_from_files
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.builder import build_mission
from aerosurvey.spec import load_spec
from conftest import make_spec


def _plan(tmp_path, overrides=None):
    plan = plan_from_files(load_spec(make_spec(tmp_path, overrides)))
    return plan, build_mission(plan)


def test_copter_item_pattern(tmp_path):
    plan, m = _plan(tmp_path)
    items = m.items
    assert items[0].command == mav.NAV_TAKEOFF and items[0].z == pytest.approx(plan.sensor.heights.nominal_agl_m, abs=0.01)
    assert items[1].command == mav.DO_CHANGE_SPEED and items[1].param2 == pytest.approx(plan.sensor.speed.speed_ms, abs=0.01)
    assert items[-1].command == mav.NAV_RETURN_TO_LAUNCH
    body = [it.command for it in items[2:-1]]
    run = [mav.NAV_WAYPOINT, mav.NAV_WAYPOINT, mav.DO_SET_CAM_TRIGG_DIST, mav.NAV_WAYPOINT, mav.DO_SET_CAM_TRIGG_DIST]
    # the first run's lead-in is followed by the gimbal pointed straight down (the mount may be where another flight left it)
    assert body[:2] == [mav.NAV_WAYPOINT, mav.DO_MOUNT_CONTROL] and (items[3].param1, items[3].param3) == (-90.0, 0.0)
    assert body[:1] + body[2:] == run * len(plan.route.runs)
    on = [it for it in items if it.command == mav.DO_SET_CAM_TRIGG_DIST and it.param1 > 0]
    off = [it for it in items if it.command == mav.DO_SET_CAM_TRIGG_DIST and it.param1 == 0]
    assert len(on) == len(off) == len(plan.route.runs)
    # ArduPilot checks the distance at 50 Hz: photos land a whole number of check steps apart
    step = plan.sensor.speed.speed_ms / 50.0
    assert all(it.param1 == plan.sensor.trigger_distance_m and it.param3 == 1 for it in on)
    assert math.ceil(plan.sensor.trigger_distance_m / step) * step == pytest.approx(plan.sensor.base_m)
    assert plan.sensor.base_m / step == pytest.approx(round(plan.sensor.base_m / step))
    assert {it.frame for it in items if it.command == mav.NAV_WAYPOINT} == {mav.FRAME_GLOBAL_RELATIVE_ALT}


def test_line_end_is_half_a_base_past_the_last_station(tmp_path):
    plan, m = _plan(tmp_path)
    t = pyproj.Geod(ellps="WGS84")
    wps = [it for it in m.items if it.command == mav.NAV_WAYPOINT]
    st = plan.stations
    for i in range(len(plan.route.runs)):
        lead, first, end = wps[3 * i: 3 * i + 3]
        last = np.flatnonzero(st.run == i)[-1]
        firsti = np.flatnonzero(st.run == i)[0]
        _, _, d_end = t.inv(st.lon[last], st.lat[last], end.y, end.x)
        _, _, d_first = t.inv(st.lon[firsti], st.lat[firsti], first.y, first.x)
        _, _, d_lead = t.inv(lead.y, lead.x, first.y, first.x)
        assert d_first < 0.01
        assert d_end == pytest.approx(plan.sensor.base_m / 2, rel=2e-3)
        assert d_lead == pytest.approx(plan.sensor.lead_in_m, rel=2e-3)


def test_copter_lead_in_is_the_stopping_distance(tmp_path):
    plan, _ = _plan(tmp_path, {"vehicle": {"acceleration_ms2": 2.0}})
    assert plan.sensor.lead_in_m == pytest.approx(max(5.0, plan.sensor.speed.speed_ms ** 2 / 4.0))


def test_plane_lead_in_is_three_l1_distances(tmp_path):
    # SITL: a plane settles onto the line only ~3 L1 distances after a turn (docs/planning.md)
    plan, _ = _plan(tmp_path, {"vehicle": {"type": "plane", "cruise_speed_ms": 16.0}})
    v = plan.sensor.speed.speed_ms
    assert plan.sensor.lead_in_m == pytest.approx(max(plan.sensor.turn_radius_m, 3 * 0.75 * 17.0 * v / math.pi), rel=1e-9)
    tuned, _ = _plan(tmp_path, {"vehicle": {"type": "plane", "cruise_speed_ms": 16.0, "nav_period_s": 12.0}})
    assert tuned.sensor.lead_in_m == pytest.approx(max(tuned.sensor.turn_radius_m, 3 * 0.75 * 12.0 * v / math.pi), rel=1e-9)
    assert tuned.sensor.lead_in_m < plan.sensor.lead_in_m
    with pytest.raises(Exception, match=r"vehicle\.nav_period_s.*2"):
        _plan(tmp_path, {"vehicle": {"type": "plane", "nav_period_s": 2}})


def test_plane_takeoff_and_land_option(tmp_path):
    plan, m = _plan(tmp_path, {"vehicle": {"type": "plane", "cruise_speed_ms": 16.0},
                               "flight": {"end": "land", "wind_from_deg": 270.0, "approach_m": 400.0}})
    assert m.items[0].command == mav.NAV_TAKEOFF and m.items[0].param1 == 15.0
    assert [it.command for it in m.items[-3:]] == [mav.DO_LAND_START, mav.NAV_WAYPOINT, mav.NAV_LAND]
    # wind from the west: the approach starts 400 m east of the touchdown, so the plane lands heading west
    approach, land = m.items[-2], m.items[-1]
    geod = pyproj.Geod(ellps="WGS84")
    az, _, dist = geod.inv(approach.y, approach.x, land.y, land.x)
    assert dist == pytest.approx(400.0, rel=0.01) and (az % 360) == pytest.approx(270.0, abs=1.0)
    with pytest.raises(Exception, match="wind_from_deg"):
        _plan(tmp_path, {"vehicle": {"type": "plane"}, "flight": {"end": "land"}})
    assert m.vehicle == "plane" and m.vehicle_type_id == mav.TYPE_FIXED_WING
    # line waypoints carry a small acceptance radius, or ArduPlane would reach them a turn distance early
    on = [i for i, it in enumerate(m.items) if it.command == mav.DO_SET_CAM_TRIGG_DIST]
    assert all(m.items[i - 1].param2 == 2.0 for i in on)
    speed = next(it for it in m.items if it.command == mav.DO_CHANGE_SPEED)
    assert speed.param1 == 0.0 and speed.param2 == pytest.approx(plan.sensor.speed.speed_ms, abs=0.01)  # airspeed for ArduPlane
    v = plan.sensor.speed.speed_ms  # the survey speed (here the motion-blur limit), not the cruise speed
    assert plan.sensor.turn_radius_m == pytest.approx(v ** 2 / (9.80665 * math.tan(math.radians(30))), rel=1e-6)


def test_time_trigger_items(tmp_path):
    plan, m = _plan(tmp_path, {"camera": {"trigger": "time", "interval_s": 3.0}})
    on = [it for it in m.items if it.command == mav.DO_SET_CAM_TRIGG_INTERVAL and it.param1 > 0]
    assert len(on) == len(plan.route.runs) and on[0].param1 == 3000.0
    # ground speed gives the photo base at that interval (or less when the vehicle is slower)
    speed = plan.sensor.speed
    assert speed.speed_ms == pytest.approx(min(plan.sensor.base_m / 3.0, speed.cruise_ms, speed.blur_limit_ms))


def test_camera_intervalometer_has_no_trigger_items(tmp_path):
    plan, m = _plan(tmp_path, {"camera": {"trigger": "camera", "interval_s": 2.0}})
    cmds = {it.command for it in m.items}
    assert mav.DO_SET_CAM_TRIGG_DIST not in cmds and mav.DO_SET_CAM_TRIGG_INTERVAL not in cmds
    assert plan.sensor.trigger_interval_s == 2.0


def test_interval_shorter_than_the_camera_cycle_is_refused(tmp_path):
    from aerosurvey.errors import InputError

    with pytest.raises(InputError, match="shorter than the camera's cycle time"):
        _plan(tmp_path, {"camera": {"trigger": "camera", "interval_s": 0.2}})


def test_copter_fixed_yaw(tmp_path):
    _, m = _plan(tmp_path, {"flight": {"fixed_yaw_deg": 45.0}})
    yaw = [it for it in m.items if it.command == mav.CONDITION_YAW]
    assert len(yaw) == 1 and yaw[0].param1 == 45.0 and yaw[0].param4 == 0.0
    _, px4 = _plan(tmp_path, {"flight": {"fixed_yaw_deg": 45.0}, "vehicle": {"firmware": "px4"}})
    assert not [it for it in px4.items if it.command == mav.CONDITION_YAW]
    assert {it.param4 for it in px4.items if it.command == mav.NAV_WAYPOINT} == {45.0}
    assert px4.autopilot_id == mav.AUTOPILOT_PX4


def test_px4_waypoints_leave_the_nose_to_px4(tmp_path):
    """Without a fixed yaw, a PX4 waypoint's yaw is NaN: PX4 turns a multicopter to a finite one
    (0 held the nose north on every line in its SITL) and keeps its yaw mode (the nose along the
    track) for NaN. ArduCopter ignores it: ArduPilot's waypoints keep 0."""
    import math

    _, px4 = _plan(tmp_path, {"vehicle": {"firmware": "px4"}})
    waypoints = [it for it in px4.items if it.command == mav.NAV_WAYPOINT]
    assert waypoints and all(math.isnan(it.param4) for it in waypoints)
    _, ardupilot = _plan(tmp_path, {})
    assert {it.param4 for it in ardupilot.items if it.command == mav.NAV_WAYPOINT} == {0.0}


def test_geofence_in_the_plan_file(tmp_path):
    import json

    import shapely

    from aerosurvey.mission.formats.qgc_plan import dumps_plan, loads_plan
    from conftest import write_geojson

    zone = [[15.0025, 49.4012], [15.0035, 49.4012], [15.0035, 49.4022], [15.0025, 49.4022], [15.0025, 49.4012]]
    write_geojson(tmp_path / "zone.geojson", [zone])
    plan, m = _plan(tmp_path, {"area": {"exclusions": ["zone.geojson"]}})
    doc = json.loads(dumps_plan(m))
    polys = doc["geoFence"]["polygons"]
    assert [p["inclusion"] for p in polys] == [True, False]
    fence = shapely.Polygon([(lon, lat) for lat, lon in polys[0]["polygon"]])
    for it in m.items:
        if it.command == mav.NAV_WAYPOINT:
            assert fence.contains(shapely.Point(it.y, it.x))
    assert loads_plan(dumps_plan(m)).fence_exclusion == m.fence_exclusion

