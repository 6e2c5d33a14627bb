"""The flight program and its MAVLink emitter: the .waypoints read back by pymavlink's loader
give the program again (by meaning); gimbal pitch changes and hover-and-shoot as MAVLink's
common.xml documents them (read from pymavlink's copy, not from our ids)."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from pymavlink import mavutil, mavwp

from aerosurvey.inputs import plan_from_files
from aerosurvey.mission.builder import build_mission, mavlink_mission
from aerosurvey.mission.formats.wpl import dumps_wpl
from aerosurvey.mission.program import CameraRestart, CameraStart, CameraStop, Gimbal, HoverShoot, flight_program
from aerosurvey.plan.model import Plan, RouteWaypoint
from aerosurvey.spec import load_spec
from conftest import REPO, make_spec

sys.path.insert(0, str(REPO / "missions" / "tools"))
from synthetic_dem import write_dem  # noqa: E402

M = mavutil.mavlink
CMD = M.enums["MAV_CMD"]
NAV = {M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_LAND}


def _plan(tmp_path: Path, overrides: dict | None = None) -> Plan:
    return plan_from_files(load_spec(make_spec(tmp_path, overrides)))


def _read_back(tmp_path: Path, text: str) -> list:
    """The items as pymavlink's MAVWPLoader reads the file (home is its item 0)."""
    path = tmp_path / "m.waypoints"
    path.write_text(text)
    loader = mavwp.MAVWPLoader()
    loader.load(str(path))
    return [loader.wp(i) for i in range(1, loader.count())]


def _meaning(items: list) -> list[tuple]:
    """Each survey waypoint of a read-back mission with what happens on reaching it, in MAVLink terms:
    (lat, lon, alt, hold s, camera on/off/photo/gimbal events)."""
    out: list[list] = []
    body = [it for it in items if it.command not in (M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_CMD_CONDITION_YAW)]
    for it in body:
        if it.command == M.MAV_CMD_NAV_WAYPOINT:
            out.append([round(it.x, 7), round(it.y, 7), round(it.z, 2), it.param1, []])
        elif it.command in (M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_NAV_LAND, M.MAV_CMD_DO_LAND_START):
            break
        elif it.command == M.MAV_CMD_DO_SET_CAM_TRIGG_DIST:
            out[-1][4].append(("distance", round(it.param1, 4)) if it.param1 > 0 else ("stop",))
        elif it.command == M.MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL:
            out[-1][4].append(("time", round(it.param1 / 1000.0, 4)) if it.param1 > 0 else ("stop",))
        elif it.command in (M.MAV_CMD_DO_DIGICAM_CONTROL, M.MAV_CMD_IMAGE_START_CAPTURE):
            out[-1][4].append(("photo",))
        elif it.command in (M.MAV_CMD_DO_MOUNT_CONTROL, M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW):
            out[-1][4].append(("gimbal", round(it.param1, 2)))
    return [tuple(w[:4]) + (tuple(w[4]),) for w in out]


def _program_meaning(program) -> list[tuple]:
    out = []
    for w in program.waypoints:
        ev: list[tuple] = []
        hold = 0.0
        for a in w.actions:
            if isinstance(a, Gimbal):
                ev.append(("gimbal", round(a.pitch_deg, 2)))
            elif isinstance(a, CameraStart):
                ev.append(("distance", round(a.distance_m, 4)) if a.distance_m is not None else ("time", round(a.interval_s, 4)))
            elif isinstance(a, CameraRestart):
                ev.append(("distance", round(a.distance_m, 4)))
            elif isinstance(a, CameraStop):
                ev.append(("stop",))
            elif isinstance(a, HoverShoot):
                hold = a.hold_s
                ev.append(("photo",))
        out.append((round(w.lat, 7), round(w.lon, 7), round(w.alt_m, 2), hold, tuple(ev)))
    # the plane's approach waypoint is the program's end, not one of its waypoints
    return out


@pytest.mark.parametrize("overrides", [
    None,
    {"camera": {"trigger": "time", "interval_s": 3.0}},
    {"vehicle": {"firmware": "px4"}, "flight": {"fixed_yaw_deg": 30.0}},
    {"vehicle": {"type": "plane", "cruise_speed_ms": 16.0}},
    {"battery": {"usable_min": 6.0, "reserve": 0.2}},
])
def test_waypoints_file_read_back_by_pymavlink_is_the_program(tmp_path: Path, overrides: dict | None) -> None:
    plan = _plan(tmp_path, overrides)
    flights = [None, *range(len(plan.sorties))]
    for k in flights:
        program = flight_program(plan, k)
        items = _read_back(tmp_path, dumps_wpl(mavlink_mission(program)))
        assert _meaning(items) == _program_meaning(program)
        takeoff = items[0]
        assert takeoff.command == M.MAV_CMD_NAV_TAKEOFF and takeoff.z == pytest.approx(program.takeoff_alt_m, abs=0.01)
        end = items[-1].command
        assert end == (M.MAV_CMD_NAV_RETURN_TO_LAUNCH if program.end == "rtl" else M.MAV_CMD_NAV_LAND)


