"""The 4-D check: every leg of every flight against each official zone's outline, height band
and times, with a verdict per zone as InterUSS's geo-awareness tests have them.

A leg meets a zone when some point of it lies inside the zone's outline at a height inside the
zone's band while the zone applies in the planned window ([conditions] start and end; without
them every zone is taken as applying). The band's limits are turned into the leg's altitude
frame at each point: an AGL limit against the ground under the point (the DEM, or the launch
point's ground where there is none: flat ground), an AMSL limit against the ground of the
altitude frame (the launch point's DEM height, or the terrain under the point); a WGS84 height
as the span of sea-level heights it can be (no geoid model: `model.amsl_span`). Without a DEM
the plan's heights above sea level are unknown: an AMSL or WGS84 lower limit is taken as the
ground, an upper one as no ceiling, and the report says so.

Between two samples of the ground (every SAMPLE_M along the part of a leg inside a zone) the
ground is taken as straight, and everything else along a leg is: the check of each such piece
is exact (where two straight heights cross), not a sampling of heights.

Verdicts: Block (PROHIBITED; REQ_AUTHORISATION without the zone's identifier in
[airspace] authorisations), Advise (CONDITIONAL, with the zone's message; REQ_AUTHORISATION
authorised), Neither (NO_RESTRICTION, or no leg meets the zone). A Block refuses the plan.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely

from aerosurvey.airspace.legs import Leg3, flight_legs
from aerosurvey.airspace.model import Airspace, Geozone, Limit, amsl_span
from aerosurvey.airspace.outline import outlines_wgs84
from aerosurvey.plan.landing import PLANE_RTL_LOITER_M

if TYPE_CHECKING:
    from aerosurvey.mission.program import FlightProgram
    from aerosurvey.plan.model import Plan

#: ground sampled this often (ground metres) along the part of a leg inside a zone, and at most this many times a part
SAMPLE_M = 10.0
MAX_SAMPLES = 400
#: zones whose outline lies within this many metres of a leg are listed in the report, whatever their verdict
NEAR_M = 1000.0
#: legs listed per zone in the manifest
LEGS_LISTED = 20
_BIG = 1e12  # a limit that is not there, as a number the crossing arithmetic takes


@dataclass(frozen=True)
class Meeting:
    """Where a leg meets a zone in its band: the first such point, its heights, how much of the leg lies inside the outline."""

    flight: str
    seq: int
    what: str
    inside_m: float  # ground metres of the leg inside the outline
    lonlat: tuple[float, float]
    xy: tuple[float, float]  # planning CRS
    agl_m: float  # height above the ground under the point (the DEM's, else the launch point's)
    amsl_m: float | None  # None without a DEM

    def text(self) -> str:
        amsl = f", {self.amsl_m:.1f} m AMSL" if self.amsl_m is not None else ""
        inside = f"{self.inside_m:.1f} m inside, first" if self.inside_m > 0 else "climbing or descending there"
        return (f"{self.flight} leg to point {self.seq} ({self.what}) at {self.agl_m:.1f} m AGL{amsl}, "
                f"{inside} at lon {self.lonlat[0]:.6f}, lat {self.lonlat[1]:.6f}")


@dataclass(frozen=True)
class ZoneVerdict:
    zone: Geozone
    verdict: str  # block, advise, neither
    reason: str
    meetings: tuple[Meeting, ...]

    def text(self) -> str:
        z = self.zone
        out = f"{self.verdict.upper()} {z.label}: {z.restriction}, {z.band_text()}: {self.reason}"
        if self.meetings:
            out += f"; {self.meetings[0].text()}"
            if len(self.meetings) > 1:
                out += f" (and {len(self.meetings) - 1} more leg(s))"
        if z.message and self.verdict != "neither":
            out += f"; message: {z.message}"
        return out


@dataclass(frozen=True)
class AirspaceReport:
    airspace: Airspace
    verdicts: tuple[ZoneVerdict, ...]  # the zones near the flights (within NEAR_M of a leg)
    notes: tuple[str, ...]  # what could not be converted, and how it was taken

    def of(self, verdict: str) -> list[ZoneVerdict]:
        return [v for v in self.verdicts if v.verdict == verdict]

    def refusal(self) -> str | None:
        """One line naming each zone the flight may not enter, its leg and its figures; None when none blocks."""
        blocked = self.of("block")
        if not blocked:
            return None
        more = f" (and {len(blocked) - 3} more zone(s))" if len(blocked) > 3 else ""
        return ("the plan flies into official UAS zones it may not enter: " + "; ".join(v.text() for v in blocked[:3]) + more
                + " (authorised zones go in [airspace] authorisations; docs/airspace.md)")

    def rule_record(self) -> dict[str, Any]:
        """The planner's own rule, as the manifest records rule results."""
        from aerosurvey.plan.coverage import PLANNER_PROFILE

        block, advise = self.of("block"), self.of("advise")
        status = "fail" if block else "warning" if advise else "pass"
        where = [{"xy": [round(m.xy[0], 2), round(m.xy[1], 2)]} for v in block + advise for m in v.meetings[:5]]
        return {"profile": PLANNER_PROFILE, "rule": "airspace", "status": status, "severity": "error",
                "statement": "no leg of any flight enters an official UAS zone that blocks it (in the zone's band and times); "
                             "the zones that advise are named with their messages",
                "measured": (f"{len(self.airspace.zones)} zone(s) read, {len(self.verdicts)} near the flights: "
                             f"{len(block)} block, {len(advise)} advise, {len(self.of('neither'))} neither"),
                "required": "0 block", "evidence": [v.text() for v in block + advise] + list(self.notes),
                "where": where, "source": "aerosurvey planner (airspace/check.py)"}

    def manifest_zones(self) -> list[dict[str, Any]]:
        """Each zone near the flights with its verdict, as the manifest's airspace.zones lists them."""
        def limit(lim: Limit | None) -> dict[str, Any] | None:
            return None if lim is None else {"m": round(lim.value_m, 3), "reference": lim.reference}

        return [{"file": v.zone.file, "format": v.zone.format, "identifier": v.zone.identifier, "name": v.zone.name,
                 "restriction": v.zone.restriction, "lower": limit(v.zone.lower), "upper": limit(v.zone.upper),
                 "verdict": v.verdict, "reason": v.reason, "message": v.zone.message,
                 "legs": [{"flight": m.flight, "seq": m.seq, "what": m.what, "inside_m": round(m.inside_m, 2),
                           "lon": round(m.lonlat[0], 8), "lat": round(m.lonlat[1], 8), "agl_m": round(m.agl_m, 2),
                           "amsl_m": None if m.amsl_m is None else round(m.amsl_m, 2)} for m in v.meetings[:LEGS_LISTED]]}
                for v in self.verdicts]


