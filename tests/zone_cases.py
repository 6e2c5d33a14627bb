"""Random survey cases with no-fly zones, for the zone safety property test and benchmark.

A case is drawn from a few plain parameters (`CaseParams`): the kind of area (convex,
concave, holed, corridor), its size (0.5-300 ha), where on Earth (latitudes 0, 35, 50 and
65, north and south, any longitude), the vehicle (copter or plane), one to three zones
crossing the boundary, inside the area or just outside it, with or without a [battery]
table (sorties), a launch point given or the default, RTL or land, the zone margin and a
seed for the shapes. `make_case` turns them into lon/lat geometry and a spec table;
`write_case` writes `spec.toml`, `area.geojson` and `zone-N.geojson` into a folder.
`random_params(rng)` draws parameters with numpy (the benchmark), `case_params()` is the
hypothesis strategy over the same parameters (the property test): both give the same
kind of case through `make_case`.

Shapes are built in metres in an azimuthal equidistant projection centred at the case's
origin and written as WGS84 longitude/latitude.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyproj
import shapely
import shapely.affinity
import tomli_w
from hypothesis import strategies as st

import independent_legs as il

# the planner's public entry points only (spec loader, planner, output writer): the checker never sees them
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import write_outputs
from aerosurvey.spec import load_spec

KINDS = ("convex", "concave", "holed", "corridor")
LATITUDES = (0.0, 35.0, 50.0, 65.0)
PLACEMENTS = ("crossing", "inside", "outside")
VEHICLES = ("copter", "plane")
MARGINS = (5.0, 10.0, 20.0, 30.0)


@dataclass(frozen=True)
class CaseParams:
    kind: str
    size_ha: float
    lat: float  # one of LATITUDES, with the hemisphere's sign
    lon: float
    vehicle: str
    zones: tuple[str, ...]  # a placement per zone
    battery_min: float | None  # usable minutes, or no [battery] table
    launch: str  # "default", "given" (area.launch), "points" (battery.launch_points)
    end: str  # "rtl" or "land"
    margin_m: float
    height_m: float
    heading: float | None  # None = auto
    seed: int


@dataclass(frozen=True)
class Case:
    params: CaseParams
    area: shapely.Geometry  # lon/lat polygon (holes = need no photos)
    zones: tuple[shapely.Geometry, ...]  # lon/lat polygons, as written to the zone files
    spec: dict[str, Any]  # the spec's tables, file names relative to the case folder
    origin: tuple[float, float]  # lon, lat of the projection the shapes were built in

    def describe(self) -> str:
        p = self.params
        return (f"{p.kind} {p.size_ha:.1f} ha at {p.lat:+.0f} {p.lon:+.1f}, {p.vehicle}, zones {','.join(p.zones)}, "
                f"margin {p.margin_m:g} m, battery {p.battery_min}, launch {p.launch}, end {p.end}, "
                f"height {p.height_m:g} m, heading {p.heading}, seed {p.seed}")


def _projection(lon: float, lat: float) -> pyproj.Transformer:
    crs = pyproj.CRS.from_proj4(f"+proj=aeqd +lat_0={lat} +lon_0={lon} +datum=WGS84 +units=m")
    return pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True)


def _scaled(g: shapely.Geometry, area_m2: float) -> shapely.Geometry:
    c = g.centroid
    k = math.sqrt(area_m2 / g.area)
    return shapely.affinity.scale(shapely.affinity.translate(g, -c.x, -c.y), k, k, origin=(0, 0))


def _star(rng: np.random.Generator, n: int, lo: float) -> shapely.Geometry:
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = rng.uniform(lo, 1.0, n)
    g = shapely.Polygon(np.column_stack([rad * np.cos(ang), rad * np.sin(ang)]))
    return g if g.is_valid and g.area > 0.05 else shapely.convex_hull(g)


def _area_shape(p: CaseParams, rng: np.random.Generator) -> shapely.Geometry:
    """The area in metres, about `size_ha` hectares, centred at the origin."""
    target = p.size_ha * 10_000.0
    if p.kind == "convex":
        g = shapely.convex_hull(shapely.MultiPoint(rng.uniform(-1, 1, (10, 2))))
        return _scaled(shapely.affinity.scale(g, rng.uniform(1, 2.5), 1.0), target)
    if p.kind == "concave":
        return _scaled(_star(rng, int(rng.integers(6, 12)), 0.3), target)
    if p.kind == "holed":
        outer = _scaled(_star(rng, 9, 0.7), target * 1.15)
        r = math.sqrt(target) * 0.12
        holes: list[shapely.Geometry] = []
        for _ in range(int(rng.integers(1, 3))):
            for _try in range(10):
                c = rng.uniform(-0.3, 0.3, 2) * math.sqrt(target)
                h = shapely.affinity.translate(_scaled(_star(rng, 7, 0.6), (r * rng.uniform(0.6, 1.4)) ** 2), *c)
                if outer.buffer(-r / 2).contains(h) and not any(h.intersects(o.buffer(r / 4)) for o in holes):
                    holes.append(h)
                    break
        return shapely.difference(outer, shapely.union_all(holes)) if holes else outer
    # corridor: a bent strip 30-120 m wide
    width = float(rng.uniform(30, 120))
    length = target / width
    n = int(rng.integers(2, 5))
    pts = [(0.0, 0.0)]
    bearing = rng.uniform(0, 2 * np.pi)
    for _ in range(n):
        bearing += rng.uniform(-0.8, 0.8)
        s = length / n
        pts.append((pts[-1][0] + s * math.cos(bearing), pts[-1][1] + s * math.sin(bearing)))
    g = shapely.buffer(shapely.LineString(pts), width / 2, cap_style="flat", join_style="mitre")
    g = g if isinstance(g, shapely.Polygon) else shapely.convex_hull(g)
    c = g.centroid
    return shapely.affinity.translate(g, -c.x, -c.y)


def _zone(kind: str, area: shapely.Geometry, margin: float, rng: np.random.Generator, scale: float) -> shapely.Geometry | None:
    """A zone crossing the area's boundary, inside it, or just outside it (1-30 m away)."""
    side = math.sqrt(area.area)
    width = min(side, math.sqrt(area.area / max(area.length / 2, 1.0)) * 2 + 20)  # corridors are thin
    r = max(12.0, scale * float(rng.uniform(0.08, 0.3)) * min(side, 4 * width))
    shape = _scaled(_star(rng, int(rng.integers(5, 9)), 0.55) if rng.random() < 0.5
                    else shapely.box(-1, -0.5 - rng.random(), 1, 0.5), (r * 1.6) ** 2)
    shape = shapely.affinity.rotate(shape, float(rng.uniform(0, 180)), origin=(0, 0))
    if kind == "inside":
        core = shapely.buffer(area, -r * 1.1)
        if core.is_empty:
            kind = "crossing"
        else:
            for _ in range(30):
                x0, y0, x1, y1 = core.bounds
                x, y = rng.uniform(x0, x1), rng.uniform(y0, y1)
                if core.contains(shapely.Point(x, y)):
                    z = shapely.affinity.translate(shape, x, y)
                    return z if area.contains(z) else None
            kind = "crossing"
    outer = max(shapely.get_parts(area), key=lambda g: g.area)
    boundary = outer.exterior
    pt = boundary.interpolate(float(rng.uniform(0, boundary.length)))
    z = shapely.affinity.translate(shape, pt.x, pt.y)
    if kind == "outside":
        gap = float(rng.uniform(1.0, 30.0))
        z = shapely.difference(z, shapely.buffer(area, gap))
        parts = sorted(shapely.get_parts(z), key=lambda g: -g.area)
        return parts[0] if parts and parts[0].area > 50.0 else None
    return z


