"""The oblique pattern: the area grid flown with the camera tilted, for 3D models.

    double-grid     two passes at right angles, the camera pitched to `pitch_deg` and looking
                    along the flight: back and forth, each pass sees the ground from two sides,
                    the two passes from all four
    five-direction  a nadir pass and four oblique passes over the same lines, the camera looking
                    towards the lines' heading and 90°, 180° and 270° from it (a gimbal's yaw
                    relative to the nose, set at each run)

Spacing and base come from the rectangle every photo of the scheme holds (`sensor.oblique_footprint`:
the tilted trapezoid's near-edge width and depth), so the asked overlaps hold in the tilted
photos. A tilted photo sees the ground ahead of the camera: the middle of its depth lies
`oblique_centre_m` ahead, so the lines are laid over the area grown by that much (a footprint
moved by at most that covers what the untilted rectangle would). The far-edge GSD is the plan's
coarsest (`SensorSolution.gsd_max_m`). Next to the zones the coverage step checks the tilted
footprints exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from aerosurvey.camera import Camera
from aerosurvey.plan.area_grid import AreaGrid
from aerosurvey.plan.layout import Layout
from aerosurvey.plan.progress import Progress
from aerosurvey.plan.sensor import SensorSolution, oblique_centre_m
from aerosurvey.plan.site import Site
from aerosurvey.spec import MissionSpec


@dataclass(frozen=True)
class Oblique:
    grid: AreaGrid  # the lines (its heading, beyond-boundary rule and margin)
    scheme: str
    pitch_deg: float
    camera: Camera
    mount: str

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> Oblique:
        return cls(AreaGrid.from_spec(spec), spec.pattern.scheme, spec.pattern.pitch_deg, spec.camera.camera, spec.camera.mount)

    def layout(self, site: Site, sensor: SensorSolution, report: Progress) -> Layout:
        ahead = oblique_centre_m(self.camera, self.mount, self.pitch_deg, sensor.heights.max_agl_m)
        grid = replace(self.grid, coverage_margin_m=self.grid.coverage_margin_m + ahead,
                       cross_hatch=self.scheme == "double-grid")
        lay = grid.layout(site, sensor, report)
        if self.scheme == "double-grid":
            passes = tuple(replace(p, pitch_deg=self.pitch_deg) for p in lay.passes)
            how = f"{lay.heading_chosen}; obliques at {self.pitch_deg:g}° looking along the flight, crossed at 90°"
        else:
            nadir = lay.passes[0]
            passes = (nadir, *(replace(nadir, index=2 + i, pitch_deg=self.pitch_deg,
                                       look_deg=(lay.heading_deg + 90.0 * i) % 360.0) for i in range(4)))
            how = f"{lay.heading_chosen}; nadir and four obliques at {self.pitch_deg:g}° over the same lines"
        return Layout(lay.heading_deg, how, passes, lay.covered, self.grid.coverage_margin_m, lay.check_exactly)