def _tilted(plan: Plan, runs: dict[int, float], yaw_offset: dict[int, float] | None = None) -> Plan:
    """The plan with the camera pitched on some runs (what the lead's oblique patterns will lay)."""
    st = plan.stations
    pitch = st.pitch_deg.copy()
    bearing = st.camera_yaw_deg.copy()
    for r, p in runs.items():
        pitch[st.run == r] = p
    for r, d in (yaw_offset or {}).items():
        bearing[st.run == r] = (bearing[st.run == r] + d) % 360.0
    return replace(plan, altitudes=replace(plan.altitudes, stations=replace(st, pitch_deg=pitch, camera_yaw_deg=bearing)))


def test_a_nadir_plan_sets_the_gimbal_down_at_every_flights_first_run(tmp_path: Path) -> None:
    """A flight may take off with the mount where another left it (an oblique sortie's -45° and yaw
    offset): every flight of a nadir plan, the whole mission and each sortie, points it straight
    down, yaw along the nose, once, right after its first lead-in waypoint."""
    plan = _plan(tmp_path, {"battery": {"usable_min": 6.0, "reserve": 0.2}})
    assert (plan.stations.pitch_deg == -90).all() and len(plan.sorties) >= 2
    for firmware, cmd in (("ardupilot", M.MAV_CMD_DO_MOUNT_CONTROL), ("px4", M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW)):
        p = replace(plan, vehicle=replace(plan.vehicle, firmware=firmware))
        for k in (None, *range(len(p.sorties))):
            items = _read_back(tmp_path, dumps_wpl(build_mission(p, k)))
            mounts = [i for i, it in enumerate(items) if it.command in (M.MAV_CMD_DO_MOUNT_CONTROL,
                                                                         M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW)]
            assert len(mounts) == 1, (firmware, k)
            g = items[mounts[0]]
            assert g.command == cmd and g.param1 == -90.0
            # yaw relative to the nose: ArduPilot's param3, PX4's param2
            assert (g.param3 if firmware == "ardupilot" else g.param2) == 0.0
            first_wp = next(i for i, it in enumerate(items) if it.command == M.MAV_CMD_NAV_WAYPOINT)
            first_cam = next(i for i, it in enumerate(items) if it.command == M.MAV_CMD_DO_SET_CAM_TRIGG_DIST)
            assert first_wp < mounts[0] < first_cam


def test_gimbal_items_where_the_pitch_changes_with_the_documented_params(tmp_path: Path) -> None:
    base = _plan(tmp_path)
    assert len(base.route.runs) >= 4
    plan = _tilted(base, {1: -45.0, 2: -45.0}, {2: 90.0})
    # ArduPilot: DO_MOUNT_CONTROL, param1 pitch, param3 yaw, param7 (z) the mount mode
    assert "pitch" in CMD[M.MAV_CMD_DO_MOUNT_CONTROL].param[1].lower()
    assert "yaw" in CMD[M.MAV_CMD_DO_MOUNT_CONTROL].param[3].lower()
    items = build_mission(plan).items
    mounts = [(i, it) for i, it in enumerate(items) if it.command == M.MAV_CMD_DO_MOUNT_CONTROL]
    # a plan that tilts the camera sets it at its first run (nadir: the mount may be where another
    # flight left it); run 1 tilts, run 2 keeps the pitch but looks 90° right of the nose, run 3 is nadir again
    assert [(it.param1, it.param3) for _, it in mounts] == [(-90.0, 0.0), (-45.0, 0.0), (-45.0, 90.0), (-90.0, 0.0)]
    assert all(it.z == M.MAV_MOUNT_MODE_MAVLINK_TARGETING for _, it in mounts)
    # each before its run's first station: right after the run's lead-in waypoint
    for (i, _), run in zip(mounts, (0, 1, 2, 3), strict=True):
        r = plan.route.runs[run]
        assert items[i - 1].command == M.MAV_CMD_NAV_WAYPOINT
        assert items[i - 1].tag == f"P{r.pass_index}-L{r.line + 1:03d}-R{r.part + 1}:lead-in"
    # PX4: DO_GIMBAL_MANAGER_PITCHYAW, param1 pitch, param2 yaw, param5 flags: pitch against the horizon
    doc = CMD[M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW].param
    assert "pitch" in doc[1].lower() and "yaw" in doc[2].lower() and "flags" in doc[5].lower()
    px4 = replace(plan, vehicle=replace(plan.vehicle, firmware="px4"))
    g = [it for it in build_mission(px4).items if it.command == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW]
    assert [(it.param1, it.param2) for it in g] == [(-90.0, 0.0), (-45.0, 0.0), (-45.0, 90.0), (-90.0, 0.0)]
    assert all(int(it.x) & M.GIMBAL_MANAGER_FLAGS_PITCH_LOCK and not int(it.x) & M.GIMBAL_MANAGER_FLAGS_YAW_LOCK for it in g)
    assert not [it for it in build_mission(px4).items if it.command == M.MAV_CMD_DO_MOUNT_CONTROL]


