"""The pass and run types: a pass (`Pass`) of strips (`Strip`) the route step orders, and what it
makes of them: the photo runs as flown (`Run`) and the route (`Route`: runs and `Waypoint`s), all in
the planning CRS, as plain frozen data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely

from aerosurvey import ids
from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.lines import LineSegment


@dataclass(frozen=True)
class Aim:
    """Where the camera looks: its pitch (gimbal convention: −90 straight down, 0 level) and its
    look, one of four:

    - along the flight, turned by `turn_deg` (0 ahead, 90 to the right, −90 to the left): the
      camera follows the track through its bends (a mount's yaw relative to the nose);
    - at a grid bearing `bearing_deg` (the planning CRS's; the flight program turns it into a
      true bearing at each place, `Planar.true_bearing`);
    - at a point `point` (planning CRS): the camera turned to it from every station, pitched so
      that from the run's first station it looks at `pitch_deg` (the point's height is where that
      ray meets its vertical: the region of interest an autopilot is given);
    - at the nearest point of an outline `outline` (a polygon's vertices, planning CRS): square to
      its side where a station faces a side, at its corner round a corner (a structure's footprint
      seen from a ring at a stand-off round it: the look turns continuously round the ring, at one
      pitch, the distance being the stand-off everywhere)."""

    pitch_deg: float = -90.0
    turn_deg: float = 0.0
    bearing_deg: float | None = None
    point: tuple[float, float] | None = None
    outline: tuple[tuple[float, float], ...] | None = None

    def __post_init__(self) -> None:
        if (self.bearing_deg is not None) + (self.point is not None) + (self.outline is not None) > 1:
            raise ValueError(f"an aim looks at a bearing, at a point or at an outline, one of them: {self}")
        if self.outline is not None and len(self.outline) < 3:
            raise ValueError(f"an aim's outline is a polygon of three vertices or more: {self}")
        if self.turn_deg and (self.bearing_deg is not None or self.point is not None or self.outline is not None):
            raise ValueError(f"an aim is turned from the flight only when it looks along it: {self}")
        if not -90.0 <= self.pitch_deg <= 30.0 or not math.isfinite(self.pitch_deg):
            raise ValueError(f"an aim's pitch is -90..30 degrees: {self}")
        if self.point is not None and self.pitch_deg == NADIR_PITCH_DEG:
            raise ValueError(f"an aim at a point looks at it from the side: a pitch above -90: {self}")

    @property
    def look(self) -> str:
        """"along", "bearing", "point" or "outline"."""
        if self.outline is not None:
            return "outline"
        return "point" if self.point is not None else "bearing" if self.bearing_deg is not None else "along"

    @property
    def nadir(self) -> bool:
        return self.pitch_deg == NADIR_PITCH_DEG

    def bearings(self, xy: np.ndarray, headings: np.ndarray) -> np.ndarray:
        """The grid bearing the camera looks to at each station (`xy` (n, 2), `headings` the
        direction of flight there, grid bearings)."""
        if self.point is not None or self.outline is not None:
            at = np.asarray(xy, float).reshape(-1, 2)
            d = (np.asarray(self.point, float) if self.point is not None else self.nearest(at)) - at
            out: np.ndarray = np.degrees(np.arctan2(d[:, 0], d[:, 1])) % 360.0
            return out
        if self.bearing_deg is not None:
            return np.full(len(headings), self.bearing_deg % 360.0)
        return (np.asarray(headings, float) + self.turn_deg) % 360.0

    def nearest(self, xy: np.ndarray) -> np.ndarray:
        """The nearest point of the aim's outline to each place `xy` (n, 2) outside it."""
        assert self.outline is not None
        lines = shapely.shortest_line(shapely.points(np.asarray(xy, float).reshape(-1, 2)), shapely.Polygon(self.outline))
        out: np.ndarray = shapely.get_coordinates(lines).reshape(-1, 2, 2)[:, 1]
        return out


#: the camera's pitch looking straight down
NADIR_PITCH_DEG = -90.0
#: straight down, the image's top ahead: a survey's mount
NADIR = Aim()


@dataclass(frozen=True, eq=False)
class Strip:
    """A photo strip in world geometry (planning CRS), in line order: the polyline the camera
    flies along from its first station to its last, and the stations on it. A corridor's strips
    bend where its centreline does."""

    line: int  # index of the strip in its pass
    part: int  # index of the piece of the line (cut by exclusion zones)
    path: np.ndarray  # (m ≥ 2, 2): the first station, the bends, the last station
    stations: np.ndarray  # (n, 2)
    station_index: np.ndarray  # (n,) index of each station along its line, for ids
    heading_deg: np.ndarray  # (n,) the strip's direction at each station (compass bearing), in line order
    bend_after: np.ndarray  # (m − 2,) for each bend, the station (index into `stations`) it follows
    # (n,) each station's height above its pass's (`Pass.rise_m`), in line order: a lane flown up or
    # down in front of a wall; None: every station at its pass's height
    rise_m: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Ring:
    """A pass flown round a structure: its one strip goes once round `path`, the structure's
    outline grown by `standoff_m` (ground metres), flown clockwise seen from above (the structure
    on the right) from the strip's first station, and the camera is turned to the structure. What
    a writer needs to lay the ring again as its client does (QGroundControl's Structure Scan:
    mission/formats/qgc_survey.py)."""

    path: np.ndarray  # (n ≥ 3, 2) planning CRS: the ring's vertices from the first station, open (not repeated)
    standoff_m: float


@dataclass(frozen=True, eq=False)
class Pass:
    """A group of strips flown one after another, with the camera held at one aim, at one height
    (the plan's, raised by `rise_m`; a strip's stations each further by its `Strip.rise_m`), and
    the hint the route step needs to order them. With `looks` the camera is turned at each station
    through `aim` and then each look, one photo each: every look is a station of its own
    (`ids.look_pass_index` numbers its pass).

    An area grid's pass is parallel lines in a frame (`frame` and `segments`): the route searches
    the line order and cells. Any other pattern gives `strips`, flown in their order, back and
    forth (each line the other way from the one before), or each its own way when `one_way`."""

    index: int  # 1 for the main pass, 2 for the cross-hatch, …
    frame: LineFrame | None = None
    segments: tuple[LineSegment, ...] = ()
    strips: tuple[Strip, ...] = ()
    aim: Aim = NADIR
    rise_m: float = 0.0  # how far above the plan's flying height (Heights) the pass flies
    one_way: bool = False  # strips flown each its own way only (a ring whose camera is turned to its inside)
    ring: Ring | None = None  # the pass goes round a structure (its one strip is this ring)
    looks: tuple[Aim, ...] = ()  # further aims shot in turn at each station after `aim` (the camera turned at rest)
    # its strips' straight approach and how far past its last station each run ends, where the route's (a copter's
    # stopping distance or the nose's turn; half a photo base, the distance trigger's) do not hold: a wall's lane flown
    # up or down, shot at rest, ends at its last station and the next is flown to from there; None: the route's
    lead_in_m: float | None = None
    end_m: float | None = None

    @property
    def empty(self) -> bool:
        return not self.segments and not self.strips

    @property
    def aims(self) -> tuple[Aim, ...]:
        """The aims shot in turn at each station: `aim`, then the `looks`."""
        return (self.aim, *self.looks)


@dataclass(frozen=True, eq=False)
class Run:
    """One photo run as flown: stations in flight order, in the planning CRS."""

    pass_index: int
    line: int
    part: int
    direction: int  # +1 along the line (the frame's +x, a strip's order), −1 against it
    heading_deg: float  # direction of flight at the first station (compass bearing)
    station_xy: np.ndarray  # (n, 2), flight order
    station_index: np.ndarray  # index of each station along its line (by +x), for ids
    lead_in_xy: tuple[float, float]
    end_xy: tuple[float, float]  # past the last station by half a photo base
    bends_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (k, 2) flight order
    bend_after: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # the station (flight order) each follows
    station_heading_deg: np.ndarray | None = None  # (n,) where the run bends; None: heading_deg throughout
    aim: Aim = NADIR
    rise_m: float = 0.0  # its pass's
    looks: tuple[Aim, ...] = ()  # its pass's
    station_rise_m: np.ndarray | None = None  # (n,) flight order: each station's height above `rise_m` (its strip's); None: 0

    @property
    def aims(self) -> tuple[Aim, ...]:
        """The aims shot in turn at each station: `aim`, then the `looks`."""
        return (self.aim, *self.looks)

    def headings(self) -> np.ndarray:
        """The direction of flight at each station."""
        if self.station_heading_deg is not None:
            return self.station_heading_deg
        return np.full(len(self.station_xy), self.heading_deg)

    def rises(self) -> np.ndarray:
        """How far above the plan's flying height (Heights) each station is, in flight order: the
        pass's `rise_m`, and a lane flown up or down its own station's."""
        out = np.full(len(self.station_xy), self.rise_m)
        return out if self.station_rise_m is None else out + self.station_rise_m


def aims_per_place(runs: tuple[Run, ...]) -> int:
    """How many aims every run shoots at each of its places (its station rows at a place): one
    number for the whole route (ValueError when the runs differ)."""
    counts = {len(r.aims) for r in runs}
    if len(counts) > 1:
        raise ValueError(f"the runs shoot {sorted(counts)} aims at a place: one count for a route")
    return counts.pop() if counts else 1


def look_pass(runs: tuple[Run, ...], pass_index: int, look: int) -> int:
    """The pass number of look `look` (0: the pass's own aim) of pass `pass_index` in a route of
    `runs` (`ids.look_pass_index`, after the route's highest pass number)."""
    return ids.look_pass_index(pass_index, look, max((r.pass_index for r in runs), default=pass_index))


@dataclass(frozen=True)
class Waypoint:
    x: float
    y: float
    kind: str  # lead_in, line_start, bend, line_end, detour
    run: int  # index into Route.runs, −1 for detours


@dataclass(frozen=True)
class Route:
    runs: tuple[Run, ...]
    waypoints: tuple[Waypoint, ...]
    strategy: tuple[str, ...]  # per pass: lines across the area, or cells
