"""The mission spec (TOML): load, validate, fill defaults.

Every error names the key (as `table.key`), the value found and what is allowed. The
format is documented in docs/mission-spec.md.
"""

from __future__ import annotations

import datetime as dt
import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from aerosurvey.camera import Camera, camera_from_mapping, get_camera
from aerosurvey.errors import InputError, bad_value

MOUNTS = ("landscape", "portrait")
#: camera.gimbal: fixed to the airframe (turns with a plane's crab) or stabilised (its image top along the track)
GIMBALS = ("body", "stabilised")
TRIGGERS = ("distance", "time", "camera", "hover")
VEHICLES = ("copter", "plane")
FIRMWARES = ("ardupilot", "px4")
TERRAIN_MODES = ("none", "fixed", "follow", "terrain-frame")
MISSION_ENDS = ("rtl", "land")


@dataclass(frozen=True)
class AreaSpec:
    """The spec's [area] table: the area (a vector file, or WKT in `wkt_crs`), the exclusion zone files, the launch point."""

    file: Path | None
    wkt: str | None
    wkt_crs: str
    exclusions: tuple[Path, ...]
    launch: tuple[float, float] | None  # (longitude, latitude)


@dataclass(frozen=True)
class CameraSpec:
    """The spec's [camera] table: the camera (from the database or given), its mount, how it is triggered, its limits."""

    camera: Camera
    mount: str
    # body: fixed to the airframe, turned with a plane's crab; stabilised: a gimbal holds its image top along the track
    gimbal: str
    # distance: autopilot by distance; time: autopilot by interval; camera: own intervalometer;
    # hover: stop and shoot at each station
    trigger: str
    interval_s: float | None
    settle_s: float  # hover: seconds held still at a station before the shot
    max_blur_px: float
    min_cycle_s: float
    exposure_s: float


@dataclass(frozen=True)
class Targets:
    """The spec's [targets] table: GSD or height, overlaps, images beyond the boundary, the coverage margin."""

    gsd_m: float | None
    height_m: float | None
    forward_overlap: float
    side_overlap: float
    images_beyond_boundary: int
    coverage_margin_m: float  # plan coverage for the area grown by this much (GCPs outside the outline)
    plan_at_cap: bool


@dataclass(frozen=True)
class PatternSpec:
    """The spec's [pattern] table: how photo runs are laid. `kind` names a pattern of the registry
    (plan/pattern.py); `options` are that pattern's own settings, read from its fields
    (`PatternKind.options`: e.g. a corridor's widths, an oblique's scheme and pitch)."""

    kind: str
    options: object = None


@dataclass(frozen=True)
class VehicleSpec:
    """The spec's [vehicle] table: copter or plane, firmware, speeds, turn and climb performance, the height cap."""

    type: str
    firmware: str
    cruise_speed_ms: float
    acceleration_ms2: float
    bank_angle_deg: float
    nav_period_s: float  # planes: ArduPlane's NAVL1_PERIOD, how fast the autopilot settles onto a line
    max_height_agl_m: float
    climb_rate_ms: float
    descent_rate_ms: float
    max_leg_m: float | None = None  # PX4: the longest leg between two places of a mission (None: ArduPilot, no limit)
    max_airspeed_ms: float | None = None  # copters: the air speed at the lean limit (None: not given; needed with a wind)
    max_airspeed_diagonal_ms: float | None = None  # copters: that 45° off the nose (None: the same as on it)
    landing_speed_ms: float | None = None  # planes: the landing approach's air speed (None: the survey speed)


@dataclass(frozen=True)
class FlightSpec:
    """The spec's [flight] table: heading, cross-hatch, zone margin, how the mission ends, lead-ins, landing approach."""

    heading_deg: float | None  # None: choose the fastest
    cross_hatch: bool
    exclusion_margin_m: float
    end: str
    lead_in_m: float | None
    fixed_yaw_deg: float | None  # copters: one heading for every photo
    wind_from_deg: float | None  # planes landing: the approach is flown into this wind
    approach_m: float
    approach_alt_m: float
    rally_points: tuple[tuple[float, float], ...] = ()  # (lon, lat): where RTL may go besides the launch sites
    pass_start: tuple[tuple[int, tuple[float, float]], ...] = ()  # (pass number, (lon, lat)): where the pilot starts it


@dataclass(frozen=True)
class TerrainSpec:
    """The spec's [terrain] table: the DEM, how heights follow it, and the clearances kept."""

    dem: Path | None
    mode: str
    tolerance_m: float
    min_clearance_m: float