def _hover(plan: Plan, settle_s: float = 2.0) -> Plan:
    return replace(plan, camera=replace(plan.camera, trigger="hover", settle_s=settle_s))


@pytest.mark.parametrize("overrides", [None, {"terrain": {"dem": "dem.tif", "mode": "follow", "tolerance_m": 2.0}},
                                       {"battery": {"usable_min": 6.0, "reserve": 0.2}}])
def test_hover_stops_and_shoots_once_at_every_station(tmp_path: Path, overrides: dict | None) -> None:
    # a hilly DEM (UTM 33N over the test area): the follow mode puts terrain waypoints on some stations
    write_dem(str(tmp_path / "dem.tif"), 32633, 499700.0, 5472400.0, 140, 140, 10.0, 400.0, 40.0)
    plan = _hover(_plan(tmp_path, overrides), settle_s=2.5)
    if overrides and "terrain" in overrides:
        assert any(w.kind == "terrain" for w in plan.waypoints)
    flights = [None] if not plan.sorties else list(range(len(plan.sorties)))
    shot: list[str] = []
    for k in flights:
        program = flight_program(plan, k)
        for w in program.waypoints:
            hovers = [a for a in w.actions if isinstance(a, HoverShoot)]
            assert not [a for a in w.actions if isinstance(a, (CameraStart, CameraStop))]
            if hovers:
                assert hovers == [HoverShoot(2.5)]
                shot.append(w.tag)
    # every station once, in flight order
    assert shot == list(plan.stations.ids)
    st = plan.stations
    program = flight_program(plan, flights[0])
    at = {w.tag: w for w in program.waypoints}
    k = [st.ids.index(t) for t in at if t in st.ids]
    assert np.allclose([at[st.ids[i]].lat for i in k], st.lat[k], atol=1e-7)


def test_hover_items_per_autopilot_with_the_documented_params(tmp_path: Path) -> None:
    plan = _hover(_plan(tmp_path), settle_s=2.0)
    assert "hold" in CMD[M.MAV_CMD_NAV_WAYPOINT].param[1].lower()
    n = len(plan.stations.ids)
    items = build_mission(plan).items
    shots = [i for i, it in enumerate(items) if it.command == M.MAV_CMD_DO_DIGICAM_CONTROL]
    assert len(shots) == n
    # DO_DIGICAM_CONTROL param5 (x) is the shooting command: 1 takes a photo
    assert "shoot" in CMD[M.MAV_CMD_DO_DIGICAM_CONTROL].param[5].lower()
    assert all(items[i].x == 1 for i in shots)
    assert all(items[i - 1].command == M.MAV_CMD_NAV_WAYPOINT and items[i - 1].param1 == 2.0 for i in shots)
    assert not [it for it in items if it.command in (M.MAV_CMD_DO_SET_CAM_TRIGG_DIST, M.MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL)]
    px4 = build_mission(replace(plan, vehicle=replace(plan.vehicle, firmware="px4"))).items
    caps = [(i, it) for i, it in enumerate(px4) if it.command == M.MAV_CMD_IMAGE_START_CAPTURE]
    doc = CMD[M.MAV_CMD_IMAGE_START_CAPTURE].param
    assert "total number of images" in doc[3].lower() and "sequence number" in doc[4].lower()
    # one image each (param3), sequence numbers 1, 2, ... (param4), no interval (param2)
    assert [(it.param2, it.param3, it.param4) for _, it in caps] == [(0.0, 1.0, float(s)) for s in range(1, n + 1)]
    assert all(px4[i - 1].param1 == 2.0 for i, _ in caps)
    assert not [it for it in px4 if it.command == M.MAV_CMD_DO_DIGICAM_CONTROL]


