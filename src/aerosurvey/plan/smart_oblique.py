"""The smart oblique (DJI's): the area grid flown once, the copter stopping at each station and
turning the camera through nadir and four obliques (at the oblique pitch, looking towards the
lines' heading and 90°, 180° and 270° from it) before it goes on: the photos of the five-direction
oblique (`oblique.py`) from one pass instead of five.

The lines, spacing and base are the five-direction oblique's (`Oblique`: the rectangle every
photo of the scheme holds, so the asked overlaps hold among the photos of each look); the one
pass shoots its aim (nadir) and its four `looks` at every station (`Pass.looks`): each look is
a station of its own (altitudes.py), the program stops at the place and turns the gimbal
between the shots (hover-and-capture: camera.trigger = "hover"), and the time model adds the
gimbal's turn to each further shot (`flight_time.GIMBAL_SLEW_S`). Copters only: a plane cannot
stop at a station.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar

from aerosurvey.errors import InputError
from aerosurvey.plan.area_grid import AreaGrid
from aerosurvey.plan.bounds import GridBounds, covered, grid_bounds
from aerosurvey.plan.layout import Field, Layout
from aerosurvey.plan.oblique import Oblique, ObliqueOptions
from aerosurvey.plan.passes import Aim
from aerosurvey.plan.sensor import SensorSolution
from aerosurvey.plan.site import Site
from aerosurvey.spec import FlightSpec, MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.model import Plan

#: the looks at each station: nadir, then obliques this many degrees from the lines' heading
LOOK_TURNS_DEG = (0.0, 90.0, 180.0, 270.0)


@dataclass(frozen=True)
class SmartOblique(Oblique):
    kind: ClassVar[str] = "smart-oblique"
    title: ClassVar[str] = "smart oblique"
    fields: ClassVar[tuple[Field, ...]] = tuple(f for f in Oblique.fields if f.key != "scheme")

    @classmethod
    def options(cls, values: Mapping[str, Any], flight: FlightSpec) -> ObliqueOptions:
        # the five-direction oblique's photos: its footprint and far-edge GSD
        return ObliqueOptions("five-direction", float(values["pitch_deg"]), values["max_far_gsd_cm"])

    @classmethod
    def from_spec(cls, spec: MissionSpec) -> SmartOblique:
        if spec.vehicle.type != "copter":
            raise InputError(f"pattern.kind = 'smart-oblique' stops at every station to turn the camera: vehicle.type = "
                             f"{spec.vehicle.type!r} cannot; allowed: 'copter'", key="vehicle.type")
        if spec.camera.trigger != "hover":
            raise InputError(f"pattern.kind = 'smart-oblique' shoots at rest at every station: camera.trigger = "
                             f"{spec.camera.trigger!r}; allowed: 'hover'", key="camera.trigger")
        o = spec.pattern.options
        assert isinstance(o, ObliqueOptions), o
        return cls(AreaGrid.from_spec(spec, several_passes=False), o.scheme, o.pitch_deg, spec.camera.camera, spec.camera.mount)

    @classmethod
    def bounds(cls, spec: MissionSpec, site: Site, sensor: SensorSolution, layout: Layout) -> GridBounds:
        """An area grid's strips, flown once, and its photos five times (one for each look)."""
        once = grid_bounds(covered(site.area, layout.margin_m, site.grid_scale), site.grid_scale, sensor.across_m,
                           sensor.spacing_m, sensor.base_m, sensor.side_images_per_point, 1)
        return replace(once, photos=once.photos * (1 + len(LOOK_TURNS_DEG)))

    @classmethod
    def parameters(cls, plan: Plan) -> dict[str, Any]:
        o = plan.pattern.options
        assert isinstance(o, ObliqueOptions)
        return {"pitch_deg": o.pitch_deg, "max_far_gsd_cm": round(o.max_far_gsd_m * 100, 4) if o.max_far_gsd_m is not None else None}

    def _tilted(self, lay: Layout) -> Layout:
        """The area grid's layout (`Oblique.layouts` lays it over the area grown as the obliques need)
        flown once: nadir and the four looks at each station."""
        looks = tuple(Aim(self.pitch_deg, bearing_deg=(lay.heading_deg + t) % 360.0) for t in LOOK_TURNS_DEG)
        how = f"{lay.heading_chosen}; at each station nadir and four obliques at {self.pitch_deg:g}°"
        return Layout(lay.heading_deg, how, (replace(lay.passes[0], looks=looks),), lay.covered, self.grid.coverage_margin_m,
                      lay.check_exactly)
