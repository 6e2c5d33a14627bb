"""The flight program: what one flight does, in order, in no file format's terms.

`flight_program(plan, sortie)` builds it once from the plan, for one sortie (or for the whole
mission), and every emitter reads it: the MAVLink items (mission/builder.py, for ArduPilot and
PX4), DJI's WPML waylines (mission/formats/wpml.py). The final gate (mission/gate.py) checks
its legs against the zones before any emitter runs.

A program is: the home (launch point), the take-off, the survey speed and the yaw mode, the
waypoints in flight order with their altitude frame ("relative": metres above the launch
point; "terrain": metres above the terrain under the waypoint) and the actions each one
starts when it is reached, then the end (return to launch, or land at the launch point, a
plane after its approach waypoint).

Every bearing in a program is a true bearing (clockwise from the meridian), as autopilots, DJI
and MAVLink take them: the plan's grid bearings are turned by the meridian convergence at
their place (`Planar.true_bearing`) when the program is built, and nowhere else.

Actions, done in their order when the vehicle reaches their waypoint:

- `Gimbal`: the camera's pitch (gimbal convention, −90 looks straight down) and its yaw
  relative to the vehicle's nose (and the true bearing it looks to), at the first waypoint
  of a run whose pitch (or, tilted, whose yaw) differs from the run before, and at the first
  run of every flight, nadir or not: a flight (a sortie, a resumed flight, a re-fly) may take
  off with the mount where another flight left it (an oblique sortie's −45° and yaw offset).
- `Roi` / `RoiEnd`: a run whose camera looks at a point (`Aim.point`) has it at every waypoint
  from its first to its line end, instead of a `Gimbal` action (MAVLink: DO_SET_ROI_LOCATION
  once, DO_SET_ROI_NONE at the line end; DJI: the towardPOI heading and the pitch towards the
  point at each waypoint); the point's altitude is where the run's first station sees it at
  the aim's pitch (`altitudes.look_at_height`). After it the mount's state is not known: the
  next run sets its gimbal, nadir or not.
- A run whose camera looks at an outline's nearest point (`Aim.outline`, a ring round a
  structure) gets, at each waypoint from its lead-in to its line end where the look of the leg
  to the next waypoint changes, that leg's look: where both ends of the leg see the same point
  of the outline (a corner, the leg a chord of the ring's round join) a `Roi` at that corner, at
  the height that gives the aim's pitch from the leg's end (on the ring), at every such waypoint; else (along a side) a `Gimbal` held
  on the side's bearing in the earth frame (`Gimbal.earth`), the look from the leg's middle. At a
  side's end both looks are the same bearing, so the camera turns continuously round the ring,
  whatever the nose does (ArduCopter's turns smoothly round the ring, the chords' by steps). A
  `Gimbal` on the line end's look (earth frame) when a `Roi` holds the mount there, or, when another
  such run follows, on that run's first look (its lead-in's), so the camera turns on the way there.
  The lead-in (no photo on it) holds the first station's look as an earth-frame bearing: the camera
  is there when the first photo is taken (a region of interest from the lead-in swept the camera
  round a corner and left it 1.7° behind at the first photo in SITL; a lead-in a zone cut to
  nothing left it 87° off).
- `CameraStart` / `CameraStop`: photos every `distance_m` metres or every `interval_s`
  seconds from a run's first station to its line end (camera.trigger "distance" or "time";
  the camera's own intervalometer, "camera", has none).
- `HoverShoot`: camera.trigger "hover": stop at the station, hold `hold_s` seconds
  (camera.settle_s), take one photo. Every station of a run is then a waypoint. A run that
  shoots several aims at each place (`Run.looks`: a station row for each) has a waypoint for
  each row at the place, and after each photo a `Gimbal` to the next row's aim: the autopilot
  starts it as the hold ends and the photo is taken, and the next waypoint's hold
  (camera.settle_s; at the same place `flight_time.look_hold_s`: the settling and
  `GIMBAL_SLEW_S`, at least the camera's cycle) covers the turn.
- `CameraRestart` (PX4, camera.trigger "distance"): the distance trigger started again at a
  station, with a photo at once, at every `PX4_RESTART_EVERY`-th station of a run (those
  stations are then waypoints). PX4's camera_trigger (src/drivers/camera_trigger,
  v1.16) checks the distance every 50 ms, ArduPilot at 50 Hz: the stations are laid for
  ArduPilot's check steps, and PX4's coarser ones give photos up to a step (0.5 m at 10 m/s)
  farther apart than commanded, so its photos would fall farther behind their stations with
  every photo of a long line (0.18 m a photo in SITL: the last of a 60-photo line not taken).
  Started again at a station, the trigger counts from that photo: the error cannot add up.
  Between two restarts PX4 triggers by distance at `px4_trigger_distance`, a little more than
  the photo base, so its own photo never comes before the restart's.

Waypoint kinds are the route's (lead_in, line_start, terrain, bend, line_end, transit,
detour) and "station" for a hover (or PX4 restart) station between them. A "bend" is a corner of a strip:
the camera stays on through it, as through a "terrain" waypoint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from aerosurvey import ids
from aerosurvey.plan.altitudes import look_at_height, station_pitches
from aerosurvey.plan.flight_time import look_hold_s
from aerosurvey.plan.landing import PLANE_TAKEOFF_PITCH_DEG
from aerosurvey.plan.model import Plan, RouteWaypoint
from aerosurvey.plan.passes import NADIR_PITCH_DEG, Aim
from aerosurvey.plan.photogrammetry import ardupilot_distance_m

#: waypoint kinds on a photo run between its first station and its line end (the camera is on)
ON_LINE = ("line_start", "terrain", "bend", "station", "line_end")
#: waypoint kinds that can sit on a station (and shoot there)
AT_STATION = ("line_start", "terrain", "bend", "station")
#: two places of an outline closer than this (planning metres) are one: its corner
OUTLINE_CORNER_M = 1e-3
#: PX4's camera_trigger checks its distance every 50 ms (Run's poll_interval_usec; v1.16)
PX4_TRIGGER_CHECK_S = 0.05
#: PX4 starts its distance trigger again at every this-many-th station of a run (measured in SITL: sitl/README.md)
PX4_RESTART_EVERY = 2


@dataclass(frozen=True)
class Gimbal:
    pitch_deg: float  # gimbal convention: −90 straight down, 0 level
    yaw_deg: float  # relative to the vehicle's nose, positive to the right, −180..180
    bearing_deg: float  # the true bearing the camera looks to (0..360)
    earth: bool = False  # the camera held on `bearing_deg` however the nose turns (else at `yaw_deg` from it)


@dataclass(frozen=True)
class Roi:
    """The camera on a point (a region of interest), at every waypoint of a run that looks at it,
    until `RoiEnd`: an autopilot given the point once turns the mount (or the vehicle) to it and
    pitches the camera towards it from wherever it flies; `pitch_deg` is that pitch from this
    waypoint (for a program that sets the gimbal at each waypoint instead)."""

    lat: float
    lon: float
    alt_m: float  # in the program's altitude frame
    pitch_deg: float  # towards the point from this waypoint (gimbal convention)


@dataclass(frozen=True)
class RoiEnd:
    """The region of interest released: the mount goes back to the last gimbal setting's mode."""