@dataclass(frozen=True)
class BatterySpec:
    """Endurance per flight: minutes of flight or energy with power draws, less a reserve."""

    usable_min: float | None
    capacity_wh: float | None
    cruise_power_w: float | None
    climb_power_w: float | None
    reserve: float
    launch_points: tuple[tuple[float, float], ...]  # (lon, lat)
    launch: str  # "nearest" or the 1-based index of a launch point, as text
    max_mission_items: int
    #: a wind of unknown direction (m/s): an allowance on every sortie's level flight (planner.battery_sorties);
    #: conditions.wind, a wind with its direction, times every leg instead
    wind_ms: float = 0.0


@dataclass(frozen=True)
class WindSpec:
    """The wind the plan is flown in (conditions.wind, `--wind 6@240G9`): its mean speed, the TRUE bearing it blows
    FROM (as a forecast or a METAR gives it) and its gusts (the mean speed when not given)."""

    speed_ms: float
    from_deg: float
    gust_ms: float

    def text(self) -> str:
        """As `--wind` takes it: 6@240, or 6@240G9 with gusts."""
        gust = f"G{self.gust_ms:g}" if self.gust_ms > self.speed_ms else ""
        return f"{self.speed_ms:g}@{self.from_deg:g}{gust}"


@dataclass(frozen=True)
class ConditionsSpec:
    """The spec's [conditions] table: the planned time window, the lowest sun elevation allowed in it, the wind."""

    start: dt.datetime | None
    end: dt.datetime | None
    min_sun_elevation_deg: float
    wind: WindSpec | None = None


@dataclass(frozen=True)
class AirspaceSpec:
    """The spec's [airspace] table: official UAS zone files (ED-269, ED-318) the plan is checked against, and the
    identifiers of the zones the operator holds an authorisation for (docs/airspace.md)."""

    zones: tuple[Path, ...] = ()
    authorisations: tuple[str, ...] = ()


@dataclass(frozen=True)
class StructureSpec:
    """The spec's [structure] table: a structure whose faces the photos must cover (plan/surfaces.py): its
    footprint (a polygon file, read as the area is; or a circle, `centre` and `radius_m`: a round tower, a
    tank, a chimney), its base and top in metres above the ground under it, the photos each point of its
    walls and roof must be seen by, and the coarsest GSD on a face that counts (metres; None: any)."""

    file: Path | None
    base_m: float
    top_m: float
    min_images: int
    max_gsd_m: float | None
    centre: tuple[float, float] | None = None  # (longitude, latitude) of a round structure's axis
    radius_m: float | None = None


def _structure(t: _Table, base: Path) -> StructureSpec:
    raw = t.raw("file")
    centre = t.raw("centre")
    radius = t.number("radius_m", None, lo=0.0, lo_open=True, hi=10000.0)
    if raw is not None and (centre is not None or radius is not None):
        raise InputError("[structure] gives both structure.file and a circle (structure.centre, structure.radius_m); "
                         "allowed: one of them", key="structure.file")
    if raw is None and centre is None and radius is None:
        raise InputError("structure.file is missing: [structure] needs the structure's footprint (a polygon file, or "
                         "structure.centre and structure.radius_m for a round one)", key="structure.file")
    if raw is None and (centre is None or radius is None):
        missing = "structure.radius_m" if radius is None else "structure.centre"
        raise InputError(f"{missing} is missing: a round structure needs structure.centre and structure.radius_m",
                         key=missing)
    if centre is not None and (not isinstance(centre, list) or len(centre) != 2
                               or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in centre)
                               or not (-180 <= centre[0] <= 180 and -90 <= centre[1] <= 90)):
        raise bad_value("structure.centre", centre, "[longitude, latitude] in degrees")
    bottom = t.number("base_m", 0.0, lo=-1000.0, hi=10000.0) or 0.0
    top = t.number("top_m", None, lo=-1000.0, hi=10000.0)
    if top is None or top <= bottom:
        raise bad_value("structure.top_m", top, f"a height above structure.base_m ({bottom:g} m)")
    gsd_cm = t.number("max_gsd_cm", None, lo=0.0, lo_open=True, hi=1000.0)
    spec = StructureSpec(_path(base, raw, "structure.file") if raw is not None else None, bottom, top,
                         t.integer("min_images", 2, lo=1, hi=100), gsd_cm / 100.0 if gsd_cm is not None else None,
                         (float(centre[0]), float(centre[1])) if centre is not None else None, radius)
    t.done()
    return spec


