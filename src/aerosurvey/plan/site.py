"""The site: the area and the exclusion zones in the planning CRS, the grid scale, and the
terrain under the area. The pipeline's first look at the inputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.area import Planar, check_area_of_use, planning_crs
from aerosurvey.errors import InputError
from aerosurvey.plan.inputs import PlanInputs
from aerosurvey.spec import MissionSpec

if TYPE_CHECKING:
    from aerosurvey.plan.terrain import Dem


@dataclass(frozen=True, eq=False)
class Site:
    planar: Planar
    area_wgs84: BaseGeometry
    exclusions_wgs84: tuple[BaseGeometry, ...]
    area: BaseGeometry  # planning CRS, normalised
    zones: BaseGeometry | None  # the exclusion zones, united
    zones_buffered: BaseGeometry | None  # with flight.exclusion_margin_m: nothing may fly inside
    grid_scale: float  # planning-CRS metres per ground metre at the area's centroid
    dem: Dem | None
    ground: tuple[float, float] | None  # lowest and highest DEM cell under the area (a terrain mode with a DEM)


def _places(spec: MissionSpec, inputs: PlanInputs) -> list[tuple[str, BaseGeometry]]:
    """The area, the exclusion zones and the launch points, each with its name in the spec."""
    out: list[tuple[str, BaseGeometry]] = [("area", inputs.area_wgs84)]
    out += [(f"exclusion zone {p.name}", z) for p, z in zip(spec.area.exclusions, inputs.exclusions_wgs84)]
    if spec.area.launch is not None:
        out.append(("area.launch", shapely.Point(spec.area.launch)))
    if spec.battery is not None:
        out += [(f"battery.launch_points[{i}]", shapely.Point(p)) for i, p in enumerate(spec.battery.launch_points)]
    return out


def prepare_site(spec: MissionSpec, inputs: PlanInputs) -> Site:
    """Project the inputs; refuse zones that leave nothing to survey."""
    planar = planning_crs(spec.crs, inputs.area_wgs84)
    if spec.crs != "auto":  # "auto" is the UTM zone of the area's centre
        check_area_of_use(planar.crs, "mission.crs", _places(spec, inputs))
    area = shapely.normalize(planar.forward(inputs.area_wgs84))
    excl = inputs.exclusions_wgs84
    zones = shapely.union_all([planar.forward(e) for e in excl]) if excl else None
    margin = spec.flight.exclusion_margin_m
    zones_buf = shapely.buffer(zones, margin) if zones is not None else None
    if zones_buf is not None:
        remaining = shapely.difference(area, zones_buf)
        if remaining.area < 0.01 * area.area:
            raise InputError(
                f"the exclusion zones (with the {margin:g} m margin, flight.exclusion_margin_m) cover "
                f"{100 * (1 - remaining.area / area.area):.1f} % of the area: nothing is left to survey",
                key="area.exclusions",
            )
    c = inputs.area_wgs84.centroid
    dem = None
    ground = None
    if inputs.dem is not None:
        from aerosurvey.plan.terrain import Dem  # rasterio loads only for plans with a DEM

        dem = Dem(inputs.dem, planar)
        if spec.terrain.mode != "none":
            ground = dem.range_over(area, "area")
    return Site(planar, inputs.area_wgs84, tuple(excl), area, zones, zones_buf, planar.scale_factor(c.x, c.y), dem, ground)