@dataclass(frozen=True)
class CameraStart:
    distance_m: float | None  # one of the two is set
    interval_s: float | None


@dataclass(frozen=True)
class CameraStop:
    distance: bool  # True: the distance trigger is stopped; False: the time trigger


@dataclass(frozen=True)
class HoverShoot:
    hold_s: float  # held still before the one photo


@dataclass(frozen=True)
class CameraRestart:
    distance_m: float  # PX4: the distance trigger started again here, a photo at once


Action = Gimbal | Roi | RoiEnd | CameraStart | CameraStop | HoverShoot | CameraRestart


@dataclass(frozen=True)
class Waypoint:
    lat: float  # degrees, to 1e-8 (about a millimetre)
    lon: float
    alt_m: float  # in the program's altitude frame, to a centimetre
    kind: str
    run: int  # index into plan.route.runs; -1 for transit
    tag: str  # the station id, or the run's id and what the waypoint is ("P1-L002-R1:lead-in"), "transit", "detour"
    run_id: str  # "P1-L002-R1"; "" off the runs
    heading_deg: float  # the direction of flight on its run, a true bearing (0 off the runs)
    actions: tuple[Action, ...] = ()


@dataclass(frozen=True)
class Approach:
    """A plane's landing approach: a waypoint downwind of the launch point, landing into the wind."""

    lat: float
    lon: float
    alt_m: float  # above the launch point