@dataclass(frozen=True)
class LimitsSpec:
    """Sanity limits checked from the spec before any planning work (raise them for a real large job)."""

    max_photos: int = 100_000
    max_flight_hours: float = 100.0


@dataclass(frozen=True)
class MissionSpec:
    """A whole mission spec as `load_spec` reads it from TOML: every table checked, defaults filled in,
    file paths taken relative to the spec's folder."""

    name: str
    crs: str  # "auto" or an authority string such as "EPSG:5514"
    area: AreaSpec
    camera: CameraSpec
    targets: Targets
    vehicle: VehicleSpec
    flight: FlightSpec
    terrain: TerrainSpec
    conditions: ConditionsSpec
    profiles: tuple[str, ...]
    rule_overrides: dict[str, Any]
    battery: BatterySpec | None
    path: Path | None
    limits: LimitsSpec = LimitsSpec()
    pattern: PatternSpec = PatternSpec("area")
    airspace: AirspaceSpec = AirspaceSpec()
    structure: StructureSpec | None = None


class _Table:
    """A TOML table read key by key; leftover keys are reported as unknown."""

    def __init__(self, data: Any, name: str):
        if not isinstance(data, Mapping):
            raise bad_value(name, data, "a table")
        self.data = dict(data)
        self.name = name
        self.used: set[str] = set()

    def key(self, key: str) -> str:
        return f"{self.name}.{key}" if self.name else key

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = None) -> Any:
        self.used.add(key)
        return self.data.get(key, default)

    def number(self, key: str, default: float | None = None, *, lo: float | None = None,
               hi: float | None = None, lo_open: bool = False, hi_open: bool = False,
               required: bool = False) -> float | None:
        self.used.add(key)
        if key not in self.data:
            if required:
                raise InputError(f"{self.key(key)} is missing: it is required", key=self.key(key))
            return default
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise bad_value(self.key(key), v, "a finite number")
        v = float(v)
        bad_lo = lo is not None and (v <= lo if lo_open else v < lo)
        bad_hi = hi is not None and (v >= hi if hi_open else v > hi)
        if bad_lo or bad_hi:
            left = "(" if lo_open else "["
            right = ")" if hi_open else "]"
            raise bad_value(self.key(key), v, f"a number in {left}{'-inf' if lo is None else lo}, {'inf' if hi is None else hi}{right}")
        return v

    def integer(self, key: str, default: int, *, lo: int = 0, hi: int = 1000) -> int:
        self.used.add(key)
        v = self.data.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise bad_value(self.key(key), v, f"a whole number from {lo} to {hi}")
        return v

    def boolean(self, key: str, default: bool) -> bool:
        self.used.add(key)
        v = self.data.get(key, default)
        if not isinstance(v, bool):
            raise bad_value(self.key(key), v, "true or false")
        return v

    def choice(self, key: str, default: str, choices: tuple[str, ...]) -> str:
        self.used.add(key)
        v = self.data.get(key, default)
        if v not in choices:
            raise bad_value(self.key(key), v, "one of " + ", ".join(choices))
        return str(v)

    def string(self, key: str, default: str | None = None) -> str | None:
        self.used.add(key)
        v = self.data.get(key, default)
        if v is not None and not isinstance(v, str):
            raise bad_value(self.key(key), v, "a string")
        return v

    def table(self, key: str) -> _Table:
        self.used.add(key)
        return _Table(self.data.get(key, {}), self.key(key))

    def done(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            where = f"[{self.name}]" if self.name else "the top level"
            raise InputError(f"unknown key(s) in {where}: {', '.join(unknown)}; allowed: {', '.join(sorted(self.used))}")


def _path(base: Path, value: str, key: str) -> Path:
    if not isinstance(value, str) or not value:
        raise bad_value(key, value, "a file path (relative to the spec file)")
    p = Path(value)
    return p if p.is_absolute() else (base / p)


def _datetime(t: _Table, key: str) -> dt.datetime | None:
    v = t.raw(key)
    if v is None:
        return None
    if isinstance(v, str):
        try:
            v = dt.datetime.fromisoformat(v)
        except ValueError:
            raise bad_value(t.key(key), v, "an ISO 8601 date and time with a UTC offset, e.g. 2026-05-14T09:30:00+02:00") from None
    if not isinstance(v, dt.datetime) or v.tzinfo is None:
        raise bad_value(t.key(key), v, "a date and time with a UTC offset, e.g. 2026-05-14T09:30:00+02:00")
    return v


#: Mission items an autopilot holds (`battery.max_mission_items` overrides). ArduPilot keeps
#: missions in its storage area: ArduCopter 4.7 SITL refuses more than 650 items, home
#: included ("Only 650 items are supported", seen here); boards with more storage hold more.
#: PX4's dataman holds 2000.
MAX_ITEMS = {"ardupilot": 650, "px4": 2000}
#: PX4 v1.13 and earlier refuse, at arming, a mission whose consecutive places lie farther apart
#: than their parameter MIS_DIST_WPS (900 m by default; PX4 v1.14 removed the check, PX4 pull
#: request 21262): legs of PX4 missions longer than `vehicle.max_leg_m` (this by default) get
#: waypoints on them (mission/builder.py).
PX4_MAX_LEG_M = 900.0


def _lonlat_list(t: _Table, key: str) -> tuple[tuple[float, float], ...]:
    raw = t.raw(key, [])
    allowed = "a list of [longitude, latitude] pairs in degrees"
    if not isinstance(raw, list):
        raise bad_value(t.key(key), raw, allowed)
    out = []
    for p in raw:
        if (not isinstance(p, list) or len(p) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in p)
                or not (-180 <= p[0] <= 180 and -90 <= p[1] <= 90)):
            raise bad_value(t.key(key), p, allowed)
        out.append((float(p[0]), float(p[1])))
    return tuple(out)