def check_airspace(plan: Plan, programs: Mapping[str, FlightProgram], rtl_m: float | None = None) -> AirspaceReport | None:
    """The verdict of every zone near the flights of `programs` (file stem → program); None when the plan has no zones.
    `rtl_m`: the vehicle's own RTL altitude above home, when known (`flight_legs`)."""
    airspace = plan.airspace
    if airspace is None:
        return None
    site = plan.site
    legs = [leg for stem, p in programs.items()
            for leg in flight_legs(p, stem, site.planar, PLANE_RTL_LOITER_M * site.grid_scale, site.grid_scale, rtl_m)]
    homes = {stem: p.home for stem, p in programs.items()}
    return check_legs_4d(plan, airspace, legs, homes)


def leg_geometries(legs: Sequence[Leg3]) -> np.ndarray:
    a = np.array([leg.leg.start for leg in legs], float).reshape(-1, 2)
    b = np.array([leg.leg.end for leg in legs], float).reshape(-1, 2)
    geoms = shapely.linestrings(np.stack([a, b], axis=1))
    point = np.all(a == b, axis=1)
    geoms[point] = shapely.points(a[point])
    return np.asarray(geoms)


def check_legs_4d(plan: Plan, airspace: Airspace, legs: Sequence[Leg3],
                  homes: Mapping[str, tuple[float, float, float]]) -> AirspaceReport:
    """The verdicts of the zones near `legs` (planning CRS); `homes` gives each flight's launch point (lat, lon, ground AMSL)."""
    site = plan.site
    k = site.grid_scale
    notes: list[str] = []
    if airspace.window is None:
        notes.append("no planned window ([conditions] start and end): every zone is taken as applying at any time")
    if not legs:
        return AirspaceReport(airspace, (), tuple(notes))
    geoms = leg_geometries(legs)
    # the zones near the flights, found in longitude/latitude, then projected
    env = shapely.buffer(shapely.envelope(shapely.union_all(geoms)), NEAR_M * k)
    env_ll = site.planar.inverse(env)
    outlines_ll = outlines_wgs84(airspace.zones)
    candidates = shapely.STRtree(outlines_ll).query(env_ll, predicate="intersects")
    zones = [airspace.zones[i] for i in candidates]
    outlines = [site.planar.forward(outlines_ll[i]) for i in candidates]
    if not zones:
        return AirspaceReport(airspace, (), tuple(notes))
    tree = shapely.STRtree(outlines)
    near_legs, near_zones = tree.query(geoms, predicate="dwithin", distance=NEAR_M * k)
    listed = sorted(set(int(z) for z in near_zones))
    leg_i, zone_i = tree.query(geoms, predicate="intersects")
    applies = [airspace.applies(z) for z in zones]
    entered = set(int(z) for z in zone_i)
    # the legs that may meet a zone that applies and restricts: where each lies inside the outline
    keep = np.array([applies[z] and airspace.blocks(zones[z]) is not None for z in zone_i.tolist()], bool).reshape(-1)
    pieces = leg_pieces(geoms, np.asarray(outlines, dtype=object), leg_i[keep], zone_i[keep])
    found: dict[int, list[Meeting]] = {}
    for (li, zi), parts in pieces.items():
        m = _meeting(legs[li], parts, zones[zi], plan, homes[legs[li].leg.flight])
        if m is not None:
            found.setdefault(zi, []).append(m)
    no_dem = site.dem is None
    unconverted = {lim.reference for zi in listed for lim in (zones[zi].lower, zones[zi].upper)
                   if lim is not None and lim.reference != "AGL"}
    if no_dem and unconverted:
        notes.append(f"no DEM (terrain.dem): the plan's heights above sea level are unknown, so limits in "
                     f"{' and '.join(sorted(unconverted))} are taken as the ground (lower) and no ceiling (upper)")
    elif "WGS84" in unconverted:
        notes.append("limits in WGS84 height: no geoid model, each taken as the span of sea-level heights it can be "
                     "(the geoid lies -106.2 to +85.8 m from the ellipsoid)")
    if any(zones[zi].unresolved_times for zi in listed):
        notes.append("schedules bounded by sunrise, sunset or twilight are taken to run from the day's start or to its end")
    verdicts = []
    for zi in listed:
        z = zones[zi]
        meetings = tuple(found.get(zi, ()))
        blocks = airspace.blocks(z)
        if blocks is None:
            verdict, reason = "neither", "no restriction"
        elif not applies[zi]:
            verdict, reason = "neither", "does not apply in the planned window"
        elif zi not in entered:
            verdict, reason = "neither", f"no leg enters its outline (within {NEAR_M:g} m)"
        elif not meetings:
            verdict, reason = "neither", "legs cross its outline outside its height band"
        elif blocks:
            verdict = "block"
            reason = "prohibited" if z.restriction == "PROHIBITED" else "authorisation required, none in [airspace] authorisations"
        else:
            verdict = "advise"
            reason = "conditional" if z.restriction == "CONDITIONAL" else "authorisation required and given"
        verdicts.append(ZoneVerdict(z, verdict, reason, meetings))
    order = {"block": 0, "advise": 1, "neither": 2}
    verdicts.sort(key=lambda v: (order[v.verdict], v.zone.file, v.zone.index))
    return AirspaceReport(airspace, tuple(verdicts), tuple(notes))


