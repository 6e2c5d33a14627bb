"""The flight-time model: what it needs of the vehicle (`Kinematics`), a plane's turn between
lines, a copter's stops at corners and its straight runs (`path_time`; `CopterTime` and
`RouteSegments` time a route in parts for the battery split), hover-and-capture, the descent, and
the quick estimate of a heading's boustrophedon (`quick_cost`) with its proven lower bounds.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, replace

import numpy as np

from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.lines import LineBounds, LineSegment


def lean_drag(nose_ms: float, diagonal_ms: float | None) -> tuple[float, float]:
    """The drag law of a copter's lean limit, as the share of the most force its lean holds (ArduCopter's
    ANGLE_MAX: m·g·tan of it): the air's velocity (x, y) in the copter's frame (x along its nose) drags
    (f(|x|), f(|y|)), f(v) = quad·v² + lin·v, a drag quadratic along each body axis (ArduPilot SITL's body
    drag, SIM_Frame.cpp) and one linear in the air speed (its rotors' momentum drag, SIM_Motor.cpp); the
    limit holds while f(|x|)² + f(|y|)² ≤ 1. Returns (quad, lin), from the air speed at the limit straight
    on the nose, `nose_ms` (f(nose_ms) = 1), and 45° off it, `diagonal_ms` (2·f(d/√2)² = 1; None: the same
    as on the nose, lin alone, a circle). The least air speed at the limit is the nose's (d ≥ nose_ms);
    d ≤ 2^¼·nose_ms keeps both parts at least 0 (the spec's bound, `spec.DIAGONAL_GAIN_MAX`)."""
    n, d = nose_ms, nose_ms if diagonal_ms is None else diagonal_ms
    det = n * d * (n - d / math.sqrt(2.0))  # of q·n² + l·n = 1, q·d²/√2 + l·d = 1
    return (d - n) / det, (n * n - d * d / math.sqrt(2.0)) / det


@dataclass(frozen=True)
class Kinematics:
    """What the time model needs of the vehicle, and the wind it flies in.

    The wind is its velocity (where the air moves to) along the planning grid's x and y, m/s
    (`planner.in_wind` turns conditions.wind, a true bearing, into it). A plane flies
    `speed_ms` through the air; a copter holds `speed_ms` over the ground as long as the air
    velocity that takes stays within its lean limit, and makes good what that limit allows where it
    does not (`ground_speed`): `airspeed_ms` straight on its nose, `airspeed_diagonal_ms` 45° off it
    (None: the same in every direction; `lean_drag`)."""

    vehicle: str
    speed_ms: float
    accel_ms2: float
    turn_radius_m: float
    jerk_ms3: float = 1.0  # copters: ArduCopter's WPNAV_JERK default
    wind_x: float = 0.0
    wind_y: float = 0.0
    airspeed_ms: float = math.inf  # copters: the most air speed on the nose (vehicle.max_airspeed_ms); planes fly speed_ms
    airspeed_diagonal_ms: float | None = None  # copters: the most 45° off the nose (vehicle.max_airspeed_diagonal_ms)
    reach_m: float = 0.0  # planes: how far short of a waypoint ArduPlane turns for the next (one L1 distance)

    @property
    def calm(self) -> bool:
        return self.wind_x == 0.0 and self.wind_y == 0.0

    def ground_speed(self, angle_deg: float) -> float:
        """The speed over the ground along a track in direction `angle_deg` (atan2(dy, dx) of the
        grid, in degrees), by the wind triangle: the air velocity a plus the wind w make a ground
        velocity along the track u, g·u = a + w, so a = (g − w·u)·u − (w×u)·u⊥. A plane's |a| is its air
        speed: g = w·u + √(|a|² − (w×u)²). A copter's nose points along its track, so a's part along the
        nose is g − w·u and across it w×u: it makes good the most g whose air velocity its lean limit
        holds, f(g − w·u)² + f(w×u)² = 1 (`lean_drag`'s f), g = w·u + f⁻¹(√(1 − f(w×u)²)), at most speed_ms."""
        a = math.radians(angle_deg)
        c, s = math.cos(a), math.sin(a)
        along, across = self.wind_x * c + self.wind_y * s, self.wind_y * c - self.wind_x * s
        air = self.speed_ms if self.vehicle != "copter" else self.airspeed_ms
        if air == math.inf:
            return self.speed_ms
        quad, lin = lean_drag(air, self.airspeed_diagonal_ms if self.vehicle == "copter" else None)  # a plane's: a circle
        left = 1.0 - (quad * across * across + lin * abs(across)) ** 2  # f(along the nose)² the crosswind leaves
        f = math.sqrt(max(left, 0.0))
        g = along + 2.0 * f / (lin + math.sqrt(lin * lin + 4.0 * quad * f))  # f⁻¹(f), the root of quad·v² + lin·v = f
        if g <= 0.0 or left < 0.0:
            raise ValueError(f"a wind of {math.hypot(self.wind_x, self.wind_y):.2f} m/s is not below the air speed "
                             f"{air:g} m/s: no headway along {angle_deg:.1f}°")
        return g if self.vehicle != "copter" else min(self.speed_ms, g)

    def in_frame(self, frame: LineFrame) -> Kinematics:
        """These kinematics with the wind turned into `frame`'s coordinates (its lines along +x), where
        `quick_cost` and the heading search time a heading's lines."""
        if self.calm:
            return self
        (x,), (y,) = frame.to_frame(np.array([self.wind_x]), np.array([self.wind_y]))
        return replace(self, wind_x=float(x), wind_y=float(y))

    def cruising(self, speed_ms: float) -> Kinematics:
        """These kinematics on the ways from and back to the launch point, in the same wind: a copter's at the
        transits' speed (vehicle.cruise_speed_ms); a plane's as they are, at the survey speed (its mission's
        DO_CHANGE_SPEED follows the take-off: `plane_transit_time`)."""
        return self if self.vehicle == "plane" else replace(self, speed_ms=speed_ms)

    @property
    def least_slowness(self) -> float:
        """The least `slowness` along any direction: a plane's, straight downwind, v / (v + |w|); a copter's is 1
        (it never flies faster over the ground than speed_ms)."""
        if self.calm or self.vehicle == "copter":
            return 1.0
        return self.speed_ms / (self.speed_ms + math.hypot(self.wind_x, self.wind_y))

    def crab_deg(self, angle_deg: float) -> float:
        """How far a plane flying along `angle_deg` (atan2(dy, dx) of the grid, in degrees) turns its nose into
        the wind, either way: asin(crosswind / air speed) (`ground_speed`'s air velocity off the track). 0 for a
        copter, whose nose points along its track while it leans into the wind."""
        if self.calm or self.vehicle == "copter":
            return 0.0
        a = math.radians(angle_deg)
        across = self.wind_y * math.cos(a) - self.wind_x * math.sin(a)
        return math.degrees(math.asin(min(abs(across) / self.speed_ms, 1.0)))

    def slowness(self, angle_deg: float) -> float:
        """speed_ms over the ground speed along `angle_deg`: the still-air length that takes as long as a metre flown there."""
        return 1.0 if self.calm else self.speed_ms / self.ground_speed(angle_deg)


def plane_turn_time(k: Kinematics) -> float:
    """Seconds of a plane's half circle at its turn radius, in the moving air (`plane_reversal`)."""
    return math.pi * k.turn_radius_m / k.speed_ms


#: A leg after a waypoint on the line that ends nearer the line than this (metres) goes back along it (`plane_reversal`)
SIDE_M = 0.01


def plane_reversal(ahead: np.ndarray, lateral: np.ndarray, back: np.ndarray, angle_in_deg: np.ndarray,
                   angle_out_deg: np.ndarray, k: Kinematics) -> np.ndarray:
    """Seconds a plane takes from a line's end to the end of the leg after the next waypoint (the next line's first
    station, its lead-in flown): the one price of a plane's reversal (`path_time`, so the route's and the sorties'
    times and `quick_cost`; `quick_cost_lower_bounds`; `plane_takeoff`'s turn back). Elementwise: the waypoint lies
    `ahead` along the line (negative: behind) and `lateral` across it (positive: to the left), the leg after it is
    `back` long; the line runs along `angle_in_deg`, that leg along `angle_out_deg` (atan2(dy, dx), degrees).

    ArduPlane flies on along the line until its L1 distance short of the waypoint along it, which grows with the
    ground speed g (ζ·P·g/π: `Kinematics.reach_m` times g/v; at once where the waypoint is nearer or behind), then
    turns towards the waypoint's side (onto the same line: either side, the longer) at its turn radius R: a half
    circle in the moving air from the heading it held (its nose into the wind), which ends 2R across that heading
    from where it began and, the air having moved, w·πR/v (`plane_turn_time`) downwind of that; from there it
    makes for the next line's first station straight, at the ground speed along that way (ArduPlane SITL does not
    fly an omega onto a line nearer than 2R: it overshoots and closes on the line from beyond it)."""
    ahead, lateral, back = (np.asarray(x, float) for x in (ahead, lateral, back))
    v, radius = k.speed_ms, k.turn_radius_m
    a_in, a_out = np.radians(angle_in_deg), np.radians(angle_out_deg)
    ux, uy = np.cos(a_in), np.sin(a_in)  # along the line; (-uy, ux) to its left
    g_in = np.array([k.ground_speed(a) for a in np.degrees(a_in).tolist()])
    start = np.maximum(ahead - k.reach_m * g_in / v, 0.0)  # where along the line it turns
    turn = plane_turn_time(k)
    nose_x, nose_y = (g_in * ux - k.wind_x) / v, (g_in * uy - k.wind_y) / v  # its air velocity's direction
    # the next line's first station from where the turn began, carried by the wind
    tx = (ahead - start) * ux - lateral * uy + back * np.cos(a_out) - k.wind_x * turn
    ty = (ahead - start) * uy + lateral * ux + back * np.sin(a_out) - k.wind_y * turn

    def way(side: float) -> np.ndarray:  # from the turn's end, 2R to the nose's left (side 1) or right (-1)
        dx, dy = tx + side * 2.0 * radius * nose_y, ty - side * 2.0 * radius * nose_x
        seconds: np.ndarray = np.hypot(dx, dy) / np.array([k.ground_speed(a) for a in np.degrees(np.arctan2(dy, dx)).tolist()])
        return seconds

    left, right = way(1.0), way(-1.0)
    # a waypoint on the line (lateral 0, a way out's approach point): the side the leg after it goes to, where it
    # leaves the line by more than SIDE_M (nearer, back along the same line: either side, the longer)
    goes = back * np.sin(a_out - a_in)
    side = np.where(lateral != 0.0, lateral, np.where(np.abs(goes) > SIDE_M, goes, 0.0))
    out: np.ndarray = start / g_in + turn + np.where(side > 0.0, left, np.where(side < 0.0, right, np.maximum(left, right)))
    return out


def approach_setback_m(k: Kinematics) -> float:
    """How far behind a line's lead-in waypoint a plane's way out first goes where it would meet that waypoint
    heading more than 90° off the line (`detours.approach_way`): the turn's diameter 2R and the L1 distance at
    twice the air speed over the ground (no wind allowed reaches the air speed), so that the turn onto the line,
    begun one L1 distance short of that point, ends on the line's extension before the lead-in; 0 for a copter."""
    return 2.0 * (k.turn_radius_m + k.reach_m) if k.vehicle == "plane" else 0.0


#: A copter stops at a corner sharper than this (degrees) and flies on through a gentler one
CORNER_DEG = 30.0


def _speed_change_time(u: float, a: float, j: float) -> float:
    """Seconds a copter takes from rest to `u` m/s (or back) with acceleration at most `a` reached at jerk `j`: the
    acceleration ramps up at j, holds a, ramps down (an S-curve, symmetric, so it covers u/2 times this); a change
    too small to reach a ramps up and straight down again. j = 0: no jerk limit."""
    if j <= 0.0:
        return u / a
    return u / a + a / j if u >= a * a / j else 2.0 * math.sqrt(u / j)


def _straight_time(d: float, k: Kinematics) -> float:
    """Copter from rest to rest over d metres: top speed v, acceleration a, jerk J (`_speed_change_time`).

    Long enough to cruise, the two speed changes take 2T(v) and cover v·T(v), so t = d/v + T(v)
    (= d/v + v/a + a/J once v ≥ a²/J). Shorter, it turns back at the peak speed u whose two changes
    cover d, u·T(u) = d, and t = 2T(u): with a reached (u ≥ a²/J), u²/a + u·a/J = d, so
    t = a/J + √((a/J)² + 4d/a); with a not reached, 2u√(u/J) = d; with no jerk limit, u²/a = d. The
    time rises with d, smoothly up to where the legs become long enough to cruise."""
    v, a, j = k.speed_ms, k.accel_ms2, k.jerk_ms3
    if d <= 0:
        return 0.0
    top = _speed_change_time(v, a, j)
    if d >= v * top:
        return d / v + top
    if j <= 0.0:
        return 2.0 * math.sqrt(d / a)
    r = a / j
    if d >= 2.0 * a * r * r:  # the peak speed reaches a²/J: u·T(u) there is a·r·2r
        return r + math.sqrt(r * r + 4.0 * d / a)
    u = (0.5 * d * math.sqrt(j)) ** (2.0 / 3.0)
    return 4.0 * math.sqrt(u / j)


#: what each further aim shot at rest at a station adds to its hold (a pass's `looks`): the gimbal
#: turned to the next aim, at most 90° (a look's yaw step; nadir to oblique is 45° of pitch) at
#: 90°/s, under the 120°/s a DJI gimbal is driven at most (DJI Mobile SDK, DJIGimbalRotation's
#: yaw angle velocity range); ArduPilot SITL's servo mount turns at once
GIMBAL_SLEW_S = 1.0


def look_hold_s(settle_s: float, cycle_s: float) -> float:
    """The hold before each further aim's photo at a place (the flight program's waypoint hold): the
    gimbal's turn and the settling, at least the camera's cycle (the photo before it was taken as
    the hold began)."""
    return max(settle_s + GIMBAL_SLEW_S, cycle_s)


#: ArduCopter's vertical acceleration in missions (WPNAV_ACCEL_Z: 1 m/s² by default): a copter's climb from one
#: station to the next above it, its jerk the level legs' (WPNAV_JERK, `Kinematics.jerk_ms3`'s default)
CLIMB_ACCEL_MS2 = 1.0


@dataclass(frozen=True)
class Climbs:
    """A copter's climbs and descents from rest to rest (a lane flown up or down a wall, a station
    above the one before): at most `up_ms` up and `down_ms` down (vehicle.climb_rate_ms and
    descent_rate_ms, ArduCopter's WPNAV_SPEED_UP and WPNAV_SPEED_DN) and `CLIMB_ACCEL_MS2`, as
    `_straight_time` flies a level leg (ArduCopter's waypoint S-curve in 3-D, jerk WPNAV_JERK)."""

    up_ms: float
    down_ms: float

    def time(self, rises: np.ndarray) -> float:
        """Seconds of the vertical moves `rises` (metres, + up), each from rest to rest."""
        up = Kinematics("copter", self.up_ms, CLIMB_ACCEL_MS2, 0.0)
        down = replace(up, speed_ms=self.down_ms)
        return float(sum(_straight_time(abs(d), up if d > 0 else down) for d in np.asarray(rises, float).tolist()))


def lanes_in_place(x: np.ndarray, y: np.ndarray, z: np.ndarray, run: np.ndarray,
                   grid_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Where station rows follow one another on a run at one place and at different heights (a lane
    flown up or down a wall): (rises, arrivals), each (n,), in flight order. `rises`: each row's
    vertical move from the row before in such a lane, else 0 (metres, + up); `arrivals`: for the
    first row of a run with such a move, the level distance from the row before it (the lane before's
    last station: the way between them is flown from rest to rest), else 0. The rows' places `x`, `y`
    (planning CRS, `grid_scale` planning metres a metre), heights `z`, runs `run`."""
    x, y, z, run = (np.asarray(a) for a in (x, y, z, run))
    if not len(z):
        return np.zeros(0), np.zeros(0)
    step = np.hypot(np.diff(x.astype(float)), np.diff(y.astype(float))) / grid_scale
    same_run = run[1:] == run[:-1]
    rises = np.r_[0.0, np.where(same_run & (step < 1e-6), np.diff(z.astype(float)), 0.0)]
    climbing = np.isin(run, run[rises != 0.0])
    arrivals = np.r_[0.0, np.where(~same_run & climbing[1:], step, 0.0)]
    return rises, arrivals


def overlap_cap_s(k: Kinematics) -> float:
    """Twice a speed change to cruise: in a chain of legs (`CopterTime`) no leg overlaps the next by more
    than half of it."""
    return 2.0 * _speed_change_time(k.speed_ms, k.accel_ms2, k.jerk_ms3)


def hover_time(stations: int, runs: int, base: float, lead: float, hold_s: float, k: Kinematics, aims: int = 1,
               look_s: float = 0.0, rises: np.ndarray | None = None, climbs: Climbs | None = None,
               arrivals: np.ndarray | None = None) -> float:
    """What hover-and-capture adds to a copter's time over runs flown straight through (`path_time`
    of the route): at each of `stations` photos it stops (braking and accelerating again over the
    `base` between two stations of a run, `_straight_time` against cruising it) and rests `hold_s`.
    With `aims` photos at each place (the camera turned between them), `stations` counts them all:
    the stops are a place's, its first aim rests `hold_s` and each further aim `look_s`
    (`look_hold_s`). A run's first station is a stop too (ArduCopter flies on through no waypoint
    with a hold): the route's run, from its `lead`-metre lead-in on into its line, brakes and speeds
    up once more than its stops do (a speed change less its overlap with the lead-in, `path_time`;
    the line's first leg taken at least as long as the lead-in), which comes off. A station
    straight above or below the one before (`rises`, of `lanes_in_place`: a lane flown up or down)
    is reached by its climb or descent (`climbs`) instead of a level base, and the level way to such
    a lane from the one before (`arrivals`) is flown from rest to rest, not straight on."""
    places = stations // aims
    moves = np.zeros(0) if rises is None else np.asarray(rises, float)
    moves = moves[moves != 0.0]
    stops = max(places - runs - len(moves), 0)
    change = _speed_change_time(k.speed_ms, k.accel_ms2, k.jerk_ms3)
    into_line = change - min(_straight_time(lead, k) / 2.0, change)
    out = (places * hold_s + (stations - places) * look_s + stops * (_straight_time(base, k) - base / k.speed_ms)
           - runs * into_line)
    if len(moves):
        assert climbs is not None, "a lane flown up or down is timed at the climb and descent rates"
        out += climbs.time(moves)
    # path_time flies the level way to a lane on from the way before it (the lanes' places lie in a line along the
    # wall, a lane's climb unseen in plan): begun as that one brakes, by half the shorter's time at most (`CopterTime`,
    # the way before as long as this one or longer: the lanes are evenly apart, the first's lead-in longer); from
    # rest to rest it takes that overlap more
    reached = np.zeros(0) if arrivals is None else np.asarray(arrivals, float)
    for d in reached[reached > 0.0].tolist():
        out += min(_straight_time(d, k), overlap_cap_s(k)) / 2.0
    return out


#: path_time takes a turn by this little (degrees) for a leg straight on from the one before: no corner
STRAIGHT_ON_DEG = 1e-3

#: path_time drops segments this short or shorter (planning-grid units / grid scale)
KEPT = 1e-9


def path_time(points: np.ndarray, k: Kinematics) -> float:
    """Flight time along a polyline.

    Copter: it stops at every corner sharper than CORNER_DEG and flies on through the others
    as ArduCopter's S-curves do (AP_Math/SCurve.cpp): each leg (from a waypoint to the next) is a
    stop-to-stop run of its own (`_straight_time`: its speed-up, cruise and braking, or turning
    back at its peak speed when too short to cruise), and the next leg starts as this one brakes,
    once the time left of it is no more than the next one's speed-up
    (SCurve::advance_target_along_track): the two overlap by the shorter of the braking and the
    speed-up. Long legs overlap by a whole speed change, and a stretch of them takes as long as one
    run of their total length; a short leg is flown at its own peak speed, whatever the speed
    asked: in ArduCopter SITL (WPNAV_ACCEL 2.5 m/s², WPNAV_JERK 1 m/s³) an orbit's ring of 4.68 m
    chords turning 22.5° flew 1.63 m/s for 5.34 m/s commanded, a chord each 2.87 s (docs/planning.md,
    "An orbit round a structure"). Plane: constant speed; a reversal between two lines (a corner, a short
    connector, a corner back) and the leg after it are flown as :func:`plane_reversal`.
    """
    if len(points) < 2:
        return 0.0
    if k.vehicle == "copter":  # the battery split times sorties in parts by the same CopterTime
        timer = CopterTime(k)
        timer.feed(kept_segments(points))
        return timer.time()
    seg = np.diff(points, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    keep = lengths > KEPT
    seg, lengths = seg[keep], lengths[keep]
    if len(lengths) == 0:
        return 0.0
    ang = np.degrees(np.arctan2(seg[:, 1], seg[:, 0]))
    signed = (np.diff(ang) + 180.0) % 360.0 - 180.0  # each corner's turn, to the left > 0
    turn = np.abs(signed)
    # in wind each metre counts its slowness (still-air metres that take as long; 1 in calm air)
    slow = [1.0] * len(lengths) if k.calm else [k.slowness(a) for a in ang.tolist()]
    total_len = float(lengths.sum()) if k.calm else float(np.dot(lengths, slow))
    # a reversal: corner, short leg, corner, both turned the same way (a leg straight on from the one before, as a
    # line from its lead-in, is no corner: paired with the next corner it would replace the line itself by a turn; a
    # jog or an S-bend, turned one way then back, is no reversal)
    corner = turn > STRAIGHT_ON_DEG
    pairs: list[int] = []
    same_way = np.sign(signed[:-1]) == np.sign(signed[1:])
    for i in np.flatnonzero(corner[:-1] & corner[1:] & same_way & (turn[:-1] + turn[1:] > 150.0)).tolist():
        if not pairs or i > pairs[-1] + 1:  # the corner after a pair pairs with none
            pairs.append(i)
    if pairs:  # the connector and the leg after it (the next line's lead-in) flown as `plane_reversal`
        at = np.asarray(pairs)
        u, after = seg[at] / lengths[at, None], seg[at + 1]
        reversal = plane_reversal(u[:, 0] * after[:, 0] + u[:, 1] * after[:, 1], u[:, 0] * after[:, 1] - u[:, 1] * after[:, 0],
                                  lengths[at + 2], ang[at], ang[at + 2], k)
        flown = np.asarray(slow)
        total_len += float(reversal.sum() * k.speed_ms - np.dot(lengths[at + 1], flown[at + 1])
                           - np.dot(lengths[at + 2], flown[at + 2]))
    return total_len / k.speed_ms


#: The segments path_time keeps of a polyline: (lengths, directions in degrees), planning-grid units / grid scale
Segments = tuple[list[float], list[float]]


def all_segments(points: np.ndarray) -> Segments:
    """Every segment's length and direction (degrees) of a polyline, the dropped ones too, as
    `kept_segments` measures them (elementwise: the same floats whichever polyline a segment is part of)."""
    d = (points[1:] - points[:-1]).T
    return np.hypot(d[0], d[1]).tolist(), np.degrees(np.arctan2(d[1], d[0])).tolist()


def kept_segments(points: np.ndarray) -> Segments:
    """The segments path_time keeps of a polyline (already divided by the grid scale), by
    the same numpy operations on the same values (np.diff is this subtraction): elementwise, so a
    segment's length and direction are the same floats whichever polyline it is part of."""
    d = (points[1:] - points[:-1]).T
    dx, dy = d[0], d[1]
    lengths = np.hypot(dx, dy)
    keep = lengths > KEPT
    if not keep.all():
        dx, dy, lengths = dx[keep], dy[keep], lengths[keep]
    return lengths.tolist(), np.degrees(np.arctan2(dy, dx)).tolist()


class RouteSegments:
    """The kept segments of the whole runs and the detours between them, in flight order, with
    path_time's corners, each segment's time in its stretch before it (`before`: CopterTime's
    `run` with it the last leg) and, at each corner, the time of the stretch it ends (`closed`)."""

    __slots__ = ("lengths", "angles", "corners", "before", "closed", "kept_before", "times", "calm")

    def __init__(self, points: np.ndarray, kin: Kinematics):
        self.lengths, self.angles = kept_segments(points)
        # each segment's time as CopterTime.feed counts it (`leg_times`): in the wind and in still air
        self.times, self.calm = leg_times(self.lengths, self.angles, kin)
        seg = np.diff(points, axis=0)
        # kept_before[i]: how many kept segments come before segment i (from point i to point i + 1)
        self.kept_before: list[int] = np.concatenate([[0], np.cumsum(np.hypot(seg[:, 0], seg[:, 1]) > KEPT)]).tolist()
        turn = np.abs((np.diff(np.asarray(self.angles)) + 180.0) % 360.0 - 180.0)
        self.corners: list[int] = (np.flatnonzero(turn > CORNER_DEG) + 1).tolist()
        self.before: list[float] = []
        self.closed: dict[int, float] = {}
        at_corner = set(self.corners)
        times, calm = self.times, self.calm
        top = overlap_cap_s(kin)
        for k in range(len(times)):
            if k in at_corner:
                self.closed[k] = self.before[-1] + times[k - 1]
            # the same operations as CopterTime.feed's
            self.before.append(0.0 if k == 0 or k in at_corner else
                               self.before[-1] + (times[k - 1] - min(calm[k - 1], calm[k], top) / 2.0))


def leg_times(lengths: list[float], angles: list[float], kin: Kinematics) -> tuple[list[float], list[float]]:
    """A copter's time of each leg (`lengths`, directions `angles` in degrees) from rest to rest, in the wind
    of `kin` and in still air: `_straight_time` of its still-air flight, and in the wind each metre of its cruise
    slowed to take as long as `Kinematics.slowness` still-air metres (the copter slows only where its lean limit
    is reached: at its cruise; its speed changes, and so how far a leg overlaps the next, as in still air)."""
    calm = [_straight_time(x, kin) for x in lengths]
    if kin.calm:
        return calm, calm
    return [t + x * (kin.slowness(a) - 1.0) / kin.speed_ms for t, x, a in zip(calm, lengths, angles)], calm


class CopterTime:
    """path_time of a copter (path_time is made by it): it stops at every corner sharper than
    CORNER_DEG, and flies on through a gentler one (or straight on) as ArduCopter's S-curves do
    (`path_time`: each leg a stop-to-stop `_straight_time`, the next begun as it slows). In
    wind each leg's cruise is slowed (`leg_times`). Fed in parts, so that the stretches between
    corners of the whole runs are timed once for all sorties (`route`). Its state: the stretches
    ended so far (`total`), the current stretch's time before its last leg (`run`), that leg's
    direction (`last`) and its times in the wind and in still air (`leg`, None before the first)."""

    __slots__ = ("kin", "total", "run", "last", "leg", "top")

    def __init__(self, kin: Kinematics, total: float = 0.0, run: float = 0.0, last: float = 0.0,
                 leg: tuple[float, float] | None = None):
        self.kin = kin
        self.total, self.run, self.last, self.leg = total, run, last, leg
        self.top = overlap_cap_s(kin)

    def state(self) -> tuple[float, float, float, tuple[float, float] | None]:
        """What a CopterTime made of it goes on from (`CopterTime(kin, *state)`)."""
        return self.total, self.run, self.last, self.leg

    def feed(self, segs: Segments) -> None:
        # the state in locals while the loop runs (the same operations in the same order as RouteSegments')
        total, run, last, leg, corner, top = self.total, self.run, self.last, self.leg, CORNER_DEG, self.top
        t_leg, c_leg = (0.0, 0.0) if leg is None else leg
        times, calm = leg_times(*segs, self.kin)
        for t, c, ang in zip(times, calm, segs[1]):
            if leg is None:
                pass
            elif abs((ang - last + 180.0) % 360.0 - 180.0) > corner:
                total += run + t_leg
                run = 0.0
            else:
                run += t_leg - min(c_leg, c, top) / 2.0
            leg, t_leg, c_leg, last = (t, c), t, c, ang
        self.total, self.run, self.last, self.leg = total, run, last, leg

    def route(self, rs: RouteSegments, k0: int, k1: int) -> None:
        """Feed the route's kept segments k0..k1-1: one by one up to the first corner, the
        stretches between corners by their times, the last one's time before its last leg."""
        if k0 >= k1:
            return
        ci, cj = bisect.bisect_right(rs.corners, k0), bisect.bisect_left(rs.corners, k1)
        end = rs.corners[ci] if ci < cj else k1
        self.feed((rs.lengths[k0:end], rs.angles[k0:end]))
        if ci < cj:
            assert self.leg is not None
            self.total += self.run + self.leg[0]
            for c in rs.corners[ci + 1:cj]:
                self.total += rs.closed[c]
            self.run, self.leg, self.last = rs.before[k1 - 1], (rs.times[k1 - 1], rs.calm[k1 - 1]), rs.angles[k1 - 1]

    def time(self) -> float:
        return 0.0 if self.leg is None else self.total + self.run + self.leg[0]


#: A copter lands its last metres slowly (ArduCopter: below LAND_ALT_LOW = 10 m at LAND_SPEED = 0.5 m/s).
LAND_SLOW_ALT_M, LAND_SLOW_SPEED_MS = 10.0, 0.5


def descent_time(alt_m: float, rate_ms: float, vehicle: str) -> float:
    """Time from the survey height to the ground: descent rate, then a copter's slow final metres."""
    if vehicle != "copter":
        return alt_m / rate_ms
    slow = min(alt_m, LAND_SLOW_ALT_M)
    return (alt_m - slow) / rate_ms + slow / LAND_SLOW_SPEED_MS


def plane_transit_time(leg_out: np.ndarray, leg_back: np.ndarray, climb_m: float, climb_rate_ms: float,
                       takeoff_speed_ms: float, descent_rate_ms: float, k: Kinematics,
                       landing_speed_ms: float | None = None) -> tuple[float, float, float, float]:
    """A plane's way out and way home (polylines, planning-grid units / grid scale) at `k`'s speed in its
    wind (the survey speed: the mission's DO_CHANGE_SPEED follows the take-off), its take-off and the
    descent the way home leaves over. (out s, home s, climb s, descent s); the one model of both for the
    mission's estimate and the battery split.

    The take-off (`plane_takeoff`): the climb to `climb_m` at `climb_rate_ms` at the air speed
    `takeoff_speed_ms`, straight ahead along the way out's first leg; the way out is what is left after it.
    The descent overlaps the way home: what the way home leaves of it. With `landing_speed_ms`, the way home's
    last leg is a landing approach, flown at that air speed (ArduPlane's TECS_LAND_ARSPD: SITL flew its 400 m at
    18.4 m/s into 5 m/s of wind, 30 s where the survey's 12.5 m/s gave 53 s).

    Each leg is straight at its ground speed: a reversal between lines (`path_time`) is no shape of
    these ways (the way home to a landing's approach point and on to the touchdown into the wind was
    read as one, and a 688 m leg timed as a 9 s turn: ArduPlane SITL, 5 m/s from 0°, flew 65 s)."""
    climb, t_out = plane_way_out(leg_out, climb_m, climb_rate_ms, takeoff_speed_ms, k)
    t_back = _legs_time(leg_back, k)
    if landing_speed_ms is not None:
        approach = leg_back[-2:]
        t_back += _legs_time(approach, replace(k, speed_ms=landing_speed_ms)) - _legs_time(approach, k)
    descent = max(0.0, descent_time(climb_m, descent_rate_ms, "plane") - t_back)
    return t_out, t_back, climb, descent


#: Seconds ArduPlane takes to slow from its take-off's air speed to the survey speed the mission's DO_CHANGE_SPEED sets
#: after it (`plane_takeoff`): SITL, 8 m/s from 270°, 27.8 m/s at the climb's end, 17 m/s 6 s on, 12.5 m/s 15 to 17 s on
TAKEOFF_SLOWING_S = 15.0


def plane_climb_out_m(angle_deg: float, climb_m: float, climb_rate_ms: float, takeoff_speed_ms: float,
                      k: Kinematics) -> float:
    """How far over the ground a plane's take-off climbs along `angle_deg` (atan2(dy, dx) of the grid, degrees): its
    climb's time at the air speed `takeoff_speed_ms` in `k`'s wind (`plane_takeoff`)."""
    return climb_m / climb_rate_ms * replace(k, speed_ms=takeoff_speed_ms).ground_speed(angle_deg)


def takeoff_doubt_m(k: Kinematics) -> float:
    """How far from `plane_climb_out_m`'s end a plane's climb may end and reach its first waypoint either way (the
    L1 distance at up to twice the air speed over the ground): a take-off leg within this of its climb-out's length
    may be met from either side (`detours.approach_way`; ArduPlane SITL, 8 m/s against it: a 215 m climb-out
    reached a waypoint 220 m out from 39 m short of it and turned from there)."""
    return 2.0 * k.reach_m


@dataclass(frozen=True)
class PlaneTakeoff:
    """A plane's take-off as its way out is laid (`detours.approach_way`), in planning-grid metres (`grid_scale` of
    them a metre): the climb to `climb_m` at `climb_rate_ms` and the air speed `takeoff_speed_ms` in `k`'s wind. A
    copter's has no setback (`approach_setback_m`): its way out is not changed."""

    k: Kinematics
    climb_m: float
    climb_rate_ms: float
    takeoff_speed_ms: float
    grid_scale: float = 1.0

    def climb_out(self, angle_deg: float) -> float:
        """How far the climb goes over the ground along `angle_deg` (`plane_climb_out_m`)."""
        return plane_climb_out_m(angle_deg, self.climb_m, self.climb_rate_ms, self.takeoff_speed_ms, self.k) * self.grid_scale

    @property
    def setback(self) -> float:
        """How far behind a line's lead-in the approach point lies (`approach_setback_m`)."""
        return approach_setback_m(self.k) * self.grid_scale

    @property
    def doubt(self) -> float:
        """How near its climb-out's length a take-off leg may be met either way (`takeoff_doubt_m`)."""
        return takeoff_doubt_m(self.k) * self.grid_scale


def plane_way_out(leg_out: np.ndarray, climb_m: float, climb_rate_ms: float, takeoff_speed_ms: float,
                  k: Kinematics) -> tuple[float, float]:
    """A plane's way out (a polyline from the launch point to the survey's first waypoint, planning-grid units / grid
    scale): its take-off along the first leg (`plane_takeoff`), the other legs straight at their ground speeds, and
    the turn at its last corner where that is sharper than 90° (an approach point set behind the first line's lead-in,
    `detours.approach_way`) as `plane_reversal` flies it, from the leg before it (flown the other way where the
    take-off climbed past that leg's end and turned back to it). (climb s, after it s)"""
    climb, after = plane_takeoff(leg_out[:2], climb_m, climb_rate_ms, takeoff_speed_ms, k)
    after += _legs_time(leg_out[1:], k)
    if len(leg_out) < 3:
        return climb, after
    a, p, b = (np.asarray(x, float) for x in leg_out[-3:])
    d_in, d_out = p - a, b - p
    ahead, back = math.hypot(*d_in), math.hypot(*d_out)
    if len(leg_out) == 3:  # the take-off's leg: climbed past its end, the plane turned back to it
        climb_out = plane_climb_out_m(math.degrees(math.atan2(d_in[1], d_in[0])), climb_m, climb_rate_ms, takeoff_speed_ms, k)
        if climb_out > ahead:
            d_in, ahead = -d_in, climb_out - ahead
    if ahead <= KEPT or back <= KEPT or float(d_in @ d_out) >= 0.0:
        return climb, after
    a_in, a_out = math.degrees(math.atan2(d_in[1], d_in[0])), math.degrees(math.atan2(d_out[1], d_out[0]))
    (turned,) = plane_reversal(np.full(1, ahead), np.zeros(1), np.full(1, back), np.full(1, a_in), np.full(1, a_out), k)
    straight = (ahead * k.slowness(a_in) + back * k.slowness(a_out)) / k.speed_ms
    return climb, after + float(turned) - straight


def plane_takeoff(first_leg: np.ndarray, climb_m: float, climb_rate_ms: float, takeoff_speed_ms: float,
                  k: Kinematics) -> tuple[float, float]:
    """A plane's take-off towards the end of `first_leg` (two points; it is launched along it): the climb to
    `climb_m` at `climb_rate_ms`, straight ahead at the air speed `takeoff_speed_ms` in `k`'s wind (ArduPlane's
    NAV_TAKEOFF, at full throttle and its AIRSPEED_CRUISE until the mission's DO_CHANGE_SPEED), and the time from
    the climb's end to the leg's end at `k`'s speed. (climb s, after it s)

    A leg longer than the climb-out is flown on at its ground speed, the plane slowing evenly from the take-off's air
    speed to `k`'s over `TAKEOFF_SLOWING_S` (in 8 m/s against it, with an approach point 134 m on, the estimate
    without the slowing was 17 to 21 s long a sortie, 0.942 to 0.951). A shorter one is overshot: the plane turns
    back onto the leg's line and flies back to its end (`plane_reversal` onto a line 0 apart, its waypoint behind).
    ArduPlane SITL (AIRSPEED_CRUISE 22 m/s) climbed to 102 m in 14.8 s over 383 m with 5 m/s of wind behind
    it, and in 14.0 s over 259 m with 3.5 m/s against it (27 and 18.2 m/s over the ground at 22 m/s of air
    speed: 400 and 255 m), each past a first place 185 and 174 m ahead, timed before at the survey speed from
    the launch."""
    climb = climb_m / climb_rate_ms
    d = first_leg[-1] - first_leg[0]
    length = math.hypot(float(d[0]), float(d[1]))
    ahead = math.degrees(math.atan2(float(d[1]), float(d[0])))
    climb_out = plane_climb_out_m(ahead, climb_m, climb_rate_ms, takeoff_speed_ms, k)
    if length >= climb_out:
        return climb, _slowing_time(length - climb_out, ahead, takeoff_speed_ms, k)
    (back,) = plane_reversal(np.full(1, length - climb_out), np.zeros(1), np.zeros(1), np.full(1, ahead),
                             np.full(1, ahead + 180.0), k)
    return climb, float(back)


#: Simpson's rule over the take-off's slowing in this many panels: one read 9 m/s of crosswind on a 12 m/s plane slowing
#: from 25 m/s 1e-4 of its time off (a property test's case), up to 2.6e-3 over random winds; eight, under 2.3e-6
SLOWING_PANELS = 8


def _slowing_time(rest: float, angle_deg: float, takeoff_speed_ms: float, k: Kinematics) -> float:
    """Seconds over `rest` metres along `angle_deg` after the take-off's climb: the air speed falling evenly from
    `takeoff_speed_ms` to `k`'s over `TAKEOFF_SLOWING_S` (the ground covered by Simpson's rule over the ground speeds
    it makes, SLOWING_PANELS panels; the time within the slowing where `rest` is reached by bisection), then at `k`'s
    speed."""
    slow = max(takeoff_speed_ms - k.speed_ms, 0.0)

    def ground(t: float) -> float:
        return replace(k, speed_ms=takeoff_speed_ms - slow * t / TAKEOFF_SLOWING_S).ground_speed(angle_deg)

    def covered(t: float) -> float:
        g = [ground(t * i / (2 * SLOWING_PANELS)) for i in range(2 * SLOWING_PANELS + 1)]
        return t / (6 * SLOWING_PANELS) * (g[0] + g[-1] + 4.0 * sum(g[1:-1:2]) + 2.0 * sum(g[2:-1:2]))

    if slow == 0.0:
        return rest / k.ground_speed(angle_deg)
    whole = covered(TAKEOFF_SLOWING_S)
    if whole <= rest:
        return TAKEOFF_SLOWING_S + (rest - whole) / k.ground_speed(angle_deg)
    lo, hi = 0.0, TAKEOFF_SLOWING_S
    for _ in range(40):
        mid = (lo + hi) / 2.0
        lo, hi = (mid, hi) if covered(mid) < rest else (lo, mid)
    return (lo + hi) / 2.0


def _legs_time(points: np.ndarray, k: Kinematics) -> float:
    """The time along a polyline flown leg by leg, each straight at its ground speed (no turn)."""
    return sum(path_time(points[i:i + 2], k) for i in range(len(points) - 1))


def line_orders(n_lines: int, spacing: float, turn_radius: float, vehicle: str) -> list[list[int]]:
    """Candidate line orders: plain boustrophedon, and for planes whose turn diameter is
    larger than the spacing, interleaved skip-line orders (0, k, 1, k+1, …) so that most
    turns are at least 2R wide. The route flies the fastest of them (`route.order_pass`), each from
    either end and either way, and the heading search prices the same (`quick_cost`)."""
    orders = [list(range(n_lines))]
    if vehicle == "plane" and spacing < 2.0 * turn_radius and n_lines > 2:
        kmax = min(n_lines - 1, math.ceil(2.0 * turn_radius / spacing) + 1)
        for k in range(2, kmax + 1):
            order: list[int] = []
            for block in range(0, n_lines, 2 * k):
                lo = list(range(block, min(block + k, n_lines)))
                hi = list(range(block + k, min(block + 2 * k, n_lines)))
                for i in range(max(len(lo), len(hi))):
                    if i < len(lo):
                        order.append(lo[i])
                    if i < len(hi):
                        order.append(hi[i])
            orders.append(order)
    return orders


def quick_cost(segments: list[LineSegment], lead_in: float, k: Kinematics, frame: LineFrame) -> float:
    """Estimated time of the fastest way over the segments the route considers (`route.order_pass`): each
    of `line_orders` (the lines' spacing read off their ordinates), from either end and with the first line
    flown either way, every line from its lead-in to half a base past its last station, in their own line
    `frame` (the wind of `k`, on the planning grid, turned into it).

    Used to compare headings: it needs only the run ends.
    """
    k = k.in_frame(frame)
    by_line: dict[int, list[LineSegment]] = {}
    for s in segments:
        by_line.setdefault(s.line, []).append(s)
    lines = [sorted(by_line[line], key=lambda s: s.x0) for line in sorted(by_line)]
    spacing = (lines[-1][0].v - lines[0][0].v) / (len(lines) - 1) if len(lines) > 1 else math.inf
    best = math.inf
    for order in line_orders(len(lines), spacing, k.turn_radius_m, k.vehicle):
        for ordered in (order, order[::-1]):
            for first_dir in (1, -1):
                pts: list[tuple[float, float]] = []
                for i, line in enumerate(ordered):
                    d = first_dir if i % 2 == 0 else -first_dir
                    for s in lines[line] if d > 0 else lines[line][::-1]:
                        first, last = (s.x0, s.x1) if d > 0 else (s.x1, s.x0)
                        pts.extend([(first - d * lead_in, s.v), (first, s.v), (last + d * s.base / 2.0, s.v)])
                best = min(best, path_time(np.asarray(pts), k))
    return best


def _least_gain(d: np.ndarray, k: Kinematics) -> tuple[np.ndarray, float]:
    """Per run length d: the least G(x) = t(x) − x/v of a copter's straight run
    (`_straight_time`) over every x ≥ d; and the least over every x > 0. G is T(v)
    (`_speed_change_time`) from D = v·T(v) on, and concave below D (t is: its slope 2/(2u + a²/J)
    falls as the peak speed u rises, 2/(3u) below u = a²/J), rising from 0 at x = 0 to T(v) at D:
    so the least over x ≥ d is min(G(d), T(v)), and over x > 0 it is 0."""
    v = k.speed_ms
    top = _speed_change_time(v, k.accel_ms2, k.jerk_ms3)
    d = np.maximum(np.asarray(d, float), 0.0)
    here = np.full(len(d), top)
    short = np.flatnonzero(d < v * top)
    here[short] = [min(_straight_time(x, k) - x / v, top) for x in d[short].tolist()]
    return here, 0.0


def _connector_ahead(lb: LineBounds, i: np.ndarray, j: np.ndarray, lead_in: float,
                     base: float) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """How far the connector from sure line i to sure line j (flown the other way) runs ahead,
    along line i's direction of flight, as (least, most), line i flown to the right (+x: from its
    last station + base/2 to line j's last station + lead_in) and to the left (from its first
    station − base/2 to line j's first station − lead_in)."""
    right = (lb.last_lo[j] + lead_in - lb.last_hi[i] - base / 2.0, lb.last_hi[j] + lead_in - lb.last_lo[i] - base / 2.0)
    left = (lb.first_lo[i] - base / 2.0 - lb.first_hi[j] + lead_in, lb.first_hi[i] - base / 2.0 - lb.first_lo[j] + lead_in)
    return right, left


def connector_stops(lb: LineBounds, i: np.ndarray, j: np.ndarray, lead_in: float, base: float) -> np.ndarray:
    """Per pair of sure lines (i, j) of a heading: is a copter surely stopped at both corners of
    the connector from line i to line j (each turn sharper than CORNER_DEG), whichever way the two
    lines are flown (see quick_cost_lower_bounds)? (j, i): the connector from line j back to line i."""
    dv = np.abs(lb.v[j] - lb.v[i])
    cot = 1.0 / math.tan(math.radians(CORNER_DEG)) * (1.0 - 1e-6)
    stops = np.ones(len(i), bool)
    for lo, hi in _connector_ahead(lb, i, j, lead_in, base):
        stops &= (hi < dv * cot) & (lo > -dv * cot)
    return stops


def quick_cost_lower_bounds(lb: LineBounds, lead_in: float, base: float, k: Kinematics) -> np.ndarray:
    """Per heading of `lb`: a proven lower bound of `quick_cost(build_lines(...), lead_in, k, frame)`.

    The path quick_cost times is, line after line (those with runs, by ordinate), the line's
    part P (lead-in, stations, half a base past the last run, all on the line, backwards
    between runs that overlap) and a connector to the next line, at least Δv long. For a line
    sure to exist, P runs from before its first station to past its last one: it is at least
    λ = extent + lead_in + base/2 long.

    Copter (t = d/v + G(d) per stop-to-stop run, G ≥ least_gain; a stretch between stops flown on
    through its waypoints takes at least a run of its whole length: tests/plan/test_copter_chain.py):
    every leg is along the line
    but the connectors, so a stop within P is a reversal (two corners of 180°: ≥ 3 runs, G ≥ 3m,
    m = least_gain(0)); otherwise P lies in one run of length ≥ λ. A connector's two corners
    add up to 180°, so at least one is a stop: either both are (the connector is a run of
    its own: Δv/v + least_gain(Δv)), or it turns by ≤ 30° into a line, so it is at least 2Δv
    long. Where both corners are surely sharper than 30°, whichever way the two lines are flown,
    the connector is a run of its own: it runs from line i's end (its last station + base/2 flown
    to the right, its first − base/2 to the left: a line's runs lie apart, so its last run ends
    at its outermost station) to line j's lead-in (its last station + lead_in, its first −
    lead_in), and the bounds of those stations bound how far it runs ahead along line i (a
    corner is sharper than 30° when that is below Δv·cot 30° out of line i and above −Δv·cot 30°
    into line j; the segments before and after it run along the lines). Runs of different lines
    and those connector runs are distinct, hence the sum.
    Between two sure lines with unsure ones between them there is at least one connector and
    they add up to the ordinate difference; each connector has G ≥ m or the extra length ≥ Δv.

    The lines are flown in any of `line_orders`, from either end, the first line either way (quick_cost
    prices the fastest): the copter's connectors join the same neighbouring lines in the plain order and its
    reverse, so a connector's corners are checked both ways (`connector_stops` of (i, j) and of (j, i)).

    Plane: path_time times each straight leg at its ground speed, at most G = v + |w| (v/`least_slowness`), and
    replaces a reversal (a corner, the leg between, a corner, their turns adding up to more than 150°) and the leg
    after it by `plane_reversal`: its stretch (≥ 0), its half circle T = πR/v (`plane_turn_time`) and the straight
    way from the turn's end to the leg's end, at least a = max(0, that leg − reach·G/v − |w|·T − 2R·|w|/v) long
    (along the line: the half circle's 2R across the nose lies at most 2R·|w|/v along it) and at least
    |offset| − 2R − |w|·T (across it). With lead_in > 0 every line's part begins with its
    lead-in straight on into its first station (no corner), so the corners pair as laid: each connector between
    two lines (flown opposite ways, its two corners add up to 180°) and the next line's lead-in are a reversal;
    within a line, a connector back to the next run's lead-in (180° and 180°) and that lead-in are one over 0.
    From its first station on, a line of one run (lb.single) is at least extent + base/2 long; one of more runs
    that (its runs joined straight on) or two half bases and a reversal over 0 between them (T + a/G). Of any
    order, the reversals between lines are at least (sure lines − 1) (C; the first line's lead-in counts 0),
    their offsets add up to at least the sure lines' span, and each is at least T + max(a, |offset| − 2R −
    |w|·T)/G: together at least C·T + max(C·a, span − C·(2R + |w|·T))/G (more reversals only add: both terms
    grow with C, as πR > 2R). With lead_in = 0 the corners may pair otherwise: a connector counts at least its
    offset over G (a reversal's T + (|offset| − 2R − |w|·T)/G is no less, as v·T = πR ≥ 2R), so together at
    least the span.

    A copter's runs are timed by their lengths times their slowness (≥ 1) and a run's time grows with its length,
    with the same corners: its bound holds as it is in wind.
    """
    frames = int(lb.heading.max()) + 1 if len(lb.heading) else 0
    exists = np.flatnonzero(lb.exists)
    hid, v, speed = lb.heading, lb.v, k.speed_ms
    lam = lb.extent[exists] + lead_in + base / 2.0
    i, j = exists[:-1], exists[1:]
    pair = hid[i] == hid[j]  # consecutive sure lines of one heading
    i, j = i[pair], j[pair]
    dv = v[j] - v[i]
    # with only surely empty lines between them, the connector joins them
    unknown = np.cumsum(~lb.exists & ~lb.absent)
    joined = unknown[j] == unknown[i]

    def per_heading(at: np.ndarray, values: np.ndarray) -> np.ndarray:
        return np.bincount(hid[at], weights=values, minlength=frames).astype(float)  # float when empty too

    if k.vehicle == "copter":
        gain, m = _least_gain(np.concatenate([lam, dv[joined]]), k)
        same = hid[1:] == hid[:-1]
        gap = float(np.min(np.diff(v)[same])) if same.any() else 0.0  # no two lines of a heading are closer
        total = per_heading(exists, lam / speed + np.minimum(gain[:len(lam)], 3.0 * m))
        # a joined connector whose corners are surely both sharper than 30°, whichever way the two
        # lines are flown, is a run of its own (see the docstring)
        stops = connector_stops(lb, i, j, lead_in, base) & connector_stops(lb, j, i, lead_in, base)
        own = dv[joined] / speed + gain[len(lam):]
        total += per_heading(i[joined], np.where(stops[joined], own, np.minimum(own, 2.0 * dv[joined] / speed)))
        total += per_heading(i[~joined], dv[~joined] / speed + min(m, gap / speed))
        return total * (1.0 - 1e-7)  # (in wind a copter's every metre takes at least as long: least_slowness is 1)
    # plane: the sure lines' parts and the reversals between them, whatever the order (see the docstring)
    radius = k.turn_radius_m
    if not len(exists):
        return np.zeros(frames)
    first = np.flatnonzero(np.r_[True, hid[exists[1:]] != hid[exists[:-1]]])
    last = np.r_[first[1:], len(exists)] - 1
    span = per_heading(exists[first], v[exists[last]] - v[exists[first]])
    if lead_in <= 1e-6:
        return span / speed * k.least_slowness * (1.0 - 1e-7)
    # the fastest ground speed, and what a reversal and the lead-in after it take at least (see the docstring)
    fastest, wind = speed / k.least_slowness, math.hypot(k.wind_x, k.wind_y)
    turn = plane_turn_time(k)
    lead_least = max(0.0, lead_in - k.reach_m * fastest / speed - wind * turn - 2.0 * radius * wind / speed)
    across = 2.0 * radius + wind * turn
    rest = lb.extent[exists] + base / 2.0  # a line's part from its first station on
    line = np.where(lb.single[exists], rest * k.least_slowness / speed,
                    np.minimum(rest * k.least_slowness / speed, base * k.least_slowness / speed + turn + lead_least / fastest))
    connectors = per_heading(exists[first], last - first)
    total = per_heading(exists, line) + connectors * turn + np.maximum(connectors * lead_least, span - connectors * across) / fastest
    return total * (1.0 - 1e-7)