def _pass_start(t: _Table) -> tuple[tuple[int, tuple[float, float]], ...]:
    """`flight.pass_start`: a table of pass number → [longitude, latitude]: where each pass starts."""
    raw = t.raw("pass_start", {})
    where = t.key("pass_start")
    if not isinstance(raw, dict):
        raise bad_value(where, raw, "a table of pass number = [longitude, latitude], e.g. { 1 = [14.95, 49.43] }")
    out = []
    for k, p in raw.items():
        if not (isinstance(k, str) and k.isdigit() and int(k) >= 1):
            raise bad_value(f"{where} key", k, "a pass number: 1 for the main pass, 2 for the cross-hatch, …")
        if (not isinstance(p, list) or len(p) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in p)
                or not (-180 <= p[0] <= 180 and -90 <= p[1] <= 90)):
            raise bad_value(f"{where}.{k}", p, "[longitude, latitude] in degrees")
        out.append((int(k), (float(p[0]), float(p[1]))))
    return tuple(sorted(out))


#: the most a copter's air speed at its lean limit 45° off its nose may exceed that on its nose: 2^¼, a drag
#: quadratic along each body axis alone; 1, the same in every direction (`plan.flight_time.lean_drag`)
DIAGONAL_GAIN_MAX = 2.0 ** 0.25


def _check_diagonal_airspeed(v: VehicleSpec) -> None:
    """vehicle.max_airspeed_diagonal_ms: with max_airspeed_ms, from it to 2^¼ times it (`DIAGONAL_GAIN_MAX`)."""
    d, n = v.max_airspeed_diagonal_ms, v.max_airspeed_ms
    if d is None:
        return
    if n is None:
        raise InputError(f"vehicle.max_airspeed_diagonal_ms = {d:g} needs vehicle.max_airspeed_ms (the air speed at the "
                         "lean limit straight on the nose)", key="vehicle.max_airspeed_diagonal_ms")
    if not n <= d <= DIAGONAL_GAIN_MAX * n:
        raise bad_value("vehicle.max_airspeed_diagonal_ms", d, f"from vehicle.max_airspeed_ms ({n:g}) to 2^¼ times it "
                        f"({DIAGONAL_GAIN_MAX * n:.3f}): a drag quadratic along each body axis at most")