@dataclass(frozen=True)
class FlightProgram:
    name: str
    vehicle: str  # "copter" or "plane"
    firmware: str  # "ardupilot" or "px4" (the MAVLink dialect)
    camera_id: str
    home: tuple[float, float, float]  # latitude, longitude, ground AMSL of the launch point
    altitude_frame: str  # "relative" (above the launch point) or "terrain" (above the terrain under each waypoint)
    takeoff_alt_m: float  # above the launch point
    takeoff_pitch_deg: float  # a plane's climb pitch; 0 for a copter
    speed_ms: float  # the survey speed (ground speed; a plane's airspeed in still air)
    cruise_speed_ms: float  # the vehicle's cruise speed, for transits
    fixed_yaw_deg: float | None  # None: the nose along the track; else one true heading for the whole flight
    waypoints: tuple[Waypoint, ...]
    end: str  # "rtl" or "land" (at the launch point)
    approach: Approach | None  # a plane landing: its approach waypoint
    fence_inclusion: tuple[tuple[tuple[float, float], ...], ...]
    fence_exclusion: tuple[tuple[tuple[float, float], ...], ...]
    rally: tuple[tuple[float, float, float], ...]  # latitude, longitude, altitude above the launch point
    max_leg_m: float | None = None  # PX4: the longest leg between two places (vehicle.max_leg_m); None: no limit


def run_id(plan: Plan, run: int) -> str:
    r = plan.route.runs[run]
    return ids.run_id(r.pass_index, r.line, r.part)


def _wrap180(deg: float) -> float:
    return (deg + 180.0) % 360.0 - 180.0