def make_case(p: CaseParams) -> Case:
    rng = np.random.default_rng(p.seed)
    area = _area_shape(p, rng)
    zones: list[shapely.Geometry] = []
    for scale in (1.0, 0.6, 0.35, 0.2):
        zones = [z for kind in p.zones if (z := _zone(kind, area, p.margin_m, rng, scale)) is not None and z.is_valid]
        if not zones:
            continue
        left = shapely.difference(area, shapely.buffer(shapely.union_all(zones), p.margin_m)).area
        if left >= 0.3 * area.area:
            break
    else:
        zones = zones[:0]
    # area.launch: near the area, inside or up to 150 m outside (it may fall in a zone: the planner must refuse that)
    x0, y0, x1, y1 = shapely.buffer(area, 150.0).bounds
    launch_xy = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))
    for _ in range(50):
        if shapely.distance(area, shapely.Point(launch_xy)) <= 150.0:
            break
        launch_xy = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))
    to_ll = _projection(p.lon, p.lat)

    def ll(g: shapely.Geometry) -> shapely.Geometry:
        return shapely.transform(g, lambda a: np.column_stack(to_ll.transform(a[:, 0], a[:, 1])))

    area_ll = ll(area)
    zones_ll = tuple(ll(z) for z in zones)
    copter = p.vehicle == "copter"
    spec: dict[str, Any] = {
        "mission": {"name": f"case-{p.seed}"},
        "area": {"file": "area.geojson", "exclusions": [f"zone-{k + 1}.geojson" for k in range(len(zones_ll))]},
        "camera": {"model": "sony-a6000-16mm"},
        "targets": {"height_m": p.height_m, "forward_overlap": 0.75 if copter else 0.7, "side_overlap": 0.6},
        "vehicle": {"type": p.vehicle, "cruise_speed_ms": 10.0 if copter else 18.0},
        "flight": {"exclusion_margin_m": p.margin_m, "end": p.end, "heading": "auto" if p.heading is None else p.heading},
    }
    if p.end == "land" and not copter:
        spec["flight"]["wind_from_deg"] = float(rng.uniform(0, 359))
    lon_l, lat_l = to_ll.transform(*launch_xy)
    if p.launch == "given":
        spec["area"]["launch"] = [round(float(lon_l), 8), round(float(lat_l), 8)]
    if p.battery_min is not None:
        spec["battery"] = {"usable_min": p.battery_min, "reserve": 0.25}
        if p.launch == "points":
            x0, y0, x1, y1 = area.bounds
            pts = [launch_xy, (x0 - 40.0, (y0 + y1) / 2), (x1 + 40.0, (y0 + y1) / 2)]
            spec["battery"]["launch_points"] = [[round(float(a), 8), round(float(b), 8)]
                                                for a, b in (to_ll.transform(*q) for q in pts)]
    return Case(p, area_ll, zones_ll, spec, (p.lon, p.lat))


