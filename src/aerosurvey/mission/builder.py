"""The MAVLink emitter: a flight program (mission/program.py) as the mission items of one flight, per autopilot.

Per photo run: a lead-in waypoint (straight approach), the first station with the camera
switched on (DO_SET_CAM_TRIGG_DIST with 'trigger once now'), terrain and bend waypoints where
the route has them, a line-end waypoint half a photo base past the last station (ArduPilot
does not take the picture that falls exactly on the waypoint, as seen in its SITL), and the
camera switched off again so no photos are taken in turns.

The DO commands after a waypoint run when the vehicle reaches it (ArduPilot's AP_Mission
starts them with the next navigation item), so the camera switches on at the first station
with a picture at once, and off at the line end. Between, ArduPilot checks the distance at
50 Hz and takes a picture at the first check that lies the trigger distance or more from the
last one (AP_Camera_Backend::update): pictures land a whole number of check steps apart,
the spacing the stations are laid at (plan/photogrammetry.py, distance_trigger).

The program's other actions (MAVLink common.xml for the parameters):

- gimbal: ArduPilot MAV_CMD_DO_MOUNT_CONTROL (param1 pitch, param2 roll, param3 yaw relative
  to the vehicle, param7 MAV_MOUNT_MODE_MAVLINK_TARGETING); PX4
  MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW (param1 pitch, param2 yaw, param3/4 rates NaN (not
  set), param5 flags ROLL_LOCK|PITCH_LOCK: pitch against the horizon, yaw relative to the
  vehicle; param7 0: every gimbal).
- gimbal held on an earth-frame bearing (`Gimbal.earth`, along a ring's side):
  MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW with GIMBAL_MANAGER_FLAGS_YAW_LOCK too, param2 the true
  bearing; ArduPilot (4.3 on) runs it in a mission and stores pitch and yaw in whole degrees
  (pitch int8, yaw int16, rates int8: 0, not set), so they are given rounded.
- hover and shoot: NAV_WAYPOINT with param1 = the hold time, then one photo: ArduPilot
  MAV_CMD_DO_DIGICAM_CONTROL with param5 (shoot) 1 (every ArduPilot version takes it in a
  mission; IMAGE_START_CAPTURE only from 4.4); PX4 MAV_CMD_IMAGE_START_CAPTURE (param1 0: all
  cameras, param2 0 s, param3 1 image, param4 the capture's sequence number from 1).
  ArduPilot starts the DO command when the hold ends, as the vehicle turns to the next
  waypoint; PX4 runs it as the next item after the hold.

PX4 by distance: the program's `CameraRestart` at every second station of a run (a
waypoint there, then DO_SET_CAM_TRIGG_DIST with the distance and 'trigger once now', as at
the line start): PX4 checks its distance every 50 ms, and the restart keeps its photos on
their stations along lines of any length (mission/program.py).

Dialects: ArduCopter (takeoff, optional CONDITION_YAW for one fixed heading, RTL or LAND
at the launch point), ArduPlane (takeoff with 15° pitch, then RTL, or DO_LAND_START, an
approach waypoint and NAV_LAND flown into the wind), PX4 (the same items except
CONDITION_YAW: a fixed heading goes into each waypoint's param4, as PX4 reads it; and no leg
between two places longer than the program's `max_leg_m`, `vehicle.max_leg_m`: PX4 v1.13 and
earlier refuse such a mission at arming (mission/legs.py), so a longer leg gets waypoints on
it, "split", in equal pieces. They go just before the place the leg leads to, after the
actions of the place it leaves: on a photo line the camera keeps triggering by distance
through them, a transit keeps its height, the way to a copter's landing its height until the
landing point, and a plane's approach leg to NAV_LAND is never cut; spec.py refuses a PX4
plane landing whose approach is longer than the limit).
"""

from __future__ import annotations

import math

from aerosurvey.mission import mavlink_ids as mav
from aerosurvey.mission.items import Mission, MissionItem
from aerosurvey.mission.legs import leg_cuts
from aerosurvey.mission.program import (
    CameraRestart,
    CameraStart,
    CameraStop,
    FlightProgram,
    Gimbal,
    HoverShoot,
    Roi,
    RoiEnd,
    Waypoint,
    flight_program,
    run_id,
)
from aerosurvey.plan.model import Plan

__all__ = ["PLANE_LINE_ACCEPTANCE_M", "build_mission", "mavlink_mission", "run_id"]

#: ArduPlane counts a waypoint as reached up to its turn distance early (WP_RADIUS, 90 m by
#: default): the camera would switch on and off that far from the line's ends. A waypoint's
#: own acceptance radius (param2) overrides it, so line waypoints of planes carry a small one.
PLANE_LINE_ACCEPTANCE_M = 2.0
_PLANE_LINE_KINDS = ("line_start", "terrain", "bend", "line_end")
#: DO_GIMBAL_MANAGER_PITCHYAW flags: roll and pitch against the horizon, yaw relative to the vehicle
GIMBAL_FLAGS = mav.GIMBAL_MANAGER_FLAGS_ROLL_LOCK | mav.GIMBAL_MANAGER_FLAGS_PITCH_LOCK