def flight_program(plan: Plan, sortie: int | None = None, name: str | None = None) -> FlightProgram:
    """The program of sortie `sortie` (0-based index into plan.sorties) from its launch site, or
    of the whole mission from the plan's home when None."""
    vehicle = plan.vehicle.type
    if sortie is None:
        wps: tuple[RouteWaypoint, ...] = plan.waypoints
        lon, lat, ground = plan.launch.home
        first_station, last_station = 0, len(plan.stations.ids) - 1
    else:
        s, wps = plan.sorties[sortie]
        site = plan.launch.sites[s.launch]
        lon, lat, ground = site.lon, site.lat, site.ground_m
        first_station, last_station = s.first, s.last
    relative = plan.altitudes.frame == "relative"
    # relative altitudes are above the plan's home; a sortie's launch site is higher or lower
    shift = plan.launch.home[2] - ground if relative else 0.0
    waypoints = _waypoints(plan, wps, shift, first_station, last_station)
    takeoff = waypoints[0].alt_m if relative and waypoints else round(plan.sensor.heights.nominal_agl_m, 2)
    landing = plan.launch.landing
    approach = None
    if landing.approach_m is not None:
        alon, alat = landing.approach_lonlat(lon, lat)
        approach = Approach(round(alat, 8), round(alon, 8), round(landing.approach_alt_m, 2))
    # the straight way home crosses a zone: the transit waypoints fly round it and a copter
    # lands at the launch point rather than leaving the way home to RTL
    home_detour = bool(wps) and wps[-1].kind == "transit"
    land = landing.end == "land" or (home_detour and vehicle == "copter")
    h = plan.sensor.heights.nominal_agl_m
    rally = tuple((round(st.lat, 8), round(st.lon, 8), round(st.ground_m - ground + h, 2))
                  for st in (*plan.launch.sites, *plan.launch.rally))
    if vehicle == "plane" and rally and min(_metres((r[0], r[1]), (lat, lon)) for r in rally) > 1.0:
        # ArduPlane's RTL goes to the nearest rally point, never home when there is one: this flight's launch
        # point (on the area's edge, no site) is one too, or the RTL that follows the way home would fly on to
        # the nearest site, wherever the zones lie
        rally = ((round(lat, 8), round(lon, 8), round(h, 2)), *rally)
    if not land and waypoints:
        # RTL goes to the nearest rally point (and home, for a copter) from where it starts: when that is
        # another launch site, the flight first comes home (its way home is clear of the zones: the
        # route's transit), so that the nearest is this one
        last = waypoints[-1]
        to = rtl_target(vehicle, (round(lat, 8), round(lon, 8)), [(r[0], r[1]) for r in rally], (last.lat, last.lon))
        if _metres(to, (lat, lon)) > 1.0:
            waypoints = (*waypoints, Waypoint(round(lat, 8), round(lon, 8), last.alt_m, "transit", -1, "transit", "", 0.0))
    return FlightProgram(
        name=name or plan.name,
        vehicle=vehicle,
        firmware=plan.vehicle.firmware,
        camera_id=plan.camera.camera.id,
        home=(round(lat, 8), round(lon, 8), round(ground, 2)),
        altitude_frame=plan.altitudes.frame,
        takeoff_alt_m=takeoff,
        takeoff_pitch_deg=PLANE_TAKEOFF_PITCH_DEG if vehicle == "plane" else 0.0,
        speed_ms=plan.sensor.speed.speed_ms,
        cruise_speed_ms=plan.vehicle.cruise_speed_ms,
        fixed_yaw_deg=plan.launch.fixed_yaw_deg,
        waypoints=waypoints,
        end="land" if land else "rtl",
        approach=approach,
        fence_inclusion=plan.launch.fence.inclusion,
        fence_exclusion=plan.launch.fence.exclusion,
        # every launch site and the spec's rally points, at the survey's height above their ground, as an altitude above
        # this launch point
        rally=rally,
        max_leg_m=plan.vehicle.max_leg_m,
    )


def rtl_target(vehicle: str, home: tuple[float, float], rally: list[tuple[float, float]],
               start: tuple[float, float]) -> tuple[float, float]:
    """(lat, lon) where RTL from `start` flies to: the nearest rally point, home among them for a
    copter (ArduCopter's RALLY_INCL_HOME = 1; ArduPlane's 0: a rally point whenever there is one)."""
    targets = rally if rally and vehicle == "plane" else [home, *rally]
    return min(targets, key=lambda t: _metres(t, start))


def _metres(a: tuple[float, float], b: tuple[float, float]) -> float:
    """ArduPilot's distance between two (lat, lon) places: it picks the nearest rally point by it."""
    return float(ardupilot_distance_m(a[1], a[0], b[1], b[0]))


def _tag(plan: Plan, w: RouteWaypoint) -> str:
    if w.kind in ("transit", "detour"):
        return w.kind
    if w.station and w.kind != "line_end":
        return w.station
    what = {"lead_in": "lead-in", "line_end": "end"}.get(w.kind, w.kind)
    return f"{run_id(plan, w.run)}:{what}"


def px4_trigger_distance(base_m: float, speed_ms: float) -> float:
    """The distance PX4's trigger is commanded between two restarts (`CameraRestart`): the photo
    base and two of its check steps spread over the photos between restarts. Its photos then
    come at least that far apart, and the restart at the next station (reached within PX4's
    reach-and-check delays, under two check steps) comes before PX4's own photo there."""
    return round(base_m + 2.0 * speed_ms * PX4_TRIGGER_CHECK_S / PX4_RESTART_EVERY, 2)