def test_a_bend_keeps_the_camera_on(tmp_path: Path) -> None:
    plan = _plan(tmp_path, {"vehicle": {"type": "plane", "cruise_speed_ms": 16.0}})
    wps = list(plan.waypoints)
    i = next(k for k, w in enumerate(wps) if w.kind == "line_start")
    a, b = wps[i], wps[i + 1]
    assert b.kind == "line_end"
    bend = RouteWaypoint((a.x + b.x) / 2, (a.y + b.y) / 2, (a.lon + b.lon) / 2, (a.lat + b.lat) / 2, a.alt_m, "bend", a.run, "")
    plan = replace(plan, waypoints=tuple(wps[:i + 1] + [bend] + wps[i + 1:]))
    items = build_mission(plan).items
    k = next(n for n, it in enumerate(items) if it.tag.endswith(":bend"))
    # the bend is between the camera switched on and off, a line waypoint (small acceptance radius for a plane)
    assert items[k - 1].command == M.MAV_CMD_DO_SET_CAM_TRIGG_DIST and items[k - 1].param1 > 0
    assert items[k + 1].command == M.MAV_CMD_NAV_WAYPOINT and items[k + 2].param1 == 0
    assert items[k].param2 == 2.0


@settings(max_examples=60, deadline=None)
@given(turns=st.lists(st.floats(-80.0, 80.0), min_size=0, max_size=4),
       lengths=st.lists(st.floats(20.0, 200.0), min_size=5, max_size=5),
       fractions=st.lists(st.floats(0.01, 0.99), min_size=1, max_size=30, unique=True), every=st.integers(1, 3))
def test_station_waypoints_fall_between_the_bends_in_flight_order(turns: list[float], lengths: list[float],
                                                                  fractions: list[float], every: int) -> None:
    """A strip with bends (turns up to 80°) and stations along it: the route with every
    `every`-th station (hover: 1; PX4's camera restarts: 2) keeps the line's waypoints and puts
    those stations, counted from the first, between them in the order they lie along the strip."""
    from types import SimpleNamespace

    from aerosurvey.mission.program import _with_stations

    # the strip's corners, turning by `turns` (degrees) after each leg
    heading, pts = 0.0, [np.zeros(2)]
    for k in range(len(turns) + 1):
        d = np.array([np.sin(np.radians(heading)), np.cos(np.radians(heading))])
        pts.append(pts[-1] + lengths[k] * d)
        if k < len(turns):
            heading += turns[k]
    pts_a = np.array(pts)
    seg = np.hypot(*np.diff(pts_a, axis=0).T)
    total = seg.sum()
    along = np.r_[0.0, np.sort(np.array(fractions))] * total  # a strip starts at its first station
    # a station exactly on a corner lies both before and after it: no order to check
    assume(np.min(np.abs(along[:, None] - np.cumsum(seg)[None, :-1]), initial=np.inf) > 1e-6)
    xy = []
    for s in along:
        k = int(np.searchsorted(np.cumsum(seg), s, side="right"))
        k = min(k, len(seg) - 1)
        t = (s - (np.cumsum(seg)[k] - seg[k])) / seg[k]
        xy.append(pts_a[k] + t * (pts_a[k + 1] - pts_a[k]))
    xy_a = np.array(xy)
    ids = [f"P1-L001-S{i + 1:04d}" for i in range(len(xy))]
    stations = SimpleNamespace(ids=ids, run=np.zeros(len(xy), int), x=xy_a[:, 0], y=xy_a[:, 1], lon=xy_a[:, 0],
                               lat=xy_a[:, 1], alt_rel_m=np.full(len(xy), 50.0))
    # the line starts on the first station, bends at the corners, ends past the last station
    kinds = ["bend"] * (len(pts) - 2)
    wps = ([RouteWaypoint(-10.0, 0.0, -10.0, 0.0, 50.0, "lead_in", 0, ""),
            RouteWaypoint(*xy_a[0], *xy_a[0], 50.0, "line_start", 0, ids[0])]
           + [RouteWaypoint(*p, *p, 50.0, kd, 0, "") for p, kd in zip(pts[1:-1], kinds)]
           + [RouteWaypoint(*pts[-1], *pts[-1], 50.0, "line_end", 0, "")])
    out, at = _with_stations(SimpleNamespace(stations=stations), tuple(wps), 0, len(ids) - 1, every)  # type: ignore[arg-type]
    assert [w.station for w in out if w.station] == ids[::every] and at == set(ids[::every])
    # every waypoint of the line kept, in its order
    assert [w for w in out if w.kind != "station"] == wps
    # the stations between two consecutive line waypoints are those whose distance along the strip lies between theirs
    corner_at = np.concatenate([[0.0], np.cumsum(seg)])
    bends = [corner_at[k + 1] for k in range(len(pts) - 2)]
    got = [w.kind for w in out if w.kind in ("bend", "station")]
    want = [kd for _, kd in sorted([(d, "bend") for d in bends] + [(s, "station") for s in along[::every][1:]])]
    assert got == want