def build_mission(plan: Plan, sortie: int | None = None, name: str | None = None) -> Mission:
    """The MAVLink mission of the whole plan (or of sortie `sortie`, 0-based)."""
    return mavlink_mission(flight_program(plan, sortie, name))


def _frame(p: FlightProgram) -> int:
    return mav.FRAME_GLOBAL_TERRAIN_ALT if p.altitude_frame == "terrain" else mav.FRAME_GLOBAL_RELATIVE_ALT


def _wp(p: FlightProgram, w: Waypoint, hold_s: float) -> MissionItem:
    accept = PLANE_LINE_ACCEPTANCE_M if p.vehicle == "plane" and w.kind in _PLANE_LINE_KINDS else 0.0
    # PX4 turns to a waypoint's finite yaw (0 = north: seen in its SITL, the nose held north on every line);
    # NaN leaves the heading to its yaw mode, the nose along the track (MPC_YAW_MODE 0). ArduPilot ignores it.
    yaw = p.fixed_yaw_deg if p.fixed_yaw_deg is not None and p.firmware == "px4" else math.nan if p.firmware == "px4" else 0.0
    return MissionItem(mav.NAV_WAYPOINT, _frame(p), hold_s, accept, 0.0, yaw, w.lat, w.lon, w.alt_m, True, w.tag)


def _gimbal(p: FlightProgram, g: Gimbal, tag: str) -> MissionItem:
    if g.earth:
        # ArduPilot keeps the angles in whole degrees (AP_Mission: pitch int8, yaw int16, the rates int8): given so here
        whole = p.firmware == "ardupilot"
        pitch, yaw = (float(round(g.pitch_deg)), float(round(g.bearing_deg) % 360)) if whole else (g.pitch_deg, round(g.bearing_deg, 2))
        rate = 0.0 if whole else math.nan
        return MissionItem(mav.DO_GIMBAL_MANAGER_PITCHYAW, mav.FRAME_MISSION, pitch, yaw, rate, rate,
                           float(GIMBAL_FLAGS | mav.GIMBAL_MANAGER_FLAGS_YAW_LOCK), 0.0, 0.0, tag=tag)
    if p.firmware == "px4":
        return MissionItem(mav.DO_GIMBAL_MANAGER_PITCHYAW, mav.FRAME_MISSION, g.pitch_deg, round(g.yaw_deg, 2), math.nan, math.nan,
                           float(GIMBAL_FLAGS), 0.0, 0.0, tag=tag)
    return MissionItem(mav.DO_MOUNT_CONTROL, mav.FRAME_MISSION, g.pitch_deg, 0.0, round(g.yaw_deg, 2), 0.0, 0.0, 0.0,
                       float(mav.MOUNT_MODE_MAVLINK_TARGETING), tag=tag)


def _shoot(p: FlightProgram, sequence: int, tag: str) -> MissionItem:
    if p.firmware == "px4":
        return MissionItem(mav.IMAGE_START_CAPTURE, mav.FRAME_MISSION, 0.0, 0.0, 1.0, float(sequence), 0.0, 0.0, math.nan, tag=tag)
    return MissionItem(mav.DO_DIGICAM_CONTROL, mav.FRAME_MISSION, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, tag=tag)


def _camera(a: CameraStart | CameraStop | CameraRestart, tag: str) -> MissionItem:
    if isinstance(a, CameraRestart):
        return MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, a.distance_m, 0.0, 1.0, tag=tag)
    if isinstance(a, CameraStart):
        if a.distance_m is not None:
            return MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, a.distance_m, 0.0, 1.0, tag=tag)
        assert a.interval_s is not None
        return MissionItem(mav.DO_SET_CAM_TRIGG_INTERVAL, mav.FRAME_MISSION, round(a.interval_s * 1000.0, 1), -1.0, tag=tag)
    if a.distance:
        return MissionItem(mav.DO_SET_CAM_TRIGG_DIST, mav.FRAME_MISSION, 0.0, 0.0, 0.0, tag=tag)
    return MissionItem(mav.DO_SET_CAM_TRIGG_INTERVAL, mav.FRAME_MISSION, 0.0, -1.0, tag=tag)


def _end(p: FlightProgram) -> list[MissionItem]:
    lat, lon, _ = p.home
    if p.approach is not None:  # DO_LAND_START, the approach waypoint downwind, NAV_LAND into the wind
        a = p.approach
        return [
            # a place on the way to land: ArduPilot takes it in a global frame, PX4 only in MAV_FRAME_MISSION
            # (anything else it answers MAV_MISSION_UNSUPPORTED_FRAME; seen against PX4's mission rules)
            MissionItem(mav.DO_LAND_START, mav.FRAME_MISSION if p.firmware == "px4" else mav.FRAME_GLOBAL_RELATIVE_ALT,
                        0, 0, 0, 0, a.lat, a.lon, 0.0, tag="land-start"),
            MissionItem(mav.NAV_WAYPOINT, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, a.lat, a.lon, a.alt_m, tag="approach"),
            MissionItem(mav.NAV_LAND, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, lat, lon, 0.0, tag="land"),
        ]
    if p.end == "land":
        return [MissionItem(mav.NAV_LAND, mav.FRAME_GLOBAL_RELATIVE_ALT, 0, 0, 0, 0, lat, lon, 0.0, tag="land")]
    return [MissionItem(mav.NAV_RETURN_TO_LAUNCH, mav.FRAME_MISSION, tag="rtl")]