def _waypoints(plan: Plan, wps: tuple[RouteWaypoint, ...], shift: float, first: int, last: int) -> tuple[Waypoint, ...]:
    """The route's waypoints with their actions (hover: every station of the sortie's runs too;
    PX4 by distance: every `PX4_RESTART_EVERY`-th)."""
    st = plan.stations
    hover = plan.camera.trigger == "hover"
    restart = plan.vehicle.firmware == "px4" and plan.camera.trigger == "distance"
    every = 1 if hover else PX4_RESTART_EVERY if restart else 0
    at: set[str] = set()
    if every:
        wps, at = _with_stations(plan, wps, first, last, every)
    start, stop = _camera_actions(plan)
    yaw_fixed = plan.launch.fixed_yaw_deg
    # the mount's state at take-off is not known: the first run of every flight sets it
    gimbal: Gimbal | None = None
    held: Gimbal | Roi | None = None  # an outline's look held on the run (`_outline_look`)
    first_of_run = {}
    for i, w in enumerate(wps):
        if w.run >= 0 and w.kind in ("lead_in", "line_start", "station") and w.run not in first_of_run:
            first_of_run[w.run] = i
    station_of_run = {int(r): int(i) for r, i in zip(*np.unique(st.run, return_index=True))}
    # the run's direction of flight and each run's camera look, as true bearings at the run's first station
    k_of_run = np.array(list(station_of_run.values()), np.intp)
    planar = plan.site.planar
    true_heading = planar.true_bearing(st.heading_deg[k_of_run], st.x[k_of_run], st.y[k_of_run])
    true_look = planar.true_bearing(st.camera_yaw_deg[k_of_run], st.x[k_of_run], st.y[k_of_run])
    heading_of_run = {r: float(true_heading[j]) for j, r in enumerate(station_of_run)}
    look_of_run = {r: float(true_look[j]) for j, r in enumerate(station_of_run)}
    row_of = {sid: n for n, sid in enumerate(st.ids)} if hover else {}
    out = []
    for i, w in enumerate(wps):
        actions: list[Action] = []
        heading = heading_of_run.get(w.run, 0.0) if w.run >= 0 else 0.0
        aim = plan.route.runs[w.run].aim if w.run >= 0 else None
        if aim is not None and aim.outline is not None and w.run in station_of_run \
                and first_of_run.get(w.run, len(wps)) <= i < len(wps) - 1 and w.kind in ("lead_in", *ON_LINE):
            after = min((j for j in first_of_run.values() if j > i), default=len(wps))  # the next run's first waypoint
            nxt = wps[after] if after < len(wps) - 1 else None
            if w.kind != "line_end":
                want_look: Gimbal | Roi | None = _outline_look(plan, aim, w, wps[i + 1], shift)
            elif nxt is not None and nxt.kind == "lead_in" and (next_aim := plan.route.runs[nxt.run].aim).outline is not None:
                # the camera turned to the next run's first look on the way there (its lead-in may be cut short by a
                # zone: a piece of a ring the zones cut took its first photo as the gimbal was told to turn 87°)
                want_look = _outline_look(plan, next_aim, nxt, wps[after + 1], shift)
            elif isinstance(held, Roi):
                # the mount off the region of interest onto a known bearing (the line end's look): no DO_SET_ROI_NONE,
                # whose stored form ArduPilot changes
                came = np.degrees(np.arctan2(w.x - wps[i - 1].x, w.y - wps[i - 1].y))
                want_look = _outline_bearing(plan, aim, np.array([[w.x, w.y]]), float(came))
            else:
                want_look = None
            # a region of interest at every waypoint that has one, as for a point (one MAVLink item for them all)
            if want_look is not None and (isinstance(want_look, Roi) or want_look != held):
                actions.append(want_look)
                held = want_look
            gimbal = None  # the earth-frame yaw or the region of interest leaves the mount so
        elif aim is not None and aim.point is not None and w.run in station_of_run and i >= first_of_run.get(w.run, len(wps)) \
                and w.kind in ("lead_in", *ON_LINE):
            k = station_of_run[w.run]
            z = look_at_height(aim, np.array([st.x[k], st.y[k]]), float(st.alt_rel_m[k]))
            pitch = float(station_pitches(aim, np.array([[w.x, w.y]]), np.array([w.alt_m]), z)[0])
            lon_lat = planar.lonlat(np.array([aim.point[0]]), np.array([aim.point[1]]))
            actions.append(Roi(round(float(lon_lat[1][0]), 8), round(float(lon_lat[0][0]), 8), round(z + shift, 2), round(pitch, 4)))
            gimbal = None  # where the region of interest leaves the mount
        elif first_of_run.get(w.run) == i and w.run in station_of_run:
            k = station_of_run[w.run]
            pitch, bearing = float(st.pitch_deg[k]), look_of_run[w.run]
            nose = heading if yaw_fixed is None else float(yaw_fixed)
            want = Gimbal(pitch, round(_wrap180(bearing - nose), 6), bearing)
            # a yaw alone matters only to a tilted camera
            if gimbal is None or want.pitch_deg != gimbal.pitch_deg or (pitch != NADIR_PITCH_DEG
                                                                         and want.yaw_deg != gimbal.yaw_deg):
                actions.append(want)
            gimbal = want
        if hover and w.station in at and w.kind in AT_STATION:
            n = row_of[w.station]
            aims = plan.route.runs[w.run].aims
            look = (n - station_of_run[w.run]) % len(aims)
            # a further aim at the place: its waypoint's hold covers the gimbal's turn and the camera's cycle
            actions.append(HoverShoot(look_hold_s(plan.camera.settle_s, plan.camera.min_cycle_s) if look
                                      else plan.camera.settle_s))
            if len(aims) > 1 and n + 1 < len(st.ids) and st.run[n + 1] == w.run:
                # the next aim set as this photo is taken (ArduPilot starts the DO items after a waypoint when
                # its hold ends): the next waypoint, at the same place or the next, holds while the gimbal turns
                nose = heading if yaw_fixed is None else float(yaw_fixed)
                bearing = float(planar.true_bearing(st.camera_yaw_deg[n + 1], st.x[n + 1], st.y[n + 1]))
                gimbal = Gimbal(float(st.pitch_deg[n + 1]), round(_wrap180(bearing - nose), 6), bearing)
                actions.append(gimbal)
        elif w.kind == "line_start" and start is not None:
            actions.append(start)
        elif restart and w.station in at and w.kind in AT_STATION and isinstance(start, CameraStart):
            assert start.distance_m is not None
            actions.append(CameraRestart(start.distance_m))
        elif w.kind == "line_end" and stop is not None:
            actions.append(stop)
        if w.kind == "line_end" and aim is not None and aim.point is not None:
            actions.append(RoiEnd())
        if w.kind == "line_end":
            held = None
        alt = w.alt_m + shift
        out.append(Waypoint(round(w.lat, 8), round(w.lon, 8), round(alt, 2), w.kind, w.run, _tag(plan, w),
                            run_id(plan, w.run) if w.run >= 0 else "", heading, tuple(actions)))
    return tuple(out)


