"""Turn a plan into the MAVLink items of one flight.

Per photo run: a lead-in waypoint (straight approach), the first station with the camera
switched on (DO_SET_CAM_TRIGG_DIST with 'trigger once now'), terrain waypoints where the
`follow` mode needs them, a line-end waypoint half a photo base past the last station
(ArduPilot does not take the picture that falls exactly on the waypoint, docs/ardupilot
notes), and the camera switched off again so no photos are taken in turns.
"""

from __future__ import annotations

from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem
from aerosurvey.plan.planner import PlanResult, RouteWaypoint


def _frame(plan: PlanResult) -> int:
    return mav.FRAME_GLOBAL_TERRAIN_ALT if plan.altitude_frame == "terrain" else mav.FRAME_GLOBAL_RELATIVE_ALT


def _wp(plan: PlanResult, w: RouteWaypoint, tag: str) -> MissionItem:
    return MissionItem(mav.NAV_WAYPOINT, _frame(plan), 0.0, 0.0, 0.0, 0.0,
                       round(w.lat, 8), round(w.lon, 8), round(w.alt_m, 2), True, tag)


def _camera_on(plan: PlanResult, tag: str) -> list[MissionItem]:
    trig = plan.spec.camera.trigger
    if trig == "distance":
        return [MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, round(plan.base_m, 2), 0.0, 1.0, tag=tag)]
    if trig == "time":
        assert plan.trigger_interval_s is not None
        return [MissionItem(mav.DO_SET_CAM_TRIGG_INTERVAL, mav.FRAME_MISSION, round(plan.trigger_interval_s * 1000.0, 1), -1.0, tag=tag)]
    return []


def _camera_off(plan: PlanResult, tag: str) -> list[MissionItem]:
    trig = plan.spec.camera.trigger
    if trig == "distance":
        return [MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 0.0, 0.0, 0.0, tag=tag)]
    if trig == "time":
        return [MissionItem(mav.DO_SET_CAM_TRIGG_INTERVAL, mav.FRAME_MISSION, 0.0, -1.0, tag=tag)]
    return []


def run_id(plan: PlanResult, run: int) -> str:
    r = plan.route.runs[run]
    return f"P{r.pass_index}-L{r.line + 1:03d}-R{r.part + 1}"


def build_mission(plan: PlanResult, waypoints: list[RouteWaypoint] | None = None, name: str = "mission") -> Mission:
    """The full mission for one flight: takeoff, survey runs in order, then RTL or land."""
    spec = plan.spec
    wps = plan.waypoints if waypoints is None else waypoints
    lon, lat, ground = plan.home
    first_alt = wps[0].alt_m
    items: list[MissionItem] = []
    takeoff_alt = round(first_alt if plan.altitude_frame == "relative" else plan.heights.nominal_agl_m, 2)
    if spec.vehicle.type == "plane":
        items.append(MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, 15.0, 0, 0, 0, round(lat, 8), round(lon, 8), takeoff_alt, tag="takeoff"))
    else:
        items.append(MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, round(lat, 8), round(lon, 8), takeoff_alt, tag="takeoff"))
    items.append(MissionItem(mav.DO_CHANGE_SPEED, mav.FRAME_MISSION, 1.0, round(plan.speed.speed_ms, 2), -1.0, tag="speed"))
    for w in wps:
        if w.kind == "lead_in":
            items.append(_wp(plan, w, f"{run_id(plan, w.run)}:lead-in"))
        elif w.kind == "line_start":
            rid = run_id(plan, w.run)
            items.append(_wp(plan, w, w.station))
            items.extend(_camera_on(plan, f"{rid}:camera-on"))
        elif w.kind == "terrain":
            items.append(_wp(plan, w, w.station))
        elif w.kind == "line_end":
            rid = run_id(plan, w.run)
            items.append(_wp(plan, w, f"{rid}:end"))
            items.extend(_camera_off(plan, f"{rid}:camera-off"))
        else:
            items.append(_wp(plan, w, "detour"))
    if spec.flight.end == "land":
        items.append(MissionItem(mav.NAV_LAND, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, round(lat, 8), round(lon, 8), 0.0, tag="land"))
    else:
        items.append(MissionItem(mav.NAV_RETURN_TO_LAUNCH, mav.FRAME_MISSION, tag="rtl"))
    return Mission(
        vehicle=spec.vehicle.type,
        firmware=spec.vehicle.firmware,
        home=(round(lat, 8), round(lon, 8), round(ground, 2)),
        items=tuple(items),
        cruise_speed=round(spec.vehicle.cruise_speed_ms, 2),
        hover_speed=round(plan.speed.speed_ms, 2),
        name=name,
    )
