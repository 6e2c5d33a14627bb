"""Sensor solution: flying heights, GSD, footprint, line spacing, photo base, speed limit and
trigger, from the spec and the relief under the area. The first step of the pipeline.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from aerosurvey.errors import InputError
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.flight_time import Kinematics, look_hold_s
from aerosurvey.plan.model import Heights
from aerosurvey.spec import MissionSpec


@dataclass(frozen=True)
class Footprint:
    """The ground a pattern's photo surely photographs, square to its line (metres, at the
    lowest height above ground), and for a tilted camera the GSD at its far edge."""

    across_m: float
    along_m: float
    far_gsd_m: float | None = None  # None: the camera looks straight down (the GSD is the height's)
    # how many lines apart the nearest two lines whose photos look the same way lie: the side
    # overlap must hold between them (what reconstruction matches), so the line spacing is laid
    # that many times closer than one line's photos would need (an oblique double grid's lines
    # alternate their look with the direction of flight: 2)
    lines_per_look: int = 1


def nadir_footprint(spec: MissionSpec, heights: Heights) -> Footprint:
    """A camera looking straight down, the image's top along the line."""
    across, along = pg.footprint(heights.spacing_agl_m, spec.camera.camera, spec.camera.mount)
    return Footprint(float(across), float(along))


@dataclass(frozen=True)
class SensorSolution:
    """Everything that follows from the camera, the targets and the vehicle, before any line is laid."""

    heights: Heights
    gsd_target_m: float
    gsd_min_m: float  # over the highest ground (the lowest height above it)
    gsd_max_m: float
    across_m: float  # footprint across the line, at the lowest height above ground
    along_m: float
    spacing_m: float
    base_m: float  # photo base flown (distance trigger: the spacing the autopilot really flies)
    trigger_distance_m: float | None  # DO_SET_CAM_TRIGG_DIST (distance triggering)
    trigger_interval_s: float | None
    speed: pg.SpeedLimit
    turn_radius_m: float
    lead_in_m: float
    side_images_per_point: int
    forward_images_per_point: int
    kinematics: Kinematics
    warnings: tuple[str, ...]
    hover_s: float | None = None  # hover-and-capture: seconds at rest at each station (settling, the shot)
    hover_look_s: float = 0.0  # hover-and-capture: the hold of each further aim at a place (`flight_time.look_hold_s`)
    # a camera turned against the lines by their heading (a plane's body-fixed camera by its crab, a copter's held
    # yaw: planner._camera_turn): the solution lines of one grid heading alone need, at that heading's own turn
    own_turn: Callable[[float], SensorSolution] | None = field(default=None, compare=False, repr=False)

    def at_heading(self, heading_deg: float) -> SensorSolution:
        """The solution lines of grid heading `heading_deg` would be laid with if they were the only ones: with a
        camera turned by the heading, its own turn's (the heading search prices each candidate so); else this one."""
        return self if self.own_turn is None else self.own_turn(heading_deg)


def target_height(spec: MissionSpec) -> tuple[float, float, tuple[str, ...]]:
    """(height AGL, target GSD, warnings) honouring the height cap."""
    cam = spec.camera.camera
    cap = spec.vehicle.max_height_agl_m
    if spec.targets.gsd_m is not None:
        gsd = spec.targets.gsd_m
        h = pg.height_from_gsd(gsd, cam)
    else:
        h = spec.targets.height_m or 0.0
        gsd = pg.gsd_from_height(h, cam)
    if h > cap + 1e-9:
        at_cap = pg.gsd_from_height(cap, cam)
        if not spec.targets.plan_at_cap:
            raise InputError(
                f"targets: GSD {gsd * 100:.2f} cm needs {h:.1f} m above ground with {cam.name}, above the cap "
                f"vehicle.max_height_agl_m = {cap:g} m; at the cap the GSD is {at_cap * 100:.2f} cm. Ask for that GSD, "
                f"or set targets.plan_at_cap = true"
            )
        return cap, at_cap, (f"flying at the height cap {cap:g} m: GSD {at_cap * 100:.2f} cm instead of the {gsd * 100:.2f} cm asked for",)
    return h, gsd, ()