def _outline_look(plan: Plan, aim: Aim, w: RouteWaypoint, to: RouteWaypoint, shift: float) -> Gimbal | Roi:
    """The look of an outline's aim on the leg from `w` to `to`, from the leg's middle: a region
    of interest at the outline's corner nearest to it, else the earth-frame bearing square to the
    side it runs along; on a lead-in (no photo on it), the look from its end as an earth-frame
    bearing. See the module's docstring."""
    ends = np.array([[w.x, w.y], [to.x, to.y]])
    at = ends[1:] if w.kind == "lead_in" else ends.mean(axis=0, keepdims=True)
    near = aim.nearest(at)[0]
    planar = plan.site.planar
    assert aim.outline is not None
    if w.kind != "lead_in" and float(np.min(np.hypot(*(np.asarray(aim.outline) - near).T))) < OUTLINE_CORNER_M:
        lon, lat = planar.lonlat(near[:1], near[1:])
        # the height that gives the aim's pitch from the ring, the stand-off from the corner: the leg's farther end (a
        # chord's ends are the ring's vertices; a ring's end lies on its first chord, inside it)
        d = float(np.max(np.hypot(*(ends - near).T))) / plan.site.grid_scale
        z = w.alt_m + d * math.tan(math.radians(aim.pitch_deg))
        return Roi(round(float(lat[0]), 8), round(float(lon[0]), 8), round(z + shift, 2), round(aim.pitch_deg, 4))
    return _outline_bearing(plan, aim, at, float(np.degrees(np.arctan2(*(ends[1] - ends[0])))))