def _battery(top: _Table, vehicle: VehicleSpec) -> BatterySpec:
    b = top.table("battery")
    minutes = b.number("usable_min", None, lo=0.0, lo_open=True, hi=1440.0)
    wh = b.number("capacity_wh", None, lo=0.0, lo_open=True)
    cruise_w = b.number("cruise_power_w", None, lo=0.0, lo_open=True)
    climb_w = b.number("climb_power_w", None, lo=0.0, lo_open=True)
    if (minutes is None) == (wh is None):
        raise InputError("[battery] needs exactly one of 'usable_min' (flight minutes) or 'capacity_wh' (with cruise_power_w)")
    if wh is not None and cruise_w is None:
        raise InputError("battery.capacity_wh needs battery.cruise_power_w (the power drawn in level flight)")
    launch = b.raw("launch", "nearest")
    points = _lonlat_list(b, "launch_points")
    if not (launch == "nearest" or (isinstance(launch, int) and not isinstance(launch, bool) and 1 <= launch <= max(1, len(points)))):
        raise bad_value("battery.launch", launch, f'"nearest" or the number (1..{max(1, len(points))}) of one of battery.launch_points')
    spec = BatterySpec(
        usable_min=minutes, capacity_wh=wh, cruise_power_w=cruise_w,
        climb_power_w=climb_w if climb_w is not None else (1.3 * cruise_w if cruise_w else None),
        reserve=b.number("reserve", 0.25, lo=0.0, hi=0.9) or 0.0,
        launch_points=points, launch=str(launch),
        max_mission_items=b.integer("max_mission_items", MAX_ITEMS[vehicle.firmware], lo=20, hi=100000),
        wind_ms=b.number("wind_ms", 0.0, lo=0.0, hi=50.0) or 0.0,
    )
    b.done()
    return spec


def _airspace(t: _Table, base: Path) -> AirspaceSpec:
    zones = t.raw("zones", [])
    if not isinstance(zones, list):
        raise bad_value("airspace.zones", zones, "a list of ED-269 or ED-318 zone files")
    auth = t.raw("authorisations", [])
    if not isinstance(auth, list) or not all(isinstance(a, str) and a.strip() for a in auth):
        raise bad_value("airspace.authorisations", auth, "a list of zone identifiers the operator is authorised for")
    t.done()
    return AirspaceSpec(tuple(_path(base, z, "airspace.zones") for z in zones), tuple(a.strip() for a in auth))


def _conditions_wind(co: _Table) -> WindSpec | None:
    """conditions.wind: a table {speed_ms, from_deg, gust_ms} or the text --wind takes ("6@240G9")."""
    raw = co.raw("wind")
    if raw is None:
        return None
    return parse_wind(raw, "conditions.wind") if isinstance(raw, str) else _wind(co.table("wind"))


def _wind(w: _Table) -> WindSpec:
    speed = w.number("speed_ms", required=True, lo=0.0, hi=60.0) or 0.0
    wind = WindSpec(speed, w.number("from_deg", required=True, lo=0.0, hi=360.0, hi_open=True) or 0.0,
                    w.number("gust_ms", speed, lo=speed, hi=80.0) or 0.0)
    w.done()
    return wind


#: `--wind`: SPEED@FROM or SPEED@FROMGGUST (m/s, degrees true the wind blows from, m/s)
WIND_TEXT = re.compile(r"^\s*(\d+(?:\.\d*)?)\s*@\s*(\d+(?:\.\d*)?)\s*(?:G\s*(\d+(?:\.\d*)?))?\s*$", re.IGNORECASE)


def parse_wind(text: str, key: str = "--wind") -> WindSpec:
    """`--wind` text (6@240, 6@240G9) read as conditions.wind is, with its limits."""
    m = WIND_TEXT.match(text)
    if m is None:
        raise bad_value(key, text, "SPEED@FROM or SPEED@FROMGGUST: m/s and the true bearing it blows from, e.g. 6@240 or 6@240G9")
    data = {"speed_ms": float(m[1]), "from_deg": float(m[2]), **({"gust_ms": float(m[3])} if m[3] else {})}
    try:
        return _wind(_Table(data, "conditions.wind"))
    except InputError as exc:
        raise InputError(f"{key} {text!r}: {exc}", key=key) from None


def with_wind(spec: MissionSpec, text: str | None) -> MissionSpec:
    """`spec` with the wind of the commands' --wind (over its conditions.wind)."""
    if text is None:
        return spec
    return replace(spec, conditions=replace(spec.conditions, wind=parse_wind(text)))


def with_zone_files(spec: MissionSpec, files: Sequence[Path]) -> MissionSpec:
    """`spec` with official zone files besides its [airspace] zones (the commands' --zones)."""
    if not files:
        return spec
    return replace(spec, airspace=replace(spec.airspace, zones=spec.airspace.zones + tuple(files)))


