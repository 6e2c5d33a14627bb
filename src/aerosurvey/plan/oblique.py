"""The oblique pattern: the area grid flown with the camera tilted, for 3D models.

    double-grid     two passes at right angles, the camera pitched to `pitch_deg` and looking
                    along the flight: back and forth, each pass sees the ground from two sides,
                    the two passes from all four
    five-direction  a nadir pass and four oblique passes over the same lines, the camera looking
                    towards the lines' heading and 90°, 180° and 270° from it (a gimbal's yaw
                    relative to the nose, set at each run)

Spacing and base come from the rectangle every photo of the scheme holds (`oblique_footprint`:
the tilted trapezoid's near-edge width and its depth, made shallower where photos are shifted
along it so that the overlap holds by area too), so the asked overlaps hold in the tilted
photos, among the photos of each look direction (what reconstruction matches): a double grid's
lines alternate their look with the direction of flight, so its lines are laid at half the
spacing (`Footprint.lines_per_look`) and neighbouring lines looking the same way (every second
line) overlap as asked; the five-direction passes look one way on every line. A tilted photo
sees the ground ahead of the camera: the middle of its depth lies
`oblique_centre_m` ahead, so the lines are laid over the area grown by that much (a footprint
moved by at most that covers what the untilted rectangle would). The far-edge GSD is the plan's
coarsest (`SensorSolution.gsd_max_m`). Next to the zones the coverage step checks the tilted
footprints exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from shapely.geometry.base import BaseGeometry

from aerosurvey.camera import Camera
from aerosurvey.errors import InputError
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.plan.area_grid import AreaGrid
from aerosurvey.plan.bounds import GridBounds, covered, grid_bounds
from aerosurvey.plan.layout import Field, Layout
from aerosurvey.plan.passes import Aim
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.sensor import Footprint, SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import FlightSpec, MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.model import Heights, Plan

SCHEMES = ("double-grid", "five-direction")


@dataclass(frozen=True)
class ObliqueOptions:
    """[pattern] kind = "oblique": the scheme, the camera's pitch (gimbal convention, −90 straight
    down) and the coarsest GSD allowed at a photo's far edge (metres; None: no limit)."""

    scheme: str
    pitch_deg: float
    max_far_gsd_m: float | None


def _options(spec: MissionSpec) -> ObliqueOptions:
    o = spec.pattern.options
    assert isinstance(o, ObliqueOptions), o  # the spec made it from this kind's fields
    return o


