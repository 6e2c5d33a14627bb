"""The pass and run types: a pass (`Pass`) of strips (`Strip`) the route step orders, and what it
makes of them: the photo runs as flown (`Run`) and the route (`Route`: runs and `Waypoint`s), all in
the planning CRS, as plain frozen data.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aerosurvey.plan.frame import LineFrame
from aerosurvey.plan.lines import LineSegment


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


@dataclass(frozen=True, eq=False)
class Pass:
    """A group of strips flown one after another, with the camera held at one attitude, and the
    hint the route step needs to order them.

    An area grid's pass is parallel lines in a frame (`frame` and `segments`): the route searches
    the line order and cells. Any other pattern gives `strips`, flown in their order, back and
    forth (each line the other way from the one before)."""

    index: int  # 1 for the main pass, 2 for the cross-hatch, …
    frame: LineFrame | None = None
    segments: tuple[LineSegment, ...] = ()
    strips: tuple[Strip, ...] = ()
    pitch_deg: float = -90.0  # the camera's pitch (gimbal convention: −90 straight down)
    look_deg: float | None = None  # the bearing the camera looks to; None: along the flight

    @property
    def empty(self) -> bool:
        return not self.segments and not self.strips


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
    pitch_deg: float = -90.0
    look_deg: float | None = None  # the camera's bearing; None: along the flight

    def headings(self) -> np.ndarray:
        """The direction of flight at each station."""
        if self.station_heading_deg is not None:
            return self.station_heading_deg
        return np.full(len(self.station_xy), self.heading_deg)


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
