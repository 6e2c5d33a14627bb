"""The orbit (structure scan): rings round the [structure]'s footprint at a stand-off, one pass
per layer between the structure's base and top, the camera turned to the structure.

- The ring is the footprint grown by `pattern.standoff_m` with round joins (a buffer): every
  vertex of it is the stand-off from the footprint, its chords round a corner at most
  `RING_SAG_M` inside it, and round a corner the camera keeps looking at the corner. The chords
  are as long as that allows: ArduCopter flies a chain of short legs at the peak speed of a
  stop-to-stop run over one (in SITL round a 10 m tower 12 m off, 16 chords a quarter circle
  flew the ring at 0.81 m/s, 4 at 1.81 m/s, for 5.34 m/s planned; `flight_time.path_time`
  times it so). It starts at its northmost point and
  is flown clockwise seen from above, one way only (`Pass.one_way`). The camera looks at the
  footprint's nearest point (`Aim.outline`): square to the wall along a side of the ring, at the
  corner round a round join, continuously round the ring (at a side's end both are the same
  bearing). The copter's nose turns smoothly round the ring where the chords turn it by steps, so
  a camera turned 90° right of the flight was up to 14° off next to the ring's vertices in SITL;
  the flight program holds an earth-frame yaw along each side and a region of interest at the
  corner round each join (mission/program.py).
- The camera is pitched by `pattern.pitch_deg`, level (0) at the highest. By default it is
  pitched down as far as keeps a ground footprint for every photo (every edge of the image at
  least `capture.MIN_DEPRESSION_DEG` below the horizon: −(half the image's vertical angle +
  that)), so the highest layer looks down on the roof. A higher pitch, level included, is
  allowed: its photos have no ground footprint (`capture.bounded_footprints`: plan.geojson
  writes their points with the reason, and no ground coverage is claimed for them), and the
  structure-faces rule proves the walls. On a wall at the stand-off s a photo covers the
  heights from s·tan(−pitch − v) to s·tan(−pitch + v) below the camera (v: half the vertical
  angle; negative: above it): the band (`WallBand`).
- Layers: the band less `targets.side_overlap` is the layer spacing; layers = ceil((top −
  base) / spacing), the first band's middle half a spacing above the base (QGroundControl's
  StructureScan), each flown where its band's middle is at its height, from `pattern.start`
  ("bottom" or "top"). The highest layer flies above the top and sees the roof down to the
  band's upper angle: a roof wider than about 2·s·tan(upper angle) … is the structure-faces
  rule's to judge (a wider roof needs a nadir grid, which this pattern does not fly).
- Stations a photo base apart along the ring (`polyline.stations_along`), the base from the
  image's width on the wall where the band is nearest and `targets.forward_overlap`.
- Heights: a layer at z above the structure's ground flies `z − the plan's height` above the
  plan's height (`Pass.rise_m`; the structure's ground: the launch point's, or over a DEM the lowest
  under its footprint, `stands_on`); the
  height cap is checked per station by the altitude step.
- Each pass says it goes round the structure (`Pass.ring`: the ring and the stand-off), which
  the exporters lay as their client's structure scan (QGroundControl's Structure Scan item); a
  ring the exclusion zones cut into pieces says nothing of the kind.
- The structure is an obstacle: the rings, the lead-ins before them and the ends after them lie
  on or outside the ring (the ring starts where its tangent is a supporting line), so every leg
  of the pattern keeps the stand-off; the ways from and back to the launch point go round the
  footprint grown by the stand-off less `CLEARANCE_ALLOWANCE_M` (what tracking may take off
  it: `Layout.obstacle`), and a launch point inside that is refused.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from aerosurvey.errors import InputError
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.bounds import GridBounds, minimum_width
from aerosurvey.plan.capture import MIN_DEPRESSION_DEG
from aerosurvey.plan.layout import Field, Layout
from aerosurvey.plan.passes import Aim, Pass, Ring, Strip
from aerosurvey.plan.polyline import stations_along, strips_clear_of
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.sensor import Footprint, SensorSolution
from aerosurvey.plan.site import Site

if TYPE_CHECKING:
    from aerosurvey.plan.model import Heights, Plan
    from aerosurvey.spec import FlightSpec, MissionSpec

#: how far (metres) the vehicle's tracking may take it inside its ring: every leg keeps
#: `standoff_m − CLEARANCE_ALLOWANCE_M` from the footprint
CLEARANCE_ALLOWANCE_M = 2.0
#: how far (metres) a ring's chords round a corner may come inside the stand-off
RING_SAG_M = 0.25
#: the steepest ray of the image (degrees below the horizon) a wall band may reach: steeper, the
#: band's foot runs away down the wall
MAX_RAY_DEPRESSION_DEG = 80.0


@dataclass(frozen=True)
class OrbitOptions:
    standoff_m: float
    start: str  # "bottom" or "top"
    pitch_deg: float | None  # None: the highest that keeps a ground footprint (`WallBand.highest_pitch_deg`)


@dataclass(frozen=True)
class WallBand:
    """What a photo covers of a wall square in front of it at the stand-off, the camera pitched
    down or level: the heights (metres below the camera, negative above it) its image's top and
    bottom rows meet, and its width along the wall where it is narrowest (the top row, nearest
    along the camera's axis)."""

    pitch_deg: float
    top_below_m: float
    foot_below_m: float
    width_m: float

    @property
    def height_m(self) -> float:
        return self.foot_below_m - self.top_below_m

    @property
    def middle_below_m(self) -> float:
        return (self.foot_below_m + self.top_below_m) / 2.0

    @staticmethod
    def tangents(spec: MissionSpec) -> tuple[float, float]:
        """The tangents of half the image's horizontal and vertical angles, the camera's top up
        (the mount's across- and along-track sides)."""
        across, along = pg.footprint(1.0, spec.camera.camera, spec.camera.mount)
        return float(across) / 2.0, float(along) / 2.0

    @classmethod
    def highest_pitch_deg(cls, spec: MissionSpec) -> float:
        """The highest pitch (whole degrees) that keeps the image's corners MIN_DEPRESSION_DEG below
        the horizon (a ground footprint for every photo; the orbit's default): a ray through a top
        corner points sin(q − v) / (cos v · √(1 + tu² + tv²)) down (q the axis' depression, v half
        the vertical angle)."""
        tu, tv = cls.tangents(spec)
        v = math.atan(tv)
        lift = math.asin(math.sin(math.radians(MIN_DEPRESSION_DEG)) * math.cos(v) * math.sqrt(1.0 + tu * tu + tv * tv))
        return -float(math.ceil(math.degrees(v + lift) - 1e-9))

    @classmethod
    def of(cls, spec: MissionSpec) -> WallBand:
        o = spec.pattern.options
        assert isinstance(o, OrbitOptions)
        tu, tv = cls.tangents(spec)
        v = math.degrees(math.atan(tv))
        pitch = cls.highest_pitch_deg(spec) if o.pitch_deg is None else o.pitch_deg
        if pitch > 0.0 or -pitch + v > MAX_RAY_DEPRESSION_DEG:
            raise InputError(f"pattern.pitch_deg = {pitch:g} is not allowed for this camera: allowed "
                             f"{v - MAX_RAY_DEPRESSION_DEG:.1f} .. 0 (the image's foot at most "
                             f"{MAX_RAY_DEPRESSION_DEG:g}° below the horizon)", key="pattern.pitch_deg")
        bottom, top, width = band_on_face(o.standoff_m, 90.0, pitch, (tu, tv))
        return cls(pitch, -top, -bottom, width)


def band_on_face(standoff_m: float, face_deg: float, pitch_deg: float, tangents: tuple[float, float]) -> tuple[float, float, float]:
    """What a photo covers of a plane face at `face_deg` from the horizontal, square in front of it at
    `standoff_m`, the camera's axis at `pitch_deg` (level at 0) and the tangents of half its image's
    horizontal and vertical angles `tangents` (`WallBand.tangents`): the slope positions (metres up the
    face from the foot of the camera's perpendicular on it) its image's bottom and top rows meet, and its
    narrowest width along the face. The axis lies δ = pitch + 90° − face angle above the face's inward
    normal; a row β off the axis meets the face at range s / cos(δ + β), cos β of that along the axis, and
    an image row meets the face along a level line, 2·tan(horizontal half angle) times that wide (the
    narrowest: the row nearest along the axis). One model for walls (90°) and inclined faces."""
    tu, tv = tangents
    s, d, h = standoff_m, math.radians(pitch_deg + 90.0 - face_deg), math.atan(tv)
    depth = min(math.cos(h) / math.cos(d - h), math.cos(h) / math.cos(d + h)) * s
    return s * math.tan(d - h), s * math.tan(d + h), 2.0 * tu * depth


def layer_heights(base_m: float, top_m: float, spacing_m: float) -> np.ndarray:
    """The layers' heights on the wall: ceil((top − base) / spacing) of them a spacing apart, the
    first half a spacing above the base (QGroundControl's StructureScan)."""
    n = max(1, math.ceil((top_m - base_m) / spacing_m - 1e-9))
    out: np.ndarray = base_m + spacing_m * (np.arange(n) + 0.5)
    return out


def ring(footprint: Polygon, standoff: float) -> np.ndarray:
    """The footprint grown by `standoff` (planning metres), round joins in chords that come at most
    `RING_SAG_M` inside it, as a closed path from its northmost point clockwise (seen from above)."""
    chord_deg = 2.0 * math.degrees(math.acos(1.0 - min(RING_SAG_M / standoff, 1.0)))
    grown = shapely.buffer(footprint, standoff, quad_segs=max(1, math.ceil(90.0 / chord_deg)))
    xy = np.asarray(orient(grown, -1.0).exterior.coords, float)[:-1]
    k = int(np.argmax(xy[:, 1]))
    path: np.ndarray = np.vstack([xy[k:], xy[:k + 1]])
    return path


@dataclass(frozen=True)
class Orbit:
    settings: OrbitOptions
    band: WallBand
    base_m: float
    top_m: float

    kind: ClassVar[str] = "orbit"
    title: ClassVar[str] = "orbit (structure scan: rings round the [structure])"
    area_is_centreline: ClassVar[bool] = False
    nose_turns_camera: ClassVar[bool] = False
    fields: ClassVar[tuple[Field, ...]] = (
        Field("standoff_m", "Stand-off (m)", "number", 15.0, lo=CLEARANCE_ALLOWANCE_M + 1.0, hi=500.0,
              hint="Distance from the structure's footprint to the rings"),
        Field("start", "Start", "choice", "bottom", choices=(("bottom", "the lowest layer"), ("top", "the highest layer")),
              hint="Which layer is flown first"),
        Field("pitch_deg", "Camera pitch (°)", "number", None, lo=-80.0, hi=0.0,
              hint="Gimbal pitch (-90 straight down, 0 level); default: the highest that keeps the photos' ground footprints"),
    )

    @classmethod
    def stands_on(cls, site: Site) -> BaseGeometry | None:
        return site.structure  # its layers are above the ground under the footprint

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        return None, None

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> OrbitOptions:
        pitch = values.get("pitch_deg")
        return OrbitOptions(float(values["standoff_m"]), str(values["start"]), None if pitch is None else float(pitch))

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Orbit:
        assert isinstance(spec.pattern.options, OrbitOptions)
        if spec.structure is None:
            raise InputError("pattern.kind = 'orbit' needs a [structure] table (its footprint, base_m and top_m): "
                             "the rings go round it", key="pattern.kind")
        if spec.terrain.mode not in ("none", "fixed"):
            raise InputError(f"terrain.mode = {spec.terrain.mode!r} is not allowed with pattern.kind = 'orbit' (its layers "
                             "are level rings at heights above the ground the structure stands on); allowed: 'fixed' (with "
                             "a DEM: above the lowest ground under its footprint) or 'none' (no DEM: the launch point's "
                             "ground)", key="terrain.mode")
        return cls(spec.pattern.options, WallBand.of(spec), spec.structure.base_m, spec.structure.top_m)

    @classmethod
    def footprint(cls, spec: MissionSpec, heights: Heights) -> Footprint:
        """A photo on a wall at the stand-off: its narrowest width along the ring (the photo base is
        laid from it), its band's height up the wall (the layer spacing)."""
        band = WallBand.of(spec)
        return Footprint(across_m=band.height_m, along_m=band.width_m)

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> GridBounds:
        """The layers, and on each a photo a base apart along the footprint's outline (the ring is
        longer): the fewest any scan of the walls at this stand-off flies."""
        assert site.structure is not None and spec.structure is not None
        layers = len(layer_heights(spec.structure.base_m, spec.structure.top_m, sensor.spacing_m))
        per_layer = math.ceil(site.structure.length / site.grid_scale / sensor.base_m)
        return GridBounds(float(minimum_width(site.structure)) / site.grid_scale, layers, layers * per_layer)

    @classmethod
    def parameters(cls, plan: Plan) -> dict[str, Any]:
        o = plan.pattern.options
        assert isinstance(o, OrbitOptions)
        return {"standoff_m": o.standoff_m, "start": o.start, "pitch_deg": plan.layout.passes[0].aim.pitch_deg,
                "layers": len(plan.layout.passes), "clearance_allowance_m": CLEARANCE_ALLOWANCE_M}

    def layouts(self, site: Site, sensor: SensorSolution, report: Progress) -> Iterator[Layout]:
        assert site.structure is not None, "an orbit is laid round [structure] (Orbit.from_spec refuses a spec without one)"
        k = site.grid_scale
        path = ring(site.structure, self.settings.standoff_m * k)

        def autopilot_m(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            lon, lat = site.planar.lonlat(np.r_[a[:, 0], b[:, 0]], np.r_[a[:, 1], b[:, 1]])
            return np.asarray(pg.ardupilot_distance_m(lon[:len(a)], lat[:len(a)], lon[len(a):], lat[len(a):]), float)

        length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
        at = stations_along(path, autopilot_m, sensor.base_m, length - sensor.base_m * k / 2.0, sensor.trigger_distance_m,
                            sensor.speed.speed_ms / pg.TRIGGER_CHECK_HZ)
        strips: tuple[Strip, ...] = tuple(strips_clear_of(0, 0, 0, path, at, site.zones_buffered, 0.0))
        if not strips:
            raise InputError("the orbit's ring lies inside the exclusion zones: nothing of it can be flown", key="pattern.standoff_m")
        heights = layer_heights(self.base_m, self.top_m, sensor.spacing_m) + self.band.middle_below_m
        if self.settings.start == "top":
            heights = heights[::-1]
        # square to the wall on a side of the ring, at the corner round a join: every point of the ring is the
        # stand-off from that nearest point, so the pitch is the band's all round
        outline = tuple((float(x), float(y)) for x, y in np.asarray(site.structure.exterior.coords)[:-1])
        aim = Aim(self.band.pitch_deg, outline=outline)
        plan_h = sensor.heights.nominal_agl_m
        # a ring the zones cut into pieces is no longer flown round in one go
        around = Ring(path[:-1], self.settings.standoff_m) if len(strips) == 1 else None
        passes = tuple(Pass(i + 1, strips=strips, aim=aim, rise_m=float(z) - plan_h, one_way=True, ring=around)
                       for i, z in enumerate(heights))
        # what the photos cover is the structure's faces: the structure-faces rule proves them (plan/surfaces.py)
        keep_out = shapely.buffer(site.structure, (self.settings.standoff_m - CLEARANCE_ALLOWANCE_M) * k)
        yield Layout(0.0, f"rings at {self.settings.standoff_m:g} m round the structure", passes, site.structure, 0.0,
                     obstacle=keep_out)


__all__ = ["CLEARANCE_ALLOWANCE_M", "Orbit", "OrbitOptions", "WallBand", "layer_heights", "ring"]