@dataclass(frozen=True)
class Oblique:
    grid: AreaGrid  # the lines (its heading, beyond-boundary rule and margin)
    scheme: str
    pitch_deg: float
    camera: Camera
    mount: str

    kind: ClassVar[str] = "oblique"
    title: ClassVar[str] = "oblique"
    area_is_centreline: ClassVar[bool] = False
    nose_turns_camera: ClassVar[bool] = False
    fields: ClassVar[tuple[Field, ...]] = (
        Field("scheme", "Scheme", "choice", "double-grid",
              choices=(("double-grid", "double grid (two headings, camera along the flight)"),
                       ("five-direction", "five directions (nadir, and four looks at 90° steps)"))),
        Field("pitch_deg", "Camera pitch (°)", "number", -45.0, lo=-80.0, hi=-20.0, hint="Gimbal pitch: -90 looks straight down"),
        Field("max_far_gsd_cm", "Far-edge GSD limit (cm)", "number", None, lo=0.0, hi=1000.0, lo_open=True, scale=0.01,
              hint="The coarsest ground sampling a tilted photo may have at its far edge"),
    )

    @classmethod
    def stands_on(cls, site: Site) -> BaseGeometry | None:
        return None  # its heights are above the area's ground

    @classmethod
    def centreline_sides(cls, spec: MissionSpec) -> tuple[float | None, float | None]:
        return None, None

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> ObliqueOptions:
        return ObliqueOptions(str(values["scheme"]), float(values["pitch_deg"]), values["max_far_gsd_cm"])

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Oblique:
        o = _options(spec)
        return cls(AreaGrid.from_spec(spec, several_passes=False), o.scheme, o.pitch_deg, spec.camera.camera, spec.camera.mount)

    @classmethod
    def footprint(cls, spec: MissionSpec, heights: Heights) -> Footprint:
        o = _options(spec)
        across, along, far = oblique_footprint(spec, o, heights.spacing_agl_m, heights.max_agl_m)
        if o.max_far_gsd_m is not None and far > o.max_far_gsd_m:
            raise InputError(f"pattern.max_far_gsd_cm = {o.max_far_gsd_m * 100:g}: the oblique photos' far edge has a GSD of "
                             f"{far * 100:.2f} cm from {heights.max_agl_m:.1f} m above ground at pitch {o.pitch_deg:g}°; "
                             f"fly at most {heights.max_agl_m * o.max_far_gsd_m / far:.1f} m high, or pitch the camera further down",
                             key="pattern.max_far_gsd_cm")
        # a double grid's lines are flown back and forth with the camera along the flight: the photos
        # looking one way are those of every second line
        return Footprint(across, along, far, lines_per_look=2 if o.scheme == "double-grid" else 1)

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> GridBounds:
        """An area grid's, once for each pass over the ground: a double grid two, five directions five."""
        return grid_bounds(covered(site.area, layout.margin_m, site.grid_scale), site.grid_scale, sensor.across_m,
                           sensor.spacing_m, sensor.base_m, sensor.side_images_per_point,
                           2 if _options(spec).scheme == "double-grid" else 5)

    @classmethod
    def parameters(cls, plan: Plan) -> dict[str, Any]:
        o = plan.pattern.options
        assert isinstance(o, ObliqueOptions)
        return {"scheme": o.scheme, "pitch_deg": o.pitch_deg,
                "max_far_gsd_cm": round(o.max_far_gsd_m * 100, 4) if o.max_far_gsd_m is not None else None}

    def layouts(self, site: Site, sensor: SensorSolution, report: Progress) -> Iterator[Layout]:
        """Each of the area grid's layouts (`AreaGrid.layouts`), flown with the camera tilted."""
        ahead = oblique_centre_m(self.camera, self.mount, self.pitch_deg, sensor.heights.max_agl_m)
        grid = replace(self.grid, coverage_margin_m=self.grid.coverage_margin_m + ahead,
                       cross_hatch=self.scheme == "double-grid")
        return (self._tilted(lay) for lay in grid.layouts(site, sensor, report))

    def _tilted(self, lay: Layout) -> Layout:
        if self.scheme == "double-grid":
            passes = tuple(replace(p, aim=Aim(self.pitch_deg)) for p in lay.passes)
            how = f"{lay.heading_chosen}; obliques at {self.pitch_deg:g}° looking along the flight, crossed at 90°"
        else:
            nadir = lay.passes[0]
            passes = (nadir, *(replace(nadir, index=2 + i, aim=Aim(self.pitch_deg, bearing_deg=(lay.heading_deg + 90.0 * i) % 360.0))
                               for i in range(4)))
            how = f"{lay.heading_chosen}; nadir and four obliques at {self.pitch_deg:g}° over the same lines"
        return Layout(lay.heading_deg, how, passes, lay.covered, self.grid.coverage_margin_m, lay.check_exactly)


def tilted_corners(camera: Camera, mount: str, pitch_deg: float, agl_m: float) -> np.ndarray:
    """(4, 2) flat-ground footprint corners of a photo from `agl_m` looking north at `pitch_deg`
    (top-right, top-left, bottom-left, bottom-right): the capture model's. ValueError when a
    corner's ray reaches the horizon."""
    from aerosurvey.plan.capture import Optics, Photos, footprint_corners

    zero = np.zeros(1)
    c: np.ndarray = footprint_corners(Photos.looking(zero, zero, np.array([agl_m]), zero, np.array([pitch_deg])),
                                      Optics.of(camera, mount), 0.0)[0]
    return c