def solve_heights(spec: MissionSpec, h_target: float, ground: tuple[float, float] | None) -> Heights:
    """What the terrain mode decides: the AGL heights that drive GSD and spacing.

    `ground` is the lowest and highest DEM cell under the area (None without a DEM).
    """
    mode = spec.terrain.mode
    tol = spec.terrain.tolerance_m
    if mode == "fixed":
        assert ground is not None
        gmin, gmax = ground
        relief = gmax - gmin
        spacing_h = h_target - relief
        if spacing_h < spec.terrain.min_clearance_m:
            raise InputError(
                f"terrain.mode = 'fixed': the ground under the area rises {relief:.1f} m (from {gmin:.1f} to {gmax:.1f} m), "
                f"so one height of {h_target:.1f} m above the lowest ground leaves {spacing_h:.1f} m above the highest, "
                f"less than terrain.min_clearance_m = {spec.terrain.min_clearance_m:g} m; use terrain.mode = 'follow'"
            )
        return Heights(mode, h_target, h_target, spacing_h, h_target, gmin + h_target, gmin, gmax)
    if mode in ("follow", "terrain-frame"):
        nominal = h_target - tol
        low = h_target - 2 * tol
        if low <= spec.terrain.min_clearance_m:
            raise InputError(
                f"terrain.tolerance_m = {tol:g} is too large for a flying height of {h_target:.1f} m "
                f"(the lowest allowed height {low:.1f} m is under terrain.min_clearance_m = {spec.terrain.min_clearance_m:g} m)"
            )
        if ground is None:
            return Heights(mode, h_target, nominal, low, h_target, None, None, None)
        return Heights(mode, h_target, nominal, low, h_target, None, ground[0], ground[1])
    return Heights("none", h_target, h_target, h_target, h_target, None, None, None)


#: seconds a copter's nose takes to turn onto a run flown back from the one before and settle there: ArduCopter
#: slews its yaw target at ATC_SLEW_YAW (60°/s by default: 3 s for 180°), and in SITL the nose then closes in on
#: the run's heading slowly: 1.8° short at a facade lane's first photo 4.4 s after the turn began, 1.0° two
#: photos later (docs/planning.md, "Facades and quarry faces")
NOSE_TURN_S = 6.0


def lead_in_m(spec: MissionSpec, speed_ms: float, radius_m: float, nose_turns: bool = False) -> float:
    """Straight approach before the first photo of a line: a copter's stopping distance, a plane's settling.
    `nose_turns`: a copter's camera looks where its nose turns it (`PatternKind.nose_turns_camera`), and the
    approach also lasts `NOSE_TURN_S` from rest (`pg.distance_from_rest`: at most that far in that time)."""
    if spec.flight.lead_in_m is not None:
        return spec.flight.lead_in_m
    if spec.vehicle.type == "copter":
        a = spec.vehicle.acceleration_ms2
        turn = pg.distance_from_rest(speed_ms, a, NOSE_TURN_S) if nose_turns and spec.flight.fixed_yaw_deg is None else 0.0
        return max(5.0, pg.stop_distance(speed_ms, a), turn)
    return max(radius_m, pg.plane_lead_in(speed_ms, spec.vehicle.nav_period_s))


