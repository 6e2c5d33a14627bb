"""The data a plan is made of: frozen records passed from step to step, and the `Plan` the
pipeline returns. Nothing here is filled in after construction.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from shapely.geometry.base import BaseGeometry

if TYPE_CHECKING:
    from aerosurvey.area import Planar
    from aerosurvey.plan.coverage import Coverage
    from aerosurvey.plan.photogrammetry import SpeedLimit
    from aerosurvey.plan.route import Pass, Route
    from aerosurvey.plan.site import Simplification
    from aerosurvey.plan.sorties import Budget, LaunchSite, Sortie
    from aerosurvey.spec import MissionSpec


@dataclass(frozen=True)
class Heights:
    """What the terrain mode decided: the AGL heights that drive GSD and spacing."""

    mode: str
    target_agl_m: float  # height giving the target GSD over flat ground
    nominal_agl_m: float  # the height flown over the station's ground (follow) or the lowest ground (fixed)
    spacing_agl_m: float  # smallest height above ground anywhere: footprint and spacing from it
    max_agl_m: float  # largest height above ground: the coarsest GSD
    fixed_alt_amsl_m: float | None
    ground_min_m: float | None
    ground_max_m: float | None


@dataclass(frozen=True, eq=False)
class Stations:
    """Photo stations in flight order (arrays of equal length)."""

    ids: list[str]
    run: np.ndarray
    x: np.ndarray
    y: np.ndarray
    lon: np.ndarray
    lat: np.ndarray
    ground_m: np.ndarray  # NaN without a DEM
    alt_rel_m: np.ndarray  # above home, as flown (terrain-frame: above terrain)
    agl_m: np.ndarray
    heading_deg: np.ndarray  # direction of flight (compass bearing)
    pitch_deg: np.ndarray  # the camera's pitch (gimbal convention: −90 looks straight down)
    camera_yaw_deg: np.ndarray  # the compass bearing the camera looks towards (its top edge faces)


@dataclass(frozen=True)
class RouteWaypoint:
    x: float
    y: float
    lon: float
    lat: float
    alt_m: float  # in the mission's altitude frame
    kind: str  # lead_in, line_start, terrain, line_end, detour, transit
    run: int
    station: str  # station id for waypoints placed on a station, else ""


#: A polygon ring as (lat, lon) pairs, not closed (the order the .plan geofence uses).
Ring = tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Fence:
    inclusion: tuple[Ring, ...]
    exclusion: tuple[Ring, ...]


class SortiePlan(NamedTuple):
    """One battery's flight: the split's record and its waypoints with lon/lat (unpacks as a pair)."""

    sortie: Sortie
    waypoints: tuple[RouteWaypoint, ...]


@dataclass(frozen=True, eq=False)
class Plan:
    """A planned survey: what every output (mission files, manifest, reports) is made from."""

    spec: MissionSpec
    planar: Planar
    area_wgs84: BaseGeometry
    area: BaseGeometry
    exclusions_wgs84: tuple[BaseGeometry, ...]
    exclusions: BaseGeometry | None
    heights: Heights
    gsd_target_m: float
    gsd_min_m: float
    gsd_max_m: float
    across_m: float
    along_m: float
    spacing_m: float
    base_m: float
    side_images_per_point: int
    forward_images_per_point: int
    speed: SpeedLimit
    trigger_interval_s: float | None
    lead_in_m: float
    turn_radius_m: float
    heading_deg: float
    heading_chosen: str
    passes: tuple[Pass, ...]
    route: Route
    stations: Stations
    waypoints: tuple[RouteWaypoint, ...]
    home: tuple[float, float, float]  # lon, lat, ground AMSL (0 without a DEM)
    home_xy: tuple[float, float]
    altitude_frame: str  # "relative" or "terrain"
    grid_scale: float  # planning-CRS metres per ground metre at the area
    trigger_distance_m: float | None  # DO_SET_CAM_TRIGG_DIST (distance triggering); base_m is the mean spacing flown
    estimates: Mapping[str, float]
    sun: Mapping[str, object] | None
    warnings: tuple[str, ...]
    fence_inclusion: tuple[Ring, ...]
    fence_exclusion: tuple[Ring, ...]
    launch_sites: tuple[LaunchSite, ...]
    sorties: tuple[SortiePlan, ...]
    battery: Budget | None  # the sortie budget when a battery is given
    coverage: Coverage  # the required ground fewer than two photos see (next to zones), exactly
    simplification: Simplification  # how the area's and the zones' boundaries were simplified