def oblique_footprint(spec: MissionSpec, options: ObliqueOptions, low_agl_m: float, high_agl_m: float) -> tuple[float, float, float]:
    """(across, along, far-edge GSD) of the oblique scheme's photos: the rectangle every one of
    them holds whichever way it looks relative to the flight (along the line or across it, and
    the nadir photos of the five-direction scheme), at the lowest height; and the coarsest GSD,
    at the far edge of an oblique photo from the highest. From the capture model: the tilted
    photo's trapezoid is `depth` deep from its near to its far edge and `near` wide at its near
    edge, which bound the rectangle inside it; where photos are shifted along their depth the
    rectangle is made shallower (`area_depth`), so that the asked overlap holds by area too."""
    from aerosurvey.plan.capture import Optics, Photos, edge_gsd

    cam, mount = spec.camera.camera, spec.camera.mount

    def corners(pitch: float) -> np.ndarray:
        return tilted_corners(cam, mount, pitch, low_agl_m)

    try:
        c = corners(options.pitch_deg)
    except ValueError:  # the image's far edge reaches the horizon
        steepest = next(p for p in np.arange(math.floor(options.pitch_deg), -89.0, -1.0) if _sees_ground(corners, float(p)))
        raise InputError(f"pattern.pitch_deg = {options.pitch_deg:g} tilts {spec.camera.camera.name}'s image up to the "
                         f"horizon: its far corners see no ground; allowed with this camera and mount: {steepest:g} or lower",
                         key="pattern.pitch_deg") from None
    depth = float(min(c[0, 1], c[1, 1]) - max(c[2, 1], c[3, 1]))
    near = float(c[3, 0] - c[2, 0])
    far = float(c[0, 0] - c[1, 0])
    # along its depth two photos overlap by area less than their rectangles do (the far part, the
    # wider, is what a shift leaves out): the depth a rectangle would need for the asked overlap to
    # hold by area too
    side_depth = area_depth(near, far, depth, spec.targets.side_overlap)
    forward_depth = area_depth(near, far, depth, spec.targets.forward_overlap)
    if options.scheme == "double-grid":  # a photo looks along its line: its depth along, its near edge across
        across, along = near, forward_depth
    else:
        nadir = [float(v) for v in pg.footprint(low_agl_m, spec.camera.camera, spec.camera.mount)]
        across, along = min(near, side_depth, *nadir), min(near, forward_depth, *nadir)
    zero = np.zeros(1)
    high = Photos.looking(zero, zero, np.array([high_agl_m]), zero, np.array([options.pitch_deg]))
    far_gsd = float(edge_gsd(high, Optics.of(cam, mount), 0.0).far_m[0])
    return across, along, far_gsd


def area_depth(near_m: float, far_m: float, depth_m: float, overlap: float) -> float:
    """The depth of the rectangle whose rule (shift = (1 − overlap) · depth) keeps `overlap` by
    area between two trapezoids `near_m` wide at the near edge, `far_m` at the far one, `depth_m`
    deep, shifted along their depth: the shifted one leaves out the far strip, so the part kept
    is the near part `y` deep with ∫₀ʸ w = overlap · area (w growing linearly from near to far)."""
    slope = (far_m - near_m) / depth_m
    area = depth_m * (near_m + far_m) / 2.0
    if slope <= 1e-12:
        y = overlap * depth_m
    else:  # slope/2 · y² + near · y − overlap · area = 0
        y = (-near_m + math.sqrt(near_m * near_m + 2.0 * slope * overlap * area)) / slope
    return (depth_m - y) / (1.0 - overlap)


def _sees_ground(corners: Callable[[float], np.ndarray], pitch: float) -> bool:
    try:
        corners(pitch)
    except ValueError:
        return False
    return True


def oblique_centre_m(camera: Camera, mount: str, pitch_deg: float, agl_m: float) -> float:
    """How far ahead of the camera (on flat ground) the middle of an oblique photo's depth lies."""
    c = tilted_corners(camera, mount, pitch_deg, agl_m)
    return float((min(c[0, 1], c[1, 1]) + max(c[2, 1], c[3, 1])) / 2.0)
