"""What planning reads from files, as plain data: the loader (`aerosurvey.inputs`) makes it,
`plan_mission` takes it and touches no file.

A web page, a test or a plug-in that has its geometry in memory builds `PlanInputs` itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry.base import BaseGeometry

if TYPE_CHECKING:
    from aerosurvey.airspace.model import Airspace


@dataclass(frozen=True, eq=False)
class DemGrid:
    """A window of a DEM held in memory: heights (NaN where the DEM has no data) on a grid.

    `transform` is the affine (a, b, c, d, e, f) of the window (x = a·col + b·row + c,
    y = d·col + e·row + f, cell corners), `offset` the window's first column and row in the
    whole DEM, `full_shape` and `full_bounds` (left, bottom, right, top) the whole DEM's, so
    that messages can tell "off the DEM" from "outside the part that was read".
    """

    name: str  # the file name, for messages
    heights: np.ndarray  # (rows, cols) float64
    transform: tuple[float, float, float, float, float, float]
    crs_wkt: str
    offset: tuple[int, int]  # (col, row) of the window in the whole DEM
    full_shape: tuple[int, int]  # (rows, cols) of the whole DEM
    full_bounds: tuple[float, float, float, float]


@dataclass(frozen=True, eq=False)
class PlanInputs:
    """The geometry a plan is made from, in WGS84 longitude/latitude, and the terrain."""

    area_wgs84: BaseGeometry
    exclusions_wgs84: tuple[BaseGeometry, ...] = ()
    dem: DemGrid | None = None
    airspace: Airspace | None = None  # official UAS zones ([airspace]), the authorisations and the planned window
    structure_wgs84: BaseGeometry | None = None  # [structure]'s footprint, one polygon