def _outline_bearing(plan: Plan, aim: Aim, at: np.ndarray, grid_heading: float) -> Gimbal:
    """The camera held in the earth frame on the look of an outline's aim from `at` (1, 2), the
    vehicle flying `grid_heading` there."""
    planar = plan.site.planar
    grid = float(aim.bearings(at, np.zeros(1))[0])
    bearing = float(planar.true_bearing(np.array([grid]), at[:, 0], at[:, 1])[0])
    heading = float(planar.true_bearing(np.array([grid_heading % 360.0]), at[:, 0], at[:, 1])[0])
    return Gimbal(aim.pitch_deg, round(_wrap180(bearing - heading), 6), round(bearing % 360.0, 6), earth=True)


def _camera_actions(plan: Plan) -> tuple[CameraStart | None, CameraStop | None]:
    trig = plan.camera.trigger
    if trig == "distance":
        assert plan.sensor.trigger_distance_m is not None
        distance = plan.sensor.trigger_distance_m
        if plan.vehicle.firmware == "px4":
            distance = px4_trigger_distance(plan.sensor.base_m, plan.sensor.speed.speed_ms)
        return CameraStart(distance, None), CameraStop(distance=True)
    if trig == "time":
        assert plan.sensor.trigger_interval_s is not None
        return CameraStart(None, plan.sensor.trigger_interval_s), CameraStop(distance=False)
    return None, None


def _station_waypoint(plan: Plan, n: int) -> RouteWaypoint:
    st = plan.stations
    return RouteWaypoint(float(st.x[n]), float(st.y[n]), float(st.lon[n]), float(st.lat[n]), float(st.alt_rel_m[n]),
                         "station", int(st.run[n]), st.ids[n])


def _with_stations(plan: Plan, wps: tuple[RouteWaypoint, ...], first: int, last: int,
                   every: int) -> tuple[tuple[RouteWaypoint, ...], set[str]]:
    """The route with every `every`-th station of each run of the flight (stations first..last,
    counted from the run's first station in it) on its run's line, in the order they lie along
    it: a waypoint already on such a station stays (and shoots there), the others ("station")
    are inserted between the line's waypoints; and the ids of those stations."""
    st = plan.stations
    at: set[str] = set()
    out: list[RouteWaypoint] = []
    i = 0
    while i < len(wps):
        w = wps[i]
        if w.kind != "line_start":
            out.append(w)
            i += 1
            continue
        j = i
        while j < len(wps) and wps[j].run == w.run and wps[j].kind in ON_LINE:
            j += 1
        line = list(wps[i:j])
        on_line = {p.station for p in line if p.station}
        k = np.flatnonzero(st.run == w.run)
        k = k[(k >= first) & (k <= last)][::every]
        at.update(st.ids[n] for n in k)
        extra = [int(n) for n in k if st.ids[n] not in on_line]
        if len(line) > 1 and extra:
            path = shapely.LineString([(p.x, p.y) for p in line])
            at_vertex = [path.project(shapely.Point(p.x, p.y)) for p in line]
            at_station = shapely.line_locate_point(path, shapely.points(st.x[extra], st.y[extra]))
            # by the distance along the line (the line end after every station: a lane flown up or down ends at its
            # last station); a station never lies on a line waypoint it is not tagged with
            merged = sorted([(d, 2 if p.kind == "line_end" else 0, p) for d, p in zip(at_vertex, line)]
                            + [(float(d), 1, _station_waypoint(plan, n)) for n, d in zip(extra, at_station)],
                            key=lambda t: (t[0], t[1]))
            out.extend(p for _, _, p in merged)
        else:
            out.extend(line)
        i = j
    return tuple(out), at