def _feature_collection(g: shapely.Geometry) -> str:
    geom = json.loads(shapely.to_geojson(g))
    return json.dumps({"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, "geometry": geom}]})


def write_case(case: Case, folder: Path) -> Path:
    """Write the case's spec and GeoJSON files into `folder`; the spec's path."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "area.geojson").write_text(_feature_collection(case.area))
    for k, z in enumerate(case.zones, start=1):
        (folder / f"zone-{k}.geojson").write_text(_feature_collection(z))
    path = folder / "spec.toml"
    path.write_text(tomli_w.dumps(case.spec))
    return path


def _size(u: float) -> float:
    """0.5-300 ha, log-uniform in u in [0, 1]."""
    return float(round(0.5 * 600.0 ** float(u), 2))


def _params(kind: str, u_size: float, lat: float, south: bool, lon: float, vehicle: str, zones: tuple[str, ...],
            battery: float | None, launch: str, end: str, margin: float, height: float, heading: float | None,
            seed: int) -> CaseParams:
    size = _size(u_size)
    if kind == "corridor":
        size = min(size, 40.0)
    if battery is not None and vehicle == "plane":
        battery *= 2.0
    if launch == "points" and battery is None:
        launch = "default"
    return CaseParams(kind, size, -lat if south else lat, lon, vehicle, zones, battery, launch, end, margin,
                      height, heading, seed)


def random_params(rng: np.random.Generator) -> CaseParams:
    """Parameters drawn with numpy: the benchmark's cases."""
    n = int(rng.integers(1, 4))
    return _params(
        kind=str(rng.choice(KINDS)), u_size=float(rng.uniform(0, 1)), lat=float(rng.choice(LATITUDES)),
        south=bool(rng.random() < 0.5), lon=round(float(rng.uniform(-170, 170)), 3),
        vehicle="copter" if rng.random() < 0.6 else "plane",
        zones=tuple(str(rng.choice(PLACEMENTS)) for _ in range(n)),
        battery=round(float(rng.uniform(6, 20)), 1) if rng.random() < 0.4 else None,
        launch=str(rng.choice(["default", "default", "given", "points"])), end=str(rng.choice(["rtl", "land"])),
        margin=float(rng.choice(MARGINS)), height=float(rng.choice([60.0, 80.0, 100.0, 120.0])),
        heading=None if rng.random() < 0.5 else round(float(rng.uniform(0, 180)), 1),
        seed=int(rng.integers(0, 2**31)),
    )


def case_params(max_ha: float = 300.0) -> st.SearchStrategy[CaseParams]:
    """The hypothesis strategy over the same parameters (sizes up to `max_ha`)."""
    u_max = math.log(max_ha / 0.5) / math.log(600.0)
    return st.builds(
        _params,
        kind=st.sampled_from(KINDS), u_size=st.floats(0, min(u_max, 1.0)), lat=st.sampled_from(LATITUDES),
        south=st.booleans(), lon=st.floats(-170, 170).map(lambda v: round(v, 3)), vehicle=st.sampled_from(VEHICLES),
        zones=st.lists(st.sampled_from(PLACEMENTS), min_size=1, max_size=3).map(tuple),
        battery=st.one_of(st.none(), st.floats(6, 20).map(lambda v: round(v, 1))),
        launch=st.sampled_from(["default", "given", "points"]), end=st.sampled_from(["rtl", "land"]),
        margin=st.sampled_from(MARGINS), height=st.sampled_from([60.0, 80.0, 100.0, 120.0]),
        heading=st.one_of(st.none(), st.floats(0, 179.9).map(lambda v: round(v, 1))),
        seed=st.integers(0, 2**31 - 1),
    )


# ---------------------------------------------------------------- plan a case and check it


@dataclass
class Outcome:
    case: Case
    refused: str | None  # the planner's InputError message when it refused the case
    files: list[il.FileReport]  # per exported mission file
    coverage: il.Coverage | None  # None when refused

    @property
    def violating_legs(self) -> list[il.Leg]:
        return [leg for f in self.files for leg in f.violations]

    @property
    def homes_in_zone(self) -> list[str]:
        return [f.file for f in self.files if f.home_zones]

    @property
    def fence_missing(self) -> list[str]:
        return [f.file for f in self.files if f.fence_missing]

    def problems(self) -> list[str]:
        """Every broken promise, one line each (empty when the plan is safe and honest)."""
        out = []
        for leg in self.violating_legs:
            out.append(f"{leg.file}: {leg.kind} leg from item {leg.item} flies {leg.worst_m:.1f} m inside zone "
                       f"{int(np.argmax(leg.inside_m)) + 1}")
        for f in self.homes_in_zone:
            out.append(f"{f}: the launch point (home) lies in an exclusion zone")
        for f in self.fence_missing:
            out.append(f"{f}: the .plan's exclusion fence does not carry every zone")
        out.extend(f"{f.file}: {n}" for f in self.files for n in f.notes if "differs" in n)
        c = self.coverage
        if c is not None and c.unreported_count:
            x, y = c.unreported[0] if len(c.unreported) else c.gap_samples[0]
            out.append(f"{c.unreported_count} of {c.samples} samples of the required ground are seen by fewer than 2 photos "
                       f"and not reported (about {c.measured_gap_m2:.0f} m² uncovered; first at {x:.1f}, {y:.1f} m; "
                       f"manifest coverage.uncovered_m2 = {c.reported_m2}, rule uncovered-ground = {c.rule_status})")
        return out

    def overstated(self) -> str | None:
        """The reported uncovered area when it is more than twice the measured one + 100 m² (counted by the
        benchmark, not asserted: the planner may count ground seen by fewer photos than its target as uncovered)."""
        c = self.coverage
        if c is not None and c.grossly_overstated:
            return f"uncovered area reported as {c.reported_m2} m², the checker measures {c.measured_gap_m2:.0f} m²"
        return None


def plan_case(case: Case, folder: Path) -> Outcome:
    """Write the case, plan it through the public entry points and check the files independently.

    A clean refusal (InputError) is an outcome, not a failure; any other exception propagates.
    """
    spec = write_case(case, folder)
    out = folder / "out"
    try:
        loaded = load_spec(spec)
        write_outputs(plan_from_files(loaded), loaded, out)
    except InputError as exc:
        return Outcome(case, str(exc), [], None)
    c = shapely.centroid(case.area)
    local = il.Local(c.x, c.y)
    files = il.check_legs(out, list(case.zones), local, case.params.vehicle, margin_m=case.params.margin_m)
    cov = il.coverage_gaps(out, case.area, list(case.zones), case.params.margin_m, local)
    return Outcome(case, None, files, cov)