def _pattern(top: _Table, flight: FlightSpec) -> PatternSpec:
    """The [pattern] table, read by the fields of the registry's pattern of its kind."""
    from aerosurvey.plan.pattern import PATTERNS

    p = top.table("pattern")
    kind = p.choice("kind", "area", tuple(PATTERNS))
    pattern = PATTERNS[kind]
    values: dict[str, Any] = {}
    for f in pattern.fields:
        if f.type == "choice":
            values[f.key] = p.choice(f.key, str(f.default), tuple(c for c, _ in f.choices))
        else:
            v = p.number(f.key, None if f.default is None else float(f.default), lo=f.lo, hi=f.hi, lo_open=f.lo_open)
            values[f.key] = None if v is None else v * f.scale
    p.done()
    return PatternSpec(kind, pattern.options(values, flight))


def load_spec(path: str | Path) -> MissionSpec:
    """Read and validate a mission spec file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"mission spec {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"mission spec {str(path)!r} cannot be read: {exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"mission spec {str(path)!r} is not valid TOML: {exc}") from None
    return parse_spec(data, base=path.parent, path=path)


def parse_spec(data: Mapping[str, Any], base: Path, path: Path | None = None) -> MissionSpec:
    """Validate a spec already parsed from TOML; relative paths are resolved against `base`."""
    top = _Table(data, "")
    mission = top.table("mission")
    name = mission.string("name", path.stem if path else "mission") or "mission"
    crs = mission.string("crs", "auto") or "auto"
    mission.done()

    a = top.table("area")
    area_file = a.raw("file")
    wkt = a.string("wkt")
    if (area_file is None) == (wkt is None):
        raise InputError("[area] needs exactly one of 'file' (an area file) or 'wkt' (a WKT polygon in longitude/latitude)")
    exclusions_raw = a.raw("exclusions", [])
    if not isinstance(exclusions_raw, list):
        raise bad_value("area.exclusions", exclusions_raw, "a list of file paths")
    launch_raw = a.raw("launch")
    launch = None
    if launch_raw is not None:
        if (not isinstance(launch_raw, list) or len(launch_raw) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in launch_raw)):
            raise bad_value("area.launch", launch_raw, "[longitude, latitude] in degrees")
        lon, lat = float(launch_raw[0]), float(launch_raw[1])
        if not (-180 <= lon <= 180 and -90 <= lat <= 90):
            raise bad_value("area.launch", launch_raw, "[longitude, latitude] with longitude in [-180, 180] and latitude in [-90, 90]")
        launch = (lon, lat)
    area = AreaSpec(
        file=_path(base, area_file, "area.file") if area_file is not None else None,
        wkt=wkt,
        wkt_crs=a.string("wkt_crs", "EPSG:4326") or "EPSG:4326",
        exclusions=tuple(_path(base, e, "area.exclusions") for e in exclusions_raw),
        launch=launch,
    )
    a.done()

    c = top.table("camera")
    model = c.raw("model")
    if isinstance(model, str):
        cam = get_camera(model)
    elif isinstance(model, Mapping):
        cam = camera_from_mapping("inline", model, "camera.model")
    else:
        raise bad_value("camera.model", model, "a camera id from `aerosurvey cameras` or an inline table with the sensor")
    trigger = c.choice("trigger", "distance", TRIGGERS)
    interval = c.number("interval_s", None, lo=0.0, lo_open=True)
    vehicle_raw = top.data.get("vehicle")
    plane = isinstance(vehicle_raw, Mapping) and vehicle_raw.get("type") == "plane"  # (the type is checked with [vehicle])
    camera = CameraSpec(
        camera=cam,
        mount=c.choice("mount", "landscape", MOUNTS),
        gimbal=c.choice("gimbal", "body" if plane else "stabilised", GIMBALS),
        trigger=trigger,
        interval_s=interval,
        settle_s=c.number("settle_s", 1.0, lo=0.0, hi=30.0) or 0.0,
        max_blur_px=c.number("max_blur_px", 0.5, lo=0.05, hi=5.0) or 0.5,
        min_cycle_s=c.number("min_cycle_s", cam.min_cycle_s, lo=0.0, lo_open=True) or cam.min_cycle_s,
        exposure_s=c.number("exposure_s", cam.exposure_s, lo=0.0, lo_open=True) or cam.exposure_s,
    )
    c.done()

    t = top.table("targets")
    gsd_cm = t.number("gsd_cm", None, lo=0.0, lo_open=True, hi=100.0)
    height = t.number("height_m", None, lo=0.0, lo_open=True)
    if (gsd_cm is None) == (height is None):
        raise InputError("[targets] needs exactly one of 'gsd_cm' or 'height_m'")
    targets = Targets(
        gsd_m=gsd_cm / 100.0 if gsd_cm is not None else None,
        height_m=height,
        forward_overlap=t.number("forward_overlap", 0.75, lo=0.0, hi=0.95, hi_open=True) or 0.0,
        side_overlap=t.number("side_overlap", 0.60, lo=0.0, hi=0.95, hi_open=True) or 0.0,
        images_beyond_boundary=t.integer("images_beyond_boundary", 0, lo=0, hi=50),
        coverage_margin_m=t.number("coverage_margin_m", 0.0, lo=0.0, hi=1000.0) or 0.0,
        plan_at_cap=t.boolean("plan_at_cap", False),
    )
    t.done()

    v = top.table("vehicle")
    vtype = v.choice("type", "copter", VEHICLES)
    firmware = v.choice("firmware", "ardupilot", FIRMWARES)
    if firmware != "px4" and v.raw("max_leg_m") is not None:
        raise InputError(f"vehicle.max_leg_m is set but vehicle.firmware is {firmware!r}: it limits the legs of PX4 "
                         "missions only (ArduPilot has no such limit); remove it or set vehicle.firmware = \"px4\"",
                         key="vehicle.max_leg_m")
    vehicle = VehicleSpec(
        type=vtype,
        firmware=firmware,
        cruise_speed_ms=v.number("cruise_speed_ms", 10.0 if vtype == "copter" else 18.0, lo=0.5, hi=60.0) or 0.0,
        acceleration_ms2=v.number("acceleration_ms2", 2.5, lo=0.1, hi=20.0) or 0.0,
        bank_angle_deg=v.number("bank_angle_deg", 30.0, lo=5.0, hi=60.0) or 0.0,
        nav_period_s=v.number("nav_period_s", 17.0, lo=5.0, hi=60.0) or 0.0,
        max_height_agl_m=v.number("max_height_agl_m", 120.0, lo=1.0, hi=10000.0) or 0.0,
        climb_rate_ms=v.number("climb_rate_ms", 2.5 if vtype == "copter" else 3.0, lo=0.1, hi=30.0) or 0.0,
        descent_rate_ms=v.number("descent_rate_ms", 1.5 if vtype == "copter" else 2.0, lo=0.1, hi=30.0) or 0.0,
        max_leg_m=v.number("max_leg_m", PX4_MAX_LEG_M, lo=10.0, hi=100000.0) if firmware == "px4" else None,
        max_airspeed_ms=v.number("max_airspeed_ms", None, lo=0.5, hi=100.0) if vtype == "copter" else None,
        max_airspeed_diagonal_ms=v.number("max_airspeed_diagonal_ms", None, lo=0.5, hi=200.0) if vtype == "copter" else None,
        landing_speed_ms=v.number("landing_speed_ms", None, lo=0.5, hi=100.0) if vtype == "plane" else None,
    )
    if vtype == "plane" and v.has("max_airspeed_ms"):
        raise InputError("vehicle.max_airspeed_ms is for copters (the air speed at their lean limit); a plane flies its "
                         "survey speed through the air", key="vehicle.max_airspeed_ms")
    if vtype == "plane" and v.has("max_airspeed_diagonal_ms"):
        raise InputError("vehicle.max_airspeed_diagonal_ms is for copters (the air speed at their lean limit 45° off the "
                         "nose); a plane flies its survey speed through the air", key="vehicle.max_airspeed_diagonal_ms")
    _check_diagonal_airspeed(vehicle)
    if vtype == "copter" and v.has("landing_speed_ms"):
        raise InputError("vehicle.landing_speed_ms is for planes (the air speed of their landing approach); a copter "
                         "lands straight down", key="vehicle.landing_speed_ms")
    v.done()

    f = top.table("flight")
    heading_raw = f.raw("heading", "auto")
    if heading_raw == "auto":
        heading = None
    elif isinstance(heading_raw, (int, float)) and not isinstance(heading_raw, bool) and math.isfinite(heading_raw):
        heading = float(heading_raw) % 180.0
    else:
        raise bad_value("flight.heading", heading_raw, "\"auto\" or a bearing in degrees (0 = north, 90 = east)")
    flight = FlightSpec(
        heading_deg=heading,
        cross_hatch=f.boolean("cross_hatch", False),
        exclusion_margin_m=f.number("exclusion_margin_m", 10.0, lo=0.0, hi=1000.0) or 0.0,
        end=f.choice("end", "rtl", MISSION_ENDS),
        lead_in_m=f.number("lead_in_m", None, lo=0.0, hi=2000.0),
        fixed_yaw_deg=f.number("fixed_yaw_deg", None, lo=0.0, hi=360.0, hi_open=True),
        wind_from_deg=f.number("wind_from_deg", None, lo=0.0, hi=360.0, hi_open=True),
        approach_m=f.number("approach_m", 300.0, lo=20.0, hi=5000.0) or 300.0,
        approach_alt_m=f.number("approach_alt_m", 30.0, lo=5.0, hi=500.0) or 30.0,
        rally_points=_lonlat_list(f, "rally_points"),
        pass_start=_pass_start(f),
    )
    f.done()
    if camera.trigger == "hover" and vtype == "plane":
        raise InputError("camera.trigger = 'hover' is for copters: a plane cannot stop at a station")
    if flight.fixed_yaw_deg is not None and vtype == "plane":
        raise InputError("flight.fixed_yaw_deg is for copters: a plane always points along its track")
    if vtype == "plane" and flight.end == "land" and flight.wind_from_deg is None:
        raise InputError("flight.end = 'land' for a plane needs flight.wind_from_deg: the landing approach is flown into the wind")
    if vtype == "plane" and flight.end == "land" and vehicle.max_leg_m is not None and flight.approach_m > vehicle.max_leg_m:
        raise InputError(f"flight.approach_m = {flight.approach_m:g} is longer than vehicle.max_leg_m = {vehicle.max_leg_m:g}: "
                         "PX4 refuses a leg that long and a landing approach is not cut; allowed: up to vehicle.max_leg_m",
                         key="flight.approach_m")

    tr = top.table("terrain")
    dem_raw = tr.raw("dem")
    dem = _path(base, dem_raw, "terrain.dem") if dem_raw is not None else None
    mode = tr.choice("mode", "fixed" if dem is not None else "none", TERRAIN_MODES)
    if mode != "none" and dem is None and mode != "terrain-frame":
        raise InputError(f"terrain.mode = {mode!r} needs terrain.dem (a DEM GeoTIFF)")
    if mode == "none" and dem is not None:
        raise InputError("terrain.dem is given but terrain.mode = 'none'; choose fixed, follow or terrain-frame")
    terrain = TerrainSpec(
        dem=dem,
        mode=mode,
        tolerance_m=tr.number("tolerance_m", 5.0, lo=0.1, hi=100.0) or 5.0,
        min_clearance_m=tr.number("min_clearance_m", 20.0, lo=0.0, hi=1000.0) or 0.0,
    )
    tr.done()

    co = top.table("conditions")
    start = _datetime(co, "start")
    end = _datetime(co, "end")
    if (start is None) != (end is None):
        raise InputError("[conditions] needs both 'start' and 'end' (or neither)")
    if start is not None and end is not None and end <= start:
        raise bad_value("conditions.end", end.isoformat(), f"a time after conditions.start ({start.isoformat()})")
    conditions = ConditionsSpec(
        start=start,
        end=end,
        min_sun_elevation_deg=co.number("min_sun_elevation_deg", 20.0, lo=-10.0, hi=90.0) or 0.0,
        wind=_conditions_wind(co),
    )
    co.done()

    battery = _battery(top, vehicle) if top.has("battery") else None
    pattern = _pattern(top, flight)

    airspace = _airspace(top.table("airspace"), base)
    structure = _structure(top.table("structure"), base) if top.has("structure") else None

    lt = top.table("limits")
    limits = LimitsSpec(
        max_photos=lt.integer("max_photos", LimitsSpec.max_photos, lo=1, hi=100_000_000),
        max_flight_hours=lt.number("max_flight_hours", LimitsSpec.max_flight_hours, lo=0.01, hi=100_000.0)
        or LimitsSpec.max_flight_hours,
    )
    lt.done()

    r = top.table("rules")
    profiles = r.raw("profiles", [])
    if not isinstance(profiles, list) or not all(isinstance(p, str) for p in profiles):
        raise bad_value("rules.profiles", profiles, "a list of rule profile ids")
    overrides = r.raw("overrides", {})
    if not isinstance(overrides, Mapping) or not all("." in k for k in overrides):
        raise bad_value("rules.overrides", overrides, 'a table of "rule-id.parameter" = value')
    r.done()
    top.done()

    return MissionSpec(
        name=name, crs=crs, area=area, camera=camera, targets=targets, vehicle=vehicle,
        flight=flight, terrain=terrain, conditions=conditions, profiles=tuple(profiles),
        rule_overrides=dict(overrides), battery=battery, path=path, limits=limits, pattern=pattern, airspace=airspace,
        structure=structure,
    )
