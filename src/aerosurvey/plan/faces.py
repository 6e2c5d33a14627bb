"""Faces and facades: lanes along inclined faces (an open pit's, a quarry's or a dam's benches)
or a vertical wall that cannot be circled, at a stand-off measured square to the face, the
camera turned square to it. One module, two registry entries: `faces` (a toe line, face
angle, face height, benches, berm depth: Mission Planner's FaceMap) and `facade` (a wall from a
line and two heights: the faces' case of one bench at 90°).

- The area file holds the toe line (the wall's foot): one straight line, two points. The faces
  rise on its right, walking from its first point to its second (`pattern.side = "left"` turns
  that round); the lanes are flown in front of them. The surface is `surfaces.Terrace`: the
  structure-faces rule proves its coverage on the faces themselves, from every station's photo.
- The camera looks square at the faces' normal seen from above (`Aim.bearing_deg`), pitched by
  `pattern.pitch_deg`: by default square to the face, −(90° − face angle) (a facade's camera
  level, a 70° face's −20°). A photo whose image reaches within `capture.MIN_DEPRESSION_DEG` of
  the horizon has no ground footprint (`capture.bounded_footprints`): plan.geojson writes its
  point with the reason, and the ground coverage counts it for no ground point; the faces are
  the structure-faces rule's.
- What a photo covers of a face is exact in the face's section (`FaceBand`): an image row is a
  level line on the face (the image's right is level and along the face), the rows at ±v (half
  the vertical angle) from the axis meet the face s · tan(δ ∓ v) from the foot of the camera's
  perpendicular, δ the axis' angle from the face's normal; the band's narrowest width along the
  face is at its row nearest along the axis.
- Lanes: the band less `targets.side_overlap` is the lane spacing; each face of slope length L
  gets ceil(L / spacing) lanes, their bands' middles spread evenly over it (never further
  apart than the spacing), flown bench by bench from `pattern.start`, each lane its own pass
  (its height: `Pass.rise_m`, above the toe line's ground, which is the launch point's: no
  DEM), back and forth. Stations a photo base apart along a lane reaching past both ends of the
  toe line by half a photo less half a base, so the ends are seen as the middle is, or farther:
  until the lane's lead-in and end keep the obstacle's distance (below); the last a whole base
  after the one before it (the distance trigger takes no photo nearer).
- Every lane keeps the stand-off from the whole solid: where a lower crest juts nearer (a berm
  narrower than the stand-off's level reach) the lane moves out along its face's normal
  (`lane_place`; the summary's heading line gives the farthest lane's distance).
- The faces are an obstacle: the ways from and back to the launch point go round the faces'
  plan (the toe line to the last crest) grown by the stand-off less
  `orbit.CLEARANCE_ALLOWANCE_M` (`Layout.obstacle`), and a launch point inside it is refused;
  the tests measure every leg's distance from the solid in 3-D.
- The camera is panned square to the lanes against a nose that turns round at each lane
  (`nose_turns_camera`): a copter's lead-in lasts the nose's turn (`sensor.NOSE_TURN_S`), so a
  lane's first photo is shot at its bearing (flown in SITL: tests/test_sitl.py).
- The lowest lane flies at least `pattern.min_height_m` (default `MIN_HEIGHT_M`, 2 m) above the
  toe line's ground: a lane laid lower moves up its face at its distance from it (`raised_lane`);
  where its photos would then no longer reach the face's foot, the plan is refused in one line.
- A facade's lanes may be flown up and down the wall instead (`pattern.lanes = "vertical"`:
  `Faces._vertical`): side by side at the stand-off, evenly at most a spacing apart along the wall
  (the photo's width on it less the side overlap: `footprint` swaps the band's sides), reaching past
  the toe line's ends by half a photo less half a spacing; on each, stations at most a photo base
  apart (the band's height less the forward overlap), the lowest where its band reaches half a
  photo less half a base below the foot, raised to `min_height_m` (refused in one line where its band
  then misses the foot), the highest where its band reaches as far past the top; up one lane, down the next, each its own
  pass, its stations' heights `Strip.rise_m`. A distance trigger counts level distance only, so they
  are shot at rest (camera.trigger "hover", copters only; refused in one line otherwise): a lane ends
  at its last station and the next lane's run starts at its first (`Pass.lead_in_m`, `Pass.end_m`),
  the nose along the wall as the first lane's lead-in turned it and kept on the climbs.
- Not offered: vertical lanes on benched faces; a bent toe line (one straight line per plan).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.errors import InputError
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.bounds import GridBounds
from aerosurvey.plan.layout import Field, Layout, SurfaceAsked
from aerosurvey.plan.orbit import CLEARANCE_ALLOWANCE_M, MAX_RAY_DEPRESSION_DEG, WallBand, band_on_face
from aerosurvey.plan.passes import Aim, Pass, Strip
from aerosurvey.plan.polyline import autopilot_distance, extend, stations_along, strips_clear_of
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.sensor import Footprint, SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.plan.surfaces import Terrace

if TYPE_CHECKING:
    from aerosurvey.plan.model import Heights, Plan
    from aerosurvey.spec import FlightSpec, MissionSpec


@dataclass(frozen=True)
class FacesOptions:
    standoff_m: float
    angle_deg: float  # the faces' angle from the horizontal
    height_m: float  # each face's
    benches: int
    berm_m: float
    base_m: float  # the lowest toe's height above the toe line's ground
    side: str  # "right" or "left": where the faces rise, walking along the toe line
    start: str  # "bottom" or "top"
    pitch_deg: float | None  # None: square to the face
    min_images: int
    max_gsd_m: float | None
    min_height_m: float  # every lane at least this high above the toe line's ground
    lanes: str = "horizontal"  # a facade's lanes: "horizontal" (along the wall) or "vertical" (up and down it)


#: the lowest lane's least height above the toe line's ground by default (`pattern.min_height_m`): a copter's
#: height hold keeps within about a metre of its target (barometer and GNSS), and nearer the ground its
#: downwash raises dust into the photos; 2 m leaves a metre's margin over that error
MIN_HEIGHT_M = 2.0


@dataclass(frozen=True)
class FaceBand:
    """What a photo covers of a face square in front of it at the stand-off: the slope positions
    (metres up the face from the foot of the camera's perpendicular) its image's bottom and top
    rows meet, and its narrowest width along the face."""

    pitch_deg: float
    bottom_m: float
    top_m: float
    width_m: float

    @property
    def height_m(self) -> float:
        return self.top_m - self.bottom_m

    @property
    def middle_m(self) -> float:
        return (self.top_m + self.bottom_m) / 2.0

    @classmethod
    def of(cls, spec: MissionSpec) -> FaceBand:
        o = spec.pattern.options
        assert isinstance(o, FacesOptions), o
        tu, tv = WallBand.tangents(spec)
        v = math.degrees(math.atan(tv))
        pitch = o.angle_deg - 90.0 if o.pitch_deg is None else o.pitch_deg
        delta = pitch + 90.0 - o.angle_deg  # the axis above the face's inward normal
        if pitch > 0.0 or abs(delta) + v > MAX_RAY_DEPRESSION_DEG:
            raise InputError(f"pattern.pitch_deg = {pitch:g} is not allowed for this camera and face angle "
                             f"{o.angle_deg:g}°: allowed {o.angle_deg - 90.0 - MAX_RAY_DEPRESSION_DEG + v:.1f} .. "
                             f"{min(0.0, o.angle_deg - 90.0 + MAX_RAY_DEPRESSION_DEG - v):.1f} (level at the highest, "
                             f"every ray at most {MAX_RAY_DEPRESSION_DEG:g}° off the face's normal)", key="pattern.pitch_deg")
        return cls(pitch, *band_on_face(o.standoff_m, o.angle_deg, pitch, (tu, tv)))


def lane_positions(slope_m: float, spacing_m: float) -> np.ndarray:
    """The bands' middles up a face of slope length `slope_m`: ceil(slope / spacing) of them, spread
    evenly (each band's share of the face at most the spacing)."""
    n = max(1, math.ceil(slope_m / spacing_m - 1e-9))
    out: np.ndarray = slope_m * (np.arange(n) + 0.5) / n
    return out


def lane_place(t: Terrace, bench: int, middle: float, band_middle: float, standoff: float) -> tuple[float, float, float]:
    """Where a lane flies in the faces' section: (metres behind the toe line, height, its distance
    from its face's plane). Its band's middle `middle` metres up bench `bench`'s face (`band_middle`:
    the band's middle up the face from the camera's perpendicular, a metre of stand-off's worth), at
    `standoff` from the face's plane, or farther out along the face's normal where a lower crest
    juts nearer than that (a berm narrower than the stand-off's level reach): every lane keeps the
    stand-off from the whole solid."""
    a = math.radians(t.angle_deg)
    toe_d, toe_z = t.toe(bench)
    off = standoff
    for _ in range(100):
        foot = middle - band_middle * off  # the camera's perpendicular meets the face this far up it
        d, z = toe_d + foot * math.cos(a) - off * math.sin(a), toe_z + foot * math.sin(a) + off * math.cos(a)
        short = standoff - t.clearance(d, z)
        if short <= 1e-3:
            return d, z, off
        off += short
    raise InputError(f"pattern.standoff_m = {standoff:g}: no lane of bench {bench + 1} keeps it from the lower benches; "
                     "allowed: a wider berm or a smaller stand-off", key="pattern.standoff_m")


def raised_lane(t: Terrace, bench: int, middle: float, band: FaceBand, o: FacesOptions) -> tuple[float, float, float]:
    """`lane_place` of a lane, moved up its face (at its distance from the face) until it flies at least
    `o.min_height_m` above the toe line's ground; refused in one line when its photos would then no
    longer reach the face's foot (a lower lane photographs the foot only from below that height)."""
    per_m = band.middle_m / o.standoff_m
    d, z, off = lane_place(t, bench, middle, per_m, o.standoff_m)
    if z >= o.min_height_m - 1e-9:
        return d, z, off
    raised = middle + (o.min_height_m - z) / math.sin(math.radians(o.angle_deg))
    d, z, off = lane_place(t, bench, raised, per_m, o.standoff_m)
    bottom = raised - (band.middle_m - band.bottom_m) * off / o.standoff_m  # the band's lowest row up the face
    if bottom > 1e-6:
        lowest = z - bottom * math.sin(math.radians(o.angle_deg))
        raise InputError(f"pattern.min_height_m = {o.min_height_m:g}: the lowest lane raised to it sees the face only from "
                         f"{bottom:.2f} m up its slope, not its foot; allowed: at most {lowest:.2f} m at this stand-off "
                         "and pitch (or a lower pattern.pitch_deg)", key="pattern.min_height_m")
    return d, z, off


@dataclass(frozen=True)
class Faces:
    settings: FacesOptions
    band: FaceBand

    kind: ClassVar[str] = "faces"
    title: ClassVar[str] = "faces (inclined benches above a toe line: open pit, quarry, dam)"
    area_is_centreline: ClassVar[bool] = True
    nose_turns_camera: ClassVar[bool] = True  # the camera panned square to the lanes, flown back and forth
    fields: ClassVar[tuple[Field, ...]] = (
        Field("standoff_m", "Stand-off (m)", "number", 20.0, lo=CLEARANCE_ALLOWANCE_M + 1.0, hi=500.0,
              hint="Distance from each face to its lanes, square to the face"),
        Field("face_angle_deg", "Face angle (°)", "number", 70.0, lo=20.0, hi=90.0, hint="Each face's slope from the horizontal"),
        Field("face_height_m", "Face height (m)", "number", 15.0, lo=0.0, hi=500.0, lo_open=True, hint="Each bench's face"),
        Field("benches", "Benches", "number", 1, lo=1, hi=20),
        Field("berm_m", "Berm depth (m)", "number", 0.0, lo=0.0, hi=500.0, hint="The level step behind each face"),
        Field("side", "Faces rise on the", "choice", "right",
              choices=(("right", "right of the toe line"), ("left", "left of the toe line")),
              hint="Walking along the toe line from its first point"),
        Field("start", "Start", "choice", "bottom", choices=(("bottom", "the lowest lane"), ("top", "the highest lane"))),
        Field("pitch_deg", "Camera pitch (°)", "number", None, lo=-90.0, hi=0.0,
              hint="Gimbal pitch (-90 straight down, 0 level); default: square to the face"),
        Field("min_images", "Photos per face point", "number", 2, lo=1, hi=100),
        Field("max_gsd_cm", "GSD on the face at most (cm)", "number", None, lo=0.0, hi=1000.0, lo_open=True, scale=0.01),
        Field("min_height_m", "Lowest lane at least (m)", "number", MIN_HEIGHT_M, lo=0.0, hi=500.0,
              hint="Above the ground at the toe line: a lower lane is raised, if its photos still reach the foot"),
    )

    @classmethod
    def stands_on(cls, site: Site) -> BaseGeometry | None:
        return site.centreline  # its lanes are above the ground along the toe line

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        """The ground the site holds: in front of the toe line to the lanes, behind it to the last crest."""
        o = spec.pattern.options
        assert isinstance(o, FacesOptions), o
        front = o.standoff_m
        back = max(1.0, o.benches * o.height_m / math.tan(math.radians(o.angle_deg)) + (o.benches - 1) * o.berm_m)
        return (front, back) if o.side == "right" else (back, front)

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> FacesOptions:
        benches = values["benches"]
        if benches != int(benches):
            raise InputError(f"pattern.benches = {benches!r} is not allowed; allowed: a whole number 1..20", key="pattern.benches")
        pitch = values.get("pitch_deg")
        return FacesOptions(float(values["standoff_m"]), float(values["face_angle_deg"]), float(values["face_height_m"]),
                            int(benches), float(values["berm_m"]), 0.0, str(values["side"]), str(values["start"]),
                            None if pitch is None else float(pitch), _min_images(values), values["max_gsd_cm"],
                            float(values["min_height_m"]))

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Faces:
        assert isinstance(spec.pattern.options, FacesOptions)
        if spec.terrain.mode not in ("none", "fixed"):
            raise InputError(f"terrain.mode = {spec.terrain.mode!r} is not allowed with pattern.kind = {cls.kind!r} (its lanes "
                             "are level, at heights above the ground at the toe line); allowed: 'fixed' (with a DEM: above "
                             "the lowest ground along the toe line) or 'none' (no DEM: the launch point's ground)",
                             key="terrain.mode")
        return cls(spec.pattern.options, FaceBand.of(spec))

    @classmethod
    def footprint(cls, spec: MissionSpec, heights: Heights) -> Footprint:
        """A photo on a face at the stand-off: its narrowest width along the face (the photo base is
        laid from it), its band's height up the face (the lane spacing)."""
        band = FaceBand.of(spec)
        o = spec.pattern.options
        assert isinstance(o, FacesOptions), o
        if o.lanes == "vertical":  # lanes side by side along the wall, stations up them
            return Footprint(across_m=band.width_m, along_m=band.height_m)
        return Footprint(across_m=band.height_m, along_m=band.width_m)

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> GridBounds:
        """The lanes, and on each a photo a base apart along the toe line: the fewest any lanes of
        these bands fly."""
        o = spec.pattern.options
        assert isinstance(o, FacesOptions) and site.centreline is not None
        slope = o.height_m / math.sin(math.radians(o.angle_deg))
        if o.lanes == "vertical":
            length = site.centreline.length / site.grid_scale
            lanes = math.ceil(length / sensor.spacing_m - 1e-9)
            return GridBounds(length, lanes, lanes * math.ceil(o.height_m / sensor.base_m - 1e-9))
        lanes = o.benches * len(lane_positions(slope, sensor.spacing_m))
        per_lane = math.ceil(site.centreline.length / site.grid_scale / sensor.base_m - 1e-9)
        return GridBounds(slope * o.benches, lanes, lanes * per_lane)

    @classmethod
    def parameters(cls, plan: Plan) -> dict[str, Any]:
        o = plan.pattern.options
        assert isinstance(o, FacesOptions)
        return {"standoff_m": o.standoff_m, "face_angle_deg": o.angle_deg, "face_height_m": o.height_m,
                "benches": o.benches, "berm_m": o.berm_m, "base_m": o.base_m, "side": o.side, "start": o.start,
                "pitch_deg": plan.layout.passes[0].aim.pitch_deg, "lanes": len(plan.layout.passes),
                "min_height_m": o.min_height_m, "lane_direction": o.lanes,
                "clearance_allowance_m": CLEARANCE_ALLOWANCE_M}

    def terrace(self, site: Site) -> Terrace:
        """The faces in the planning CRS, from the site's toe line."""
        line = site.centreline
        xy = np.asarray(line.coords, float) if isinstance(line, shapely.LineString) else np.zeros((0, 2))
        if len(xy) != 2:
            raise InputError(f"area.file holds {'a line of ' + str(len(xy)) + ' points' if len(xy) else 'no single line'}: "
                             f"pattern.kind = {self.kind!r} takes the toe line as one straight line of 2 points",
                             key="area.file")
        a, b = (tuple(map(float, p)) for p in (xy if self.settings.side == "right" else xy[::-1]))
        o = self.settings
        return Terrace((a[0], a[1]), (b[0], b[1]), o.base_m, o.angle_deg, o.height_m, o.benches, o.berm_m)

    def layouts(self, site: Site, sensor: SensorSolution, report: Progress) -> Iterator[Layout]:
        k = site.grid_scale
        o, band = self.settings, self.band
        t = self.terrace(site)
        along, into, length = t.axes(k)
        if o.lanes == "vertical":
            yield self._vertical(site, sensor, t)
            return
        a = math.radians(o.angle_deg)
        slope = o.height_m / math.sin(a)
        lanes = [(i, float(m)) for i in range(o.benches) for m in lane_positions(slope, sensor.spacing_m)]
        if o.start == "top":
            lanes = lanes[::-1]
        # past the toe line's ends: half a photo less half a base (the ends seen as the middle is),
        # and so far that the lead-ins and ends keep the stand-off less the allowance off the faces
        lead = min(sensor.lead_in_m, sensor.base_m / 2.0)
        reach = max(band.width_m / 2.0 - sensor.base_m / 2.0, o.standoff_m - CLEARANCE_ALLOWANCE_M + 1.0 - lead, 0.0) * k
        autopilot_m = autopilot_distance(site.planar)

        aim = Aim(band.pitch_deg, bearing_deg=float(np.degrees(np.arctan2(into[0], into[1])) % 360.0))
        plan_h = sensor.heights.nominal_agl_m
        passes = []
        farthest = o.standoff_m
        for n, (bench, middle) in enumerate(lanes):
            d, z, off = raised_lane(t, bench, middle, band, o)
            farthest = max(farthest, off)
            start = np.asarray(t.a) + into * d * k
            path = extend(np.array([start, start + along * length * k]), reach, reach)
            if n % 2:
                path = path[::-1]
            span = float(np.hypot(*(path[-1] - path[0])))
            # room past the end for the last station a whole base on: the distance trigger takes no
            # photo nearer (a station clamped to the end would be planned and never taken)
            path = extend(path, 0.0, 1.5 * sensor.base_m * k)
            at = stations_along(path, autopilot_m, sensor.base_m, span, sensor.trigger_distance_m,
                                sensor.speed.speed_ms / pg.TRIGGER_CHECK_HZ)
            strips: tuple[Strip, ...] = tuple(strips_clear_of(0, 0, 0, path, at, site.zones_buffered, 0.0))
            if not strips:
                raise InputError(f"lane {n + 1} of the faces lies inside the exclusion zones: nothing of it can be flown",
                                 key="pattern.standoff_m")
            passes.append(Pass(n + 1, strips=strips, aim=aim, rise_m=z - plan_h, one_way=True))
        yield self._layout(t, k, f"lanes along the toe line at {o.standoff_m:g}"
                           + (f"..{farthest:.1f}" if farthest > o.standoff_m else "") + " m from the faces", tuple(passes))

    def _layout(self, t: Terrace, k: float, how: str, passes: tuple[Pass, ...]) -> Layout:
        """The layout of the lanes `passes`: the ways from and back to the launch point keep the
        stand-off less the allowance off the faces' plan (toe line to last crest), the lanes reach
        that far past its ends; what the photos cover is the faces: the structure-faces rule proves
        them (plan/surfaces.py)."""
        o = self.settings
        along, into, _ = t.axes(k)
        depth = t.profile()[0][-1] * k
        plan = shapely.Polygon([t.a, t.b, t.b + into * depth, t.a + into * depth]) if depth > 0 \
            else shapely.LineString([t.a, t.b])
        keep_out = shapely.buffer(plan, (o.standoff_m - CLEARANCE_ALLOWANCE_M) * k)
        toe = shapely.LineString([t.a, t.b])
        return Layout(float(np.degrees(np.arctan2(along[0], along[1])) % 360.0), how, passes, toe.buffer(0.01 * k), 0.0,
                      obstacle=keep_out, surface=SurfaceAsked(t, o.min_images, o.max_gsd_m))

    def _vertical(self, site: Site, sensor: SensorSolution, t: Terrace) -> Layout:
        """A wall's lanes flown up and down it (`pattern.lanes = "vertical"`), side by side at the
        stand-off: see the module's docstring."""
        k = site.grid_scale
        o, band = self.settings, self.band
        along, into, length = t.axes(k)
        spacing, base = sensor.spacing_m, sensor.base_m
        # along the wall: past both ends by half a photo less half a spacing, lanes evenly at most a spacing apart
        reach = max(band.width_m / 2.0 - spacing / 2.0, 0.0)
        span = length + 2.0 * reach
        count = math.ceil(span / spacing - 1e-9) + 1
        at = -reach + span * np.arange(count) / (count - 1)
        gap = span / (count - 1)
        # up the wall: the lowest photo's band reaching below the foot by half a photo less half a base, raised
        # to pattern.min_height_m while it still sees the foot; the highest's as far past the top
        top = o.base_m + o.height_m
        past = band.height_m / 2.0 - base / 2.0
        low = max(o.base_m - past - band.middle_m, o.min_height_m)
        if low + band.bottom_m > o.base_m + 1e-6:
            raise InputError(f"pattern.min_height_m = {o.min_height_m:g}: the lowest station raised to it sees the wall only "
                             f"from {low + band.bottom_m - o.base_m:.2f} m above its foot; allowed: at most "
                             f"{o.base_m - band.bottom_m:.2f} m at this stand-off and pitch (or a lower pattern.pitch_deg)",
                             key="pattern.min_height_m")
        high = max(top + past - band.middle_m, low)
        n = math.ceil((high - low) / base - 1e-9) + 1
        z = low + (high - low) * np.arange(n) / max(n - 1, 1)
        if o.start == "top":
            z = z[::-1]
        bearing = float(np.degrees(np.arctan2(along[0], along[1])) % 360.0)
        aim = Aim(band.pitch_deg, bearing_deg=float(np.degrees(np.arctan2(into[0], into[1])) % 360.0))
        plan_h = sensor.heights.nominal_agl_m
        passes = []
        for i, a in enumerate(at.tolist()):
            xy = np.asarray(t.a) + (into * -o.standoff_m + along * a) * k
            if site.zones_buffered is not None and shapely.intersects(site.zones_buffered, shapely.Point(xy)):
                raise InputError(f"lane {i + 1} of the facade lies inside the exclusion zones: the wall there cannot be "
                                 "photographed", key="pattern.standoff_m")
            heights = z if i % 2 == 0 else z[::-1]
            strip = Strip(0, 0, np.array([xy, xy]), np.repeat(xy[None], n, axis=0), np.arange(n), np.full(n, bearing),
                          np.zeros(0, np.int64), heights - low)
            # shot at rest: a lane ends at its last station, and the next is flown to straight from there, the nose
            # along the wall as the first lane's lead-in turned it
            passes.append(Pass(i + 1, strips=(strip,), aim=aim, rise_m=low - plan_h, one_way=True,
                               lead_in_m=None if i == 0 else 0.0, end_m=0.0))
        return self._layout(t, k, f"{count} lanes up and down the wall at {o.standoff_m:g} m from it, {gap:.2f} m apart",
                            tuple(passes))


def _min_images(values: Mapping[str, Any]) -> int:
    n = values["min_images"]
    if n != int(n):
        raise InputError(f"pattern.min_images = {n!r} is not allowed; allowed: a whole number 1..100", key="pattern.min_images")
    return int(n)


@dataclass(frozen=True)
class Facade(Faces):
    """A vertical wall from the toe line (its foot) between two heights: one face at 90°."""

    kind: ClassVar[str] = "facade"
    title: ClassVar[str] = "facade (a wall that cannot be circled, from a line and two heights)"
    fields: ClassVar[tuple[Field, ...]] = (
        Faces.fields[0],
        Field("base_m", "Wall base (m)", "number", 0.0, lo=0.0, hi=1000.0, hint="Above the ground at the line"),
        Field("top_m", "Wall top (m)", "number", None, lo=0.0, hi=1000.0, lo_open=True, hint="Above the ground at the line"),
        *Faces.fields[5:],
        Field("lanes", "Lanes", "choice", "horizontal",
              choices=(("horizontal", "along the wall, one above another"), ("vertical", "up and down the wall, side by side")),
              hint="Vertical: a copter stopping at each station (camera.trigger = 'hover')"),
    )

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Faces:
        o = spec.pattern.options
        assert isinstance(o, FacesOptions), o
        if o.lanes == "vertical" and spec.vehicle.type != "copter":
            raise InputError(f"pattern.lanes = 'vertical' climbs and descends in front of the wall: vehicle.type = "
                             f"{spec.vehicle.type!r} cannot; allowed: 'copter'", key="vehicle.type")
        if o.lanes == "vertical" and spec.camera.trigger != "hover":
            raise InputError(f"pattern.lanes = 'vertical' shoots at rest at every station (an autopilot's distance trigger "
                             f"counts level distance only: a lane flown up or down takes no photo by it): camera.trigger = "
                             f"{spec.camera.trigger!r}; allowed: 'hover'", key="camera.trigger")
        return super().from_spec(spec)

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        o = spec.pattern.options
        assert isinstance(o, FacesOptions), o
        return (o.standoff_m, 1.0) if o.side == "right" else (1.0, o.standoff_m)

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> FacesOptions:
        base, top = float(values["base_m"]), values["top_m"]
        if top is None or float(top) <= base:
            raise InputError(f"pattern.top_m = {top!r} is not allowed; allowed: a height above pattern.base_m ({base:g} m)",
                             key="pattern.top_m")
        pitch = values.get("pitch_deg")
        return FacesOptions(float(values["standoff_m"]), 90.0, float(top) - base, 1, 0.0, base, str(values["side"]),
                            str(values["start"]), None if pitch is None else float(pitch), _min_images(values),
                            values["max_gsd_cm"], float(values["min_height_m"]), str(values["lanes"]))


__all__ = ["FaceBand", "Facade", "Faces", "FacesOptions", "lane_positions"]