def leg_pieces(geoms: np.ndarray, outlines: np.ndarray, leg_i: np.ndarray,
            zone_i: np.ndarray) -> dict[tuple[int, int], list[tuple[float, float]]]:
    """For each (leg, zone) pair: the parts of the leg inside the outline, as fractions (t0, t1) along it; a point leg
    (vertical) inside: (0, 1). One vectorised intersection for every pair."""
    out: dict[tuple[int, int], list[tuple[float, float]]] = {}
    if len(leg_i) == 0:
        return out
    lines, polys = geoms[leg_i], outlines[zone_i]
    point = shapely.get_type_id(lines) == 0
    for j in np.flatnonzero(point & shapely.covers(polys, lines)):
        out[(int(leg_i[j]), int(zone_i[j]))] = [(0.0, 1.0)]
    seg = np.flatnonzero(~point)
    inside = shapely.intersection(lines[seg], polys[seg])
    parts, part_of = shapely.get_parts(inside, return_index=True)
    if len(parts) == 0:
        return out
    coords, coord_of = shapely.get_coordinates(parts, return_index=True)
    first = np.searchsorted(coord_of, np.arange(len(parts)))
    last = np.searchsorted(coord_of, np.arange(len(parts)), side="right") - 1
    owner = lines[seg][part_of]
    t0 = shapely.line_locate_point(owner, shapely.points(coords[first]), normalized=True)
    t1 = shapely.line_locate_point(owner, shapely.points(coords[last]), normalized=True)
    for p, a, b in zip(part_of.tolist(), t0.tolist(), t1.tolist()):
        j = seg[p]
        out.setdefault((int(leg_i[j]), int(zone_i[j])), []).append((min(a, b), max(a, b)))
    return out


