"""Turn a plan (or one sortie of it) into the MAVLink items of one flight, per autopilot.

Per photo run: a lead-in waypoint (straight approach), the first station with the camera
switched on (DO_SET_CAM_TRIGG_DIST with 'trigger once now'), terrain waypoints where the
`follow` mode needs them, a line-end waypoint half a photo base past the last station
(ArduPilot does not take the picture that falls exactly on the waypoint, as seen in its
SITL), and the camera switched off again so no photos are taken in turns.

The DO commands after a waypoint run when the vehicle reaches it (ArduPilot's AP_Mission
starts them with the next navigation item), so the camera switches on at the first station
with a picture at once, and off at the line end. Between, ArduPilot checks the distance at
50 Hz and takes a picture at the first check that lies the trigger distance or more from the
last one (AP_Camera_Backend::update): pictures land a whole number of check steps apart,
the spacing the stations are laid at (plan/photogrammetry.py, distance_trigger).

Dialects: ArduCopter (takeoff, optional CONDITION_YAW for one fixed heading, RTL or LAND
at the launch point), ArduPlane (takeoff with 15° pitch, then RTL, or DO_LAND_START, an
approach waypoint and NAV_LAND flown into the wind), PX4 (the same items except
CONDITION_YAW: a fixed heading goes into each waypoint's param4, as PX4 reads it).
"""

from __future__ import annotations

from aerosurvey import ids
from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem
from aerosurvey.plan.landing import PLANE_TAKEOFF_PITCH_DEG, approach_lonlat
from aerosurvey.plan.planner import Plan, RouteWaypoint


def _frame(plan: Plan) -> int:
    return mav.FRAME_GLOBAL_TERRAIN_ALT if plan.altitude_frame == "terrain" else mav.FRAME_GLOBAL_RELATIVE_ALT


def _yaw_param4(plan: Plan) -> float:
    yaw = plan.spec.flight.fixed_yaw_deg
    return float(yaw) if yaw is not None and plan.spec.vehicle.firmware == "px4" else 0.0


#: ArduPlane counts a waypoint as reached up to its turn distance early (WP_RADIUS, 90 m by
#: default): the camera would switch on and off that far from the line's ends. A waypoint's
#: own acceptance radius (param2) overrides it, so line waypoints of planes carry a small one.
PLANE_LINE_ACCEPTANCE_M = 2.0


def _wp(plan: Plan, w: RouteWaypoint, tag: str, alt_shift: float) -> MissionItem:
    alt = w.alt_m + (alt_shift if plan.altitude_frame == "relative" else 0.0)
    on_line = w.kind in ("line_start", "terrain", "bend", "line_end")
    accept = PLANE_LINE_ACCEPTANCE_M if plan.spec.vehicle.type == "plane" and on_line else 0.0
    return MissionItem(mav.NAV_WAYPOINT, _frame(plan), 0.0, accept, 0.0, _yaw_param4(plan),
                       round(w.lat, 8), round(w.lon, 8), round(alt, 2), True, tag)


def _camera_on(plan: Plan, tag: str) -> list[MissionItem]:
    trig = plan.spec.camera.trigger
    if trig == "distance":
        assert plan.trigger_distance_m is not None
        return [MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, plan.trigger_distance_m, 0.0, 1.0, tag=tag)]
    if trig == "time":
        assert plan.trigger_interval_s is not None
        return [MissionItem(mav.DO_SET_CAM_TRIGG_INTERVAL, mav.FRAME_MISSION, round(plan.trigger_interval_s * 1000.0, 1), -1.0, tag=tag)]
    return []


def _camera_off(plan: Plan, tag: str) -> list[MissionItem]:
    trig = plan.spec.camera.trigger
    if trig == "distance":
        assert plan.trigger_distance_m is not None
        return [MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 0.0, 0.0, 0.0, tag=tag)]
    if trig == "time":
        return [MissionItem(mav.DO_SET_CAM_TRIGG_INTERVAL, mav.FRAME_MISSION, 0.0, -1.0, tag=tag)]
    return []


def run_id(plan: Plan, run: int) -> str:
    r = plan.route.runs[run]
    return ids.run_id(r.pass_index, r.line, r.part)


def _landing(plan: Plan, lat: float, lon: float) -> list[MissionItem]:
    """DO_LAND_START, an approach waypoint downwind of the launch point, NAV_LAND into the wind."""
    f = plan.spec.flight
    # the plane lands heading into the wind: the approach starts downwind of the touchdown point
    alon, alat = approach_lonlat(plan.spec, lon, lat)
    return [
        MissionItem(mav.DO_LAND_START, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, round(alat, 8), round(alon, 8), 0.0, tag="land-start"),
        MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, round(alat, 8), round(alon, 8),
                    round(f.approach_alt_m, 2), tag="approach"),
        MissionItem(mav.NAV_LAND, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, round(lat, 8), round(lon, 8), 0.0, tag="land"),
    ]