def _cuts(p: FlightProgram, last: MissionItem, to: MissionItem, w: Waypoint | None) -> list[MissionItem]:
    """Waypoints that cut the leg from the place `last` to the place `to` (the program's waypoint
    `w`, or None for the end) into pieces within `p.max_leg_m`; none without a limit. On the way
    to a landing the height stays, else it goes evenly from one end's to the other's."""
    if p.max_leg_m is None:
        return []
    keep = to.command == mav.NAV_LAND
    tag = "transit" if w is None else f"{w.run_id}:split" if w.run_id else w.tag
    run, run_id, heading = (-1, "", 0.0) if w is None else (w.run, w.run_id, w.heading_deg)
    return [_wp(p, Waypoint(round(lat, 8), round(lon, 8), round(last.z if keep else last.z + f * (to.z - last.z), 2),
                            "split", run, tag, run_id, heading), 0.0)
            for lat, lon, f in leg_cuts(last.x, last.y, to.x, to.y, p.max_leg_m)]


def mavlink_mission(p: FlightProgram) -> Mission:
    """The mission for one flight: takeoff, speed, the program's waypoints and actions in order, then RTL or land."""
    lat, lon, ground = p.home
    last = MissionItem(mav.NAV_TAKEOFF, mav.FRAME_GLOBAL_RELATIVE_ALT, p.takeoff_pitch_deg, 0, 0, 0, lat, lon,
                       p.takeoff_alt_m, tag="takeoff")
    items = [last]
    # copters: ground speed (type 1); ArduPlane reads type 1 as a minimum ground speed and flies
    # its cruise airspeed, so planes get the speed as airspeed (type 0; equal to ground speed in still air)
    speed_type = 0.0 if p.vehicle == "plane" else 1.0
    items.append(MissionItem(mav.DO_CHANGE_SPEED, mav.FRAME_MISSION, speed_type, round(p.speed_ms, 2), -1.0, tag="speed"))
    if p.fixed_yaw_deg is not None and p.firmware == "ardupilot":
        items.append(MissionItem(mav.CONDITION_YAW, mav.FRAME_MISSION, p.fixed_yaw_deg, 0.0, 1.0, 0.0, tag="fixed-yaw"))
    shots = 0
    roi: tuple[float, float, float] | None = None  # the region of interest the autopilot holds
    for w in p.waypoints:
        hover = next((a for a in w.actions if isinstance(a, HoverShoot)), None)
        wp = _wp(p, w, hover.hold_s if hover is not None else 0.0)
        items += _cuts(p, last, wp, w)
        items.append(wp)
        last = wp
        rid = w.run_id
        for a in w.actions:
            if isinstance(a, Gimbal):
                items.append(_gimbal(p, a, f"{rid}:gimbal"))
                roi = None  # the mount leaves the region of interest for the angles
            elif isinstance(a, Roi):
                # given once, ArduPilot and PX4 hold the mount (and a copter's nose) on it until DO_SET_ROI_NONE
                if (a.lat, a.lon, a.alt_m) != roi:
                    items.append(MissionItem(mav.DO_SET_ROI_LOCATION, _frame(p), 0.0, 0.0, 0.0, 0.0, a.lat, a.lon, a.alt_m,
                                             tag=f"{rid}:roi"))
                    roi = (a.lat, a.lon, a.alt_m)
            elif isinstance(a, RoiEnd):
                items.append(MissionItem(mav.DO_SET_ROI_NONE, mav.FRAME_MISSION, tag=f"{rid}:roi-none"))
                roi = None
            elif isinstance(a, HoverShoot):
                shots += 1
                items.append(_shoot(p, shots, f"{w.tag}:photo"))
            else:
                what = "restart" if isinstance(a, CameraRestart) else "on" if isinstance(a, CameraStart) else "off"
                items.append(_camera(a, f"{rid}:camera-{what}"))
    end = _end(p)
    # the leg to the end's first place (none after RTL; a plane's approach leg to NAV_LAND is not cut)
    first = next((it for it in end if it.has_position), None)
    if first is not None:
        items += _cuts(p, last, first, None)
    items.extend(end)
    return Mission(
        vehicle=p.vehicle,
        firmware=p.firmware,
        home=p.home,
        items=tuple(items),
        # whole m/s: Mission Planner reads a .plan's cruiseSpeed and hoverSpeed into ints
        # (MissionFile.cs); QGroundControl uses them only for time estimates, the vehicle flies
        # the DO_CHANGE_SPEED above
        cruise_speed=float(max(1, round(p.cruise_speed_ms))),
        hover_speed=float(max(1, round(p.speed_ms))),
        name=p.name,
        fence_inclusion=p.fence_inclusion,
        fence_exclusion=p.fence_exclusion,
        rally=p.rally,
    )