def solve_sensor(spec: MissionSpec, h_target: float, gsd_target: float, heights: Heights,
                 warnings: tuple[str, ...] = (), *, footprint: Footprint, autopilot_stretch: float,
                 camera_turns_deg: tuple[float, ...] = (), nose_turns: bool = False) -> SensorSolution:
    """Footprint, spacing, base, speed and trigger for the heights the terrain mode decided.
    `footprint`: the ground a photo of the pattern surely photographs (`PatternKind.footprint`).
    `camera_turns_deg`: the angles a camera held at a fixed yaw is turned by against the lines; the
    footprint is then the ground it surely photographs across and along the line at every one of them.
    `autopilot_stretch`: the most ground metres a metre of the autopilot's distance spans at the
    site (`Site.autopilot_stretch`); the base is in the autopilot's metres (it triggers and
    flies by them), short enough that on the ground it keeps the forward overlap in any direction."""
    cam = spec.camera.camera
    if heights.max_agl_m > spec.vehicle.max_height_agl_m + 1e-9:
        raise InputError(f"the plan would fly {heights.max_agl_m:.1f} m above ground, above "
                         f"vehicle.max_height_agl_m = {spec.vehicle.max_height_agl_m:g} m")
    across, along, gsd_far = footprint.across_m, footprint.along_m, footprint.far_gsd_m
    if camera_turns_deg:
        turned = [pg.turned_footprint(across, along, t) for t in camera_turns_deg]
        across, along = min(a for a, _ in turned), min(b for _, b in turned)
    spacing = pg.line_spacing(across, spec.targets.side_overlap) / footprint.lines_per_look
    # whole centimetres, rounded down: the mission carries the trigger distance to 1 cm, and
    # the stations must lie exactly where the autopilot's distance trigger will fire
    base = math.floor(pg.trigger_distance(along, spec.targets.forward_overlap) / autopilot_stretch * 100.0) / 100.0
    gsd_min = pg.gsd_from_height(heights.spacing_agl_m, cam)
    gsd_max = pg.gsd_from_height(heights.max_agl_m, cam) if gsd_far is None else gsd_far
    speed = pg.survey_speed(spec.vehicle.cruise_speed_ms, base, gsd_min, cam, spec.camera.max_blur_px,
                            spec.camera.min_cycle_s, spec.camera.exposure_s)
    interval = None
    if spec.camera.trigger in ("time", "camera"):
        interval = spec.camera.interval_s or max(spec.camera.min_cycle_s, base / speed.speed_ms)
        if interval < spec.camera.min_cycle_s - 1e-9:
            raise InputError(f"camera.interval_s = {interval:g} is shorter than the camera's cycle time {spec.camera.min_cycle_s:g} s",
                             key="camera.interval_s")
        v = min(speed.speed_ms, base / interval)
        speed = pg.SpeedLimit(v, speed.reason if v == speed.speed_ms else f"trigger interval {interval:g} s",
                              speed.cruise_ms, speed.cycle_limit_ms, speed.blur_limit_ms)
    hover, look = None, 0.0
    if spec.camera.trigger == "hover":
        # photos taken at rest: neither motion blur nor the camera's cycle limits the speed between them
        speed = pg.SpeedLimit(spec.vehicle.cruise_speed_ms, "vehicle cruise speed (hover-and-capture: photos at rest)",
                              speed.cruise_ms, speed.cycle_limit_ms, speed.blur_limit_ms)
        hover = hover_rest_s(spec)
        look = look_hold_s(spec.camera.settle_s, spec.camera.min_cycle_s)
    trigger_cmd = None
    if spec.camera.trigger == "distance":
        # whole centimetres a second, rounded down: the mission commands the speed to 1 cm/s, and
        # the trigger's check steps (speed / 50 Hz) must be those the autopilot flies
        speed = replace(speed, speed_ms=math.floor(speed.speed_ms * 100.0 + 1e-6) / 100.0)
        try:
            trigger_cmd, base = pg.distance_trigger(base, speed.speed_ms)
        except ValueError as exc:
            raise InputError(f"{exc}: fly slower or ask for a larger photo base") from None
    radius = pg.turn_radius(speed.speed_ms, spec.vehicle.bank_angle_deg) if spec.vehicle.type == "plane" else 0.0
    lead = lead_in_m(spec, speed.speed_ms, radius, nose_turns)
    return SensorSolution(
        heights=heights, gsd_target_m=gsd_target, gsd_min_m=gsd_min, gsd_max_m=gsd_max, across_m=across, along_m=along,
        spacing_m=spacing, base_m=base, trigger_distance_m=trigger_cmd, trigger_interval_s=interval, speed=speed,
        turn_radius_m=radius, lead_in_m=lead,
        side_images_per_point=pg.images_per_point(spec.targets.side_overlap),
        forward_images_per_point=pg.images_per_point(spec.targets.forward_overlap),
        kinematics=Kinematics(spec.vehicle.type, speed.speed_ms, spec.vehicle.acceleration_ms2, radius,
                              reach_m=pg.l1_distance(speed.speed_ms, spec.vehicle.nav_period_s) if radius else 0.0),
        warnings=warnings, hover_s=hover, hover_look_s=look,
    )


def hover_rest_s(spec: MissionSpec) -> float:
    """Hover-and-capture: the seconds at rest at a station, settling (`camera.settle_s`) and the shot (the camera's cycle)."""
    return spec.camera.settle_s + spec.camera.min_cycle_s


def reach_beyond_area_m(spec: MissionSpec) -> float:
    """An upper bound of how far beyond the area a plan's stations, lead-ins and line ends lie,
    from the spec alone: the loader reads that much DEM around the area."""
    cam = spec.camera.camera
    h = spec.targets.height_m if spec.targets.gsd_m is None else pg.height_from_gsd(spec.targets.gsd_m, cam)
    h = min(h or 0.0, spec.vehicle.max_height_agl_m)
    across, along = pg.footprint(h, cam, spec.camera.mount)
    v = spec.vehicle.cruise_speed_ms
    radius = pg.turn_radius(v, spec.vehicle.bank_angle_deg) if spec.vehicle.type == "plane" else 0.0
    lead = lead_in_m(spec, v, radius, nose_turns=True)
    beyond = (spec.targets.images_beyond_boundary + 1) * along
    return spec.targets.coverage_margin_m + max(across, beyond) + lead + 2.0 * radius + 100.0
