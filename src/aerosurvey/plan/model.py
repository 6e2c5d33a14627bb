"""The data a plan is made of: frozen records passed from step to step, and the `Plan` the
pipeline returns. Nothing here is filled in after construction.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from aerosurvey.airspace.model import Airspace
    from aerosurvey.plan.altitudes import Altitudes
    from aerosurvey.plan.bounds import GridBounds
    from aerosurvey.plan.coverage import Coverage
    from aerosurvey.plan.landing import Landing
    from aerosurvey.plan.layout import Layout
    from aerosurvey.plan.passes import Pass, Route
    from aerosurvey.plan.sensor import SensorSolution
    from aerosurvey.plan.site import Site
    from aerosurvey.plan.sorties import Budget, LaunchSite, Sortie
    from aerosurvey.plan.surfaces import FacesCheck
    from aerosurvey.spec import CameraSpec, PatternSpec, VehicleSpec


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


@dataclass(frozen=True)
class Launch:
    """Where the flights start and end and where they may fly: the launch, fence and landing steps' decisions."""

    home: tuple[float, float, float]  # lon, lat, ground AMSL (0 without a DEM)
    home_xy: tuple[float, float]  # planning CRS
    sites: tuple[LaunchSite, ...]  # where sorties may start: the battery's launch points, else home
    rally: tuple[LaunchSite, ...]  # the spec's rally points: where RTL may go besides the launch sites
    fence: Fence
    landing: Landing  # how a flight ends: land (a plane on its approach) or RTL
    fixed_yaw_deg: float | None  # copters: the nose's one heading for the whole flight; None: along the track


@dataclass(frozen=True, eq=False)
class Plan:
    """A planned survey, each part the record of the step that decided it: what every output
    (mission files, manifest, reports) is made from. It holds decisions, not the spec: the
    vehicle and camera it was planned for, the pattern flown, then each step's result."""

    name: str
    vehicle: VehicleSpec
    camera: CameraSpec  # the camera, its mount and how it is triggered
    pattern: PatternSpec
    site: Site  # the area and zones in the planning CRS, the relief
    sensor: SensorSolution  # heights, GSD, footprint, spacing, base, speed, trigger
    layout: Layout  # the heading and the passes of strips
    route: Route  # the runs in flight order
    altitudes: Altitudes  # the stations and survey waypoints with their heights, the altitude frame
    launch: Launch
    waypoints: tuple[RouteWaypoint, ...]  # the whole flight: the survey's with the transits from and back home
    sorties: tuple[SortiePlan, ...]  # battery flights; () without a [battery] table
    # the sorties' budget: a battery's (its reserve set) when [battery] is given; for a resumed plan
    # without one, only the autopilot's item limit (reserve None); None when no sorties were split
    battery: Budget | None
    coverage: Coverage  # the required ground fewer than two photos see (next to zones), exactly
    bounds: GridBounds  # the strip and photo counts no grid can go below
    estimates: Mapping[str, float]
    sun: Mapping[str, object] | None
    warnings: tuple[str, ...]
    # the wind planned in (conditions.wind: speed_ms, from_deg, gust_ms; grid_from_deg at the area's centre); None: still air
    wind: Mapping[str, float] | None = None
    # the official UAS zones the flights are checked against (airspace/check.py), as given; None without [airspace] zones
    airspace: Airspace | None = None
    # [structure]: which of its walls' and roof's points the photos see, and how often; None without one
    faces: FacesCheck | None = None

    def crab_deg(self, p: Pass) -> float | None:
        """How far the camera of pass `p` is turned by the plane's crab against its lines (camera.gimbal =
        "body", a plane in the wind, a pass looking along the flight); None where it is not."""
        kin = self.sensor.kinematics
        if self.camera.gimbal != "body" or kin.vehicle != "plane" or kin.calm or p.frame is None or p.aim.look != "along":
            return None
        return kin.crab_deg(90.0 - p.frame.heading_deg)

    @property
    def stations(self) -> Stations:
        """The photo stations in flight order (the altitudes step's)."""
        return self.altitudes.stations