def _meeting(leg: Leg3, pieces: list[tuple[float, float]], zone: Geozone, plan: Plan,
             home: tuple[float, float, float]) -> Meeting | None:
    """The first point of the leg inside the outline (`pieces`, fractions along it) at a height in the zone's band, or None."""
    site = plan.site
    k = site.grid_scale
    (x0, y0), (x1, y1) = leg.leg.start, leg.leg.end
    length = math.hypot(x1 - x0, y1 - y0) / k
    home_ground = home[2]
    relative = plan.altitudes.frame == "relative"
    for t0, t1 in pieces:
        n = int(min(MAX_SAMPLES, max(1, math.ceil((t1 - t0) * length / SAMPLE_M))))
        t = np.linspace(t0, t1, n + 1)
        x, y = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
        ground = site.dem.sample(x, y, f"the ground under {leg.leg.flight}'s leg {leg.leg.seq}") if site.dem is not None \
            else np.full(len(t), home_ground)
        base = np.full(len(t), home_ground) if relative else ground  # what the altitude frame is above
        lo = leg.alt_start[0] + t * (leg.alt_end[0] - leg.alt_start[0])
        hi = leg.alt_start[1] + t * (leg.alt_end[1] - leg.alt_start[1])
        lower = limit_in_frame(zone.lower, ground, base, site.dem is None, upper=False)
        upper = limit_in_frame(zone.upper, ground, base, site.dem is None, upper=True)
        hit = _first_meeting(upper - lo, hi - lower)
        if hit is None:
            continue
        i, f = hit
        tt = t[i] + f * (t[i + 1] - t[i])
        gx, gy = x0 + tt * (x1 - x0), y0 + tt * (y1 - y0)
        g = float(np.interp(tt, t, ground))
        alt = float(np.interp(tt, t, np.clip(lower, lo, hi)))  # the lowest height in the band there
        amsl = alt + float(np.interp(tt, t, base))
        lon, lat = site.planar.lonlat(np.array([gx]), np.array([gy]))
        inside = sum(b - a for a, b in pieces) * length
        return Meeting(leg.leg.flight, leg.leg.seq, leg.leg.what, inside, (float(lon[0]), float(lat[0])), (gx, gy),
                       amsl - g, None if site.dem is None else amsl)
    return None


def limit_in_frame(limit: Limit | None, ground: np.ndarray, base: np.ndarray, no_dem: bool, upper: bool) -> np.ndarray:
    """A limit as an altitude in the leg's frame at each sample (above `base`); ±_BIG where it is not there or unknown."""
    none = np.full(len(ground), _BIG if upper else -_BIG)
    if limit is None:
        return none
    if limit.reference == "AGL":
        return np.asarray(limit.value_m + ground - base, float)
    if no_dem:
        return none
    span = amsl_span(limit)
    return np.asarray((span[1] if upper else span[0]) - base, float)


def _first_meeting(c1: np.ndarray, c2: np.ndarray) -> tuple[int, float] | None:
    """The first interval i (between samples i and i + 1) and the fraction f in it where the straight functions c1 and
    c2 (their values at the samples) are both >= 0; None when there is none."""
    lo = np.zeros(len(c1) - 1)
    hi = np.ones(len(c1) - 1)
    for c in (c1, c2):
        a, b = c[:-1], c[1:]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(a != b, a / (a - b), 0.0)
        rising = (a < 0) & (b >= 0)
        falling = (a >= 0) & (b < 0)
        lo = np.where(rising, np.maximum(lo, r), lo)
        hi = np.where(falling, np.minimum(hi, r), hi)
        hi = np.where((a < 0) & (b < 0), -1.0, hi)
    ok = np.flatnonzero(lo <= hi)
    if len(ok) == 0:
        return None
    i = int(ok[0])
    return i, float(lo[i])