def build_mission(plan: Plan, waypoints: list[RouteWaypoint] | None = None, name: str = "mission",
                  home: tuple[float, float, float] | None = None) -> Mission:
    """The mission for one flight: takeoff, survey runs in order, then RTL or land.

    `home` (lon, lat, ground AMSL) is the launch point of a sortie; relative altitudes are
    shifted by the difference between its ground and the plan's home ground.
    """
    spec = plan.spec
    wps = plan.waypoints if waypoints is None else waypoints
    lon, lat, ground = plan.home if home is None else home
    alt_shift = plan.home[2] - ground
    items: list[MissionItem] = []
    first_alt = wps[0].alt_m + (alt_shift if plan.altitude_frame == "relative" else 0.0)
    takeoff_alt = round(first_alt if plan.altitude_frame == "relative" else plan.heights.nominal_agl_m, 2)
    pitch = PLANE_TAKEOFF_PITCH_DEG if spec.vehicle.type == "plane" else 0.0
    items.append(MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, pitch, 0, 0, 0, round(lat, 8), round(lon, 8),
                             takeoff_alt, tag="takeoff"))
    # copters: ground speed (type 1); ArduPlane reads type 1 as a minimum ground speed and flies
    # its cruise airspeed, so planes get the speed as airspeed (type 0; equal to ground speed in still air)
    speed_type = 0.0 if spec.vehicle.type == "plane" else 1.0
    items.append(MissionItem(mav.DO_CHANGE_SPEED, mav.FRAME_MISSION, speed_type, round(plan.speed.speed_ms, 2), -1.0, tag="speed"))
    if spec.flight.fixed_yaw_deg is not None and spec.vehicle.firmware == "ardupilot":
        items.append(MissionItem(mav.CONDITION_YAW, mav.FRAME_MISSION, float(spec.flight.fixed_yaw_deg), 0.0, 1.0, 0.0, tag="fixed-yaw"))
    for w in wps:
        if w.kind == "lead_in":
            items.append(_wp(plan, w, f"{run_id(plan, w.run)}:lead-in", alt_shift))
        elif w.kind == "line_start":
            items.append(_wp(plan, w, w.station, alt_shift))
            items.extend(_camera_on(plan, f"{run_id(plan, w.run)}:camera-on"))
        elif w.kind == "terrain":
            items.append(_wp(plan, w, w.station, alt_shift))
        elif w.kind == "bend":
            items.append(_wp(plan, w, f"{run_id(plan, w.run)}:bend", alt_shift))
        elif w.kind == "line_end":
            rid = run_id(plan, w.run)
            items.append(_wp(plan, w, f"{rid}:end", alt_shift))
            items.extend(_camera_off(plan, f"{rid}:camera-off"))
        elif w.kind == "transit":
            items.append(_wp(plan, w, "transit", alt_shift))
        else:
            items.append(_wp(plan, w, "detour", alt_shift))
    # the straight way home crosses a zone: the transit waypoints fly round it and a copter
    # lands at the launch point (NAV_LAND) rather than leaving the way home to RTL
    home_detour = bool(wps) and wps[-1].kind == "transit"
    if spec.flight.end == "land" and spec.vehicle.type == "plane":
        items.extend(_landing(plan, lat, lon))
    elif spec.flight.end == "land" or (home_detour and spec.vehicle.type == "copter"):
        items.append(MissionItem(mav.NAV_LAND, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, round(lat, 8), round(lon, 8), 0.0, tag="land"))
    else:
        items.append(MissionItem(mav.NAV_RETURN_TO_LAUNCH, mav.FRAME_MISSION, tag="rtl"))
    return Mission(
        vehicle=spec.vehicle.type,
        firmware=spec.vehicle.firmware,
        home=(round(lat, 8), round(lon, 8), round(ground, 2)),
        items=tuple(items),
        # whole m/s: Mission Planner reads a .plan's cruiseSpeed and hoverSpeed into ints
        # (MissionFile.cs); QGroundControl uses them only for time estimates, the vehicle flies
        # the DO_CHANGE_SPEED above
        cruise_speed=float(max(1, round(spec.vehicle.cruise_speed_ms))),
        hover_speed=float(max(1, round(plan.speed.speed_ms))),
        name=name,
        fence_inclusion=plan.fence_inclusion,
        fence_exclusion=plan.fence_exclusion,
        rally=rally_points(plan, ground),
    )


def rally_points(plan: Plan, home_ground_m: float) -> tuple[tuple[float, float, float], ...]:
    """Every launch site of the plan as a rally point, at the survey's height above that site's
    ground, as an altitude above the home of the mission (ground `home_ground_m`). An autopilot
    returns to the nearest of its rally points and home (ArduPilot with RALLY_INCL_HOME), so a
    sortie launched away from where it was armed, or that must turn back, lands at a planned
    site. None when the plan has no launch site."""
    h = plan.heights.nominal_agl_m
    return tuple((round(s.lat, 8), round(s.lon, 8), round(s.ground_m - home_ground_m + h, 2)) for s in plan.launch_sites)
