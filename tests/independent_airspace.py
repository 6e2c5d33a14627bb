"""An independent 4-D check of exported missions against official UAS zones.

It shares no code with aerosurvey: the zones are the test's own description of what it wrote
into the ED-269 / ED-318 files (`Zone`), the flights are rebuilt from the exported
mission .waypoints (QGC WPL 110) and the .plan's rally points, in a local azimuthal
equidistant projection (metres), and the heights come from the items themselves:

- home is the first line (its altitude: the ground above sea level at the launch point);
- NAV_TAKEOFF: a copter climbs vertically at home from the ground to its altitude;
- NAV_WAYPOINT: straight to the point, the altitude changing evenly on the way;
- NAV_LAND: to the point at the altitude it has, then straight down to the ground;
- NAV_RETURN_TO_LAUNCH: to the nearest of home and the rally points (ArduCopter counts home),
  anywhere between its altitude and the rally point's (home: its altitude) on the way, then
  straight down from the higher;
- altitudes are above home (frame 3) or above the terrain (frame 10); heights above ground
  use `ground(lon, lat)`, the test's own terrain (flat at home without one).

Whether a leg meets a zone is found by sampling: every SAMPLE_M along each leg (every 0.1 m of
height along a vertical one), each sample's position inside the outline (a circle: its
geodesic distance from the centre) and its height in the band (feet turned into metres, AGL
against the ground under the sample, AMSL against home's ground plus the altitude). Two
tolerances make the answer firm or say it is not: `meets(..., slack=+s)` grows the zones and
bands by s, `slack=-s` shrinks them.

Copters only: the property and feature tests fly copters.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyproj
import shapely

from independent_legs import Local, parse_wpl

FT = 0.3048
SAMPLE_M = 0.5
_GEOD = pyproj.Geod(ellps="WGS84")
DAYS = ("MON", "TUE", "WED", "THU", "FRI", "SAT", "SUN")


@dataclass(frozen=True)
class Daily:
    days: tuple[str, ...]
    start: dt.time  # with tzinfo
    end: dt.time


@dataclass(frozen=True)
class Period:
    start: dt.datetime | None = None
    end: dt.datetime | None = None
    schedule: tuple[Daily, ...] = ()

    def active(self, t: dt.datetime) -> bool:
        if self.start is not None and t < self.start or self.end is not None and t > self.end:
            return False
        if not self.schedule:
            return True
        for d in self.schedule:
            tz = d.start.tzinfo
            local = t.astimezone(tz)
            a, b = d.start.replace(tzinfo=None), d.end.replace(tzinfo=None)
            now = local.time()
            if a < b:
                if DAYS[local.weekday()] in d.days and a <= now <= b:
                    return True
            else:  # across midnight: the evening of its day, the morning of the next
                if DAYS[local.weekday()] in d.days and now >= a:
                    return True
                if DAYS[(local.weekday() - 1) % 7] in d.days and now <= b:
                    return True
        return False


@dataclass(frozen=True)
class Zone:
    ident: str
    restriction: str  # PROHIBITED, REQ_AUTHORISATION, CONDITIONAL, NO_RESTRICTION
    lower: tuple[float, str, str] | None  # (value, unit m/ft, reference AGL/AMSL); None: not stated
    upper: tuple[float, str, str] | None
    ring: list[tuple[float, float]] | None = None  # lon/lat outline (polygon)
    holes: list[list[tuple[float, float]]] = field(default_factory=list)
    circle: tuple[float, float, float, str] | None = None  # lon, lat, radius, unit
    periods: tuple[Period, ...] = ()  # (): permanent
    message: str = ""

    def active_in(self, start: dt.datetime | None, end: dt.datetime | None) -> bool:
        if not self.periods or start is None or end is None:
            return True
        t = start
        while t <= end:
            if any(p.active(t) for p in self.periods):
                return True
            t += dt.timedelta(minutes=1)
        return any(p.active(end) for p in self.periods)


@dataclass(frozen=True)
class Leg3:
    file: str
    kind: str
    a: tuple[float, float]  # local metres
    b: tuple[float, float]
    alt_a: tuple[float, float]  # (lowest, highest) altitude in the item frame
    alt_b: tuple[float, float]
    frame: int


def flight_legs(wpl: Path, local: Local) -> tuple[list[Leg3], float]:
    """The legs of one exported copter mission, and home's ground above sea level."""
    home, items = parse_wpl(wpl.read_text(), wpl.name)
    plan = wpl.with_suffix(".plan")
    rally: list[tuple[float, float, float]] = []
    if plan.exists():
        doc = json.loads(plan.read_text())
        rally = [(float(p[1]), float(p[0]), float(p[2])) for p in doc.get("rallyPoints", {}).get("points", [])]
    hx, hy = local.xy(home.lon, home.lat)
    pos, alt, frame = (hx, hy), 0.0, 3
    legs: list[Leg3] = []
    for it in items:
        if it.command not in (16, 20, 21, 22):
            continue
        if it.frame in (3, 10):
            frame = it.frame
        if it.command == 22:
            legs.append(Leg3(wpl.name, "takeoff", pos, pos, (alt, alt), (it.alt, it.alt), frame))
            alt = it.alt
        elif it.command == 16:
            to = pos if it.lat == 0 and it.lon == 0 else local.xy(it.lon, it.lat)
            legs.append(Leg3(wpl.name, "waypoint", pos, to, (alt, alt), (it.alt, it.alt), frame))
            pos, alt = to, it.alt
        elif it.command == 21:
            to = pos if it.lat == 0 and it.lon == 0 else local.xy(it.lon, it.lat)
            legs.append(Leg3(wpl.name, "land", pos, to, (alt, alt), (alt, alt), frame))
            legs.append(Leg3(wpl.name, "descent", to, to, (alt, alt), (0.0, 0.0), frame))
            return legs, home.alt
        else:
            targets = [((hx, hy), alt)] + [(local.xy(lon, lat), a) for lon, lat, a in rally]
            to, back = min(targets, key=lambda t: math.dist(t[0], pos))
            span = (min(alt, back), max(alt, back))
            legs.append(Leg3(wpl.name, "rtl", pos, to, span, span, frame))
            legs.append(Leg3(wpl.name, "rtl-descent", to, to, (span[1], span[1]), (0.0, 0.0), frame))
            return legs, home.alt
    return legs, home.alt


def _outline(zone: Zone, local: Local) -> shapely.Geometry | None:
    if zone.ring is None:
        return None
    return local.geom(shapely.Polygon(zone.ring, zone.holes))


def _limit_m(limit: tuple[float, str, str]) -> tuple[float, str]:
    v, unit, ref = limit
    return (v * FT if unit == "ft" else v), ref


def meets(zone: Zone, leg: Leg3, local: Local, home_amsl: float, ground: Callable[[float, float], float],
          slack: float) -> bool:
    """Whether some sample of the leg lies inside the zone (grown by `slack` metres) at a height inside its band
    (grown by `slack` / 2 metres); a negative slack shrinks both."""
    n = max(1, int(math.ceil(math.dist(leg.a, leg.b) / SAMPLE_M)))
    vertical = leg.a == leg.b
    if vertical:
        n = max(1, int(math.ceil(max(abs(leg.alt_b[1] - leg.alt_a[1]), abs(leg.alt_b[0] - leg.alt_a[0])) / 0.1)))
    t = np.linspace(0.0, 1.0, n + 1)
    x = leg.a[0] + t * (leg.b[0] - leg.a[0])
    y = leg.a[1] + t * (leg.b[1] - leg.a[1])
    lon, lat = local.inv.transform(x, y)
    lon, lat = np.asarray(lon), np.asarray(lat)
    if zone.circle is not None:
        clon, clat, r, unit = zone.circle
        _, _, d = _GEOD.inv(np.full(len(lon), clon), np.full(len(lat), clat), lon, lat)
        inside = np.asarray(d) <= r * (FT if unit == "ft" else 1.0) + slack
    else:
        poly = _outline(zone, local)
        assert poly is not None
        inside = shapely.contains_xy(shapely.buffer(poly, slack), x, y)
    if not inside.any():
        return False
    g = np.array([ground(float(a), float(b)) for a, b in zip(lon, lat)])
    lo = leg.alt_a[0] + t * (leg.alt_b[0] - leg.alt_a[0])
    hi = leg.alt_a[1] + t * (leg.alt_b[1] - leg.alt_a[1])
    base = home_amsl if leg.frame == 3 else g  # what the altitude is above
    lo_amsl, hi_amsl = base + lo, base + hi
    ok = inside.copy()
    if zone.lower is not None:
        v, ref = _limit_m(zone.lower)
        top = hi_amsl - (g if ref == "AGL" else 0.0)
        ok &= top >= v - slack / 2
    if zone.upper is not None and zone.upper[0] < 99999:
        v, ref = _limit_m(zone.upper)
        bottom = lo_amsl - (g if ref == "AGL" else 0.0)
        ok &= bottom <= v + slack / 2
    return bool(ok.any())


@dataclass(frozen=True)
class Expected:
    verdict: str | None  # block, advise, neither; None when the tolerances disagree (a leg on an edge)
    legs: list[Leg3]  # the legs that surely meet it


def expected_verdict(zone: Zone, legs: list[Leg3], local: Local, home_amsl: float, ground: Callable[[float, float], float],
                     authorised: set[str], window: tuple[dt.datetime, dt.datetime] | None, slack: float = 1.0) -> Expected:
    if zone.restriction == "NO_RESTRICTION" or not zone.active_in(*(window or (None, None))):
        return Expected("neither", [])
    sure = [leg for leg in legs if meets(zone, leg, local, home_amsl, ground, -slack)]
    maybe = [leg for leg in legs if meets(zone, leg, local, home_amsl, ground, slack)]
    if not maybe:
        return Expected("neither", [])
    if not sure:
        return Expected(None, [])
    if zone.restriction == "PROHIBITED" or zone.restriction == "REQ_AUTHORISATION" and zone.ident not in authorised:
        return Expected("block", sure)
    return Expected("advise", sure)


# ------------------------------------------------------------------ writing the files


def _days(days: tuple[str, ...]) -> list[str]:
    return ["ANY"] if len(days) == 7 else list(days)


def _time(t: dt.time) -> str:
    off = t.utcoffset() or dt.timedelta()
    sign = "+" if off >= dt.timedelta() else "-"
    mins = abs(int(off.total_seconds() // 60))
    return t.strftime("%H:%M:%S") + ("Z" if not mins else f"{sign}{mins // 60:02d}:{mins % 60:02d}")


def ed269_feature(z: Zone, spelling: str = "REQ_AUTHORISATION") -> dict:
    """A feature of ED-269's UASZoneVersion from its published fields."""
    unit = {"m": "M", "ft": "FT"}
    lim = z.lower or z.upper or (0, z.circle[3] if z.circle else "m", "AGL")
    geometry: dict = {"uomDimensions": unit[lim[1]], "lowerVerticalReference": (z.lower or lim)[2],
                      "upperVerticalReference": (z.upper or lim)[2]}
    if z.lower is not None:
        geometry["lowerLimit"] = z.lower[0]
    if z.upper is not None:
        geometry["upperLimit"] = z.upper[0]
    if z.circle is not None:
        assert z.circle[3] == lim[1], "ED-269 holds one unit a volume"
        geometry["horizontalProjection"] = {"type": "Circle", "center": [z.circle[0], z.circle[1]], "radius": z.circle[2]}
    else:
        assert z.ring is not None
        geometry["horizontalProjection"] = {"type": "Polygon", "coordinates": [[list(p) for p in r] for r in [z.ring, *z.holes]]}
    if z.periods:
        applicability = [{"permanent": "NO",
                          **({"startDateTime": p.start.isoformat()} if p.start else {}),
                          **({"endDateTime": p.end.isoformat()} if p.end else {}),
                          **({"schedule": [{"day": _days(d.days), "startTime": _time(d.start), "endTime": _time(d.end)}
                                           for d in p.schedule]} if p.schedule else {})} for p in z.periods]
    else:
        applicability = [{"permanent": "YES"}]
    restriction = spelling if z.restriction == "REQ_AUTHORISATION" else z.restriction
    return {"identifier": z.ident, "country": "CZE", "name": f"zone {z.ident}", "type": "COMMON",
            "restriction": restriction, "reason": ["OTHER"], "message": z.message,
            "zoneAuthority": [{"name": "the authority", "purpose": "AUTHORIZATION"}],
            "applicability": applicability, "geometry": [geometry]}


def write_ed269(path: Path, zones: list[Zone], bom: bool = False) -> Path:
    text = json.dumps({"title": "test zones", "description": "written by the test", "features": [ed269_feature(z) for z in zones]})
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8"))
    return path


def ed318_feature(z: Zone) -> dict:
    """A feature of ED-318's GeoJSON from its published fields."""
    lim = z.lower or z.upper or (0, z.circle[3] if z.circle else "m", "AGL")
    layer: dict = {"uom": lim[1]}
    if z.lower is not None:
        layer |= {"lower": z.lower[0], "lowerReference": z.lower[2]}
    if z.upper is not None:
        layer |= {"upper": z.upper[0], "upperReference": z.upper[2]}
    if z.circle is not None:
        geometry = {"type": "Point", "coordinates": [z.circle[0], z.circle[1]],
                    "extent": {"subType": "Circle", "radius": z.circle[2]}, "layer": layer}
    else:
        assert z.ring is not None
        geometry = {"type": "Polygon", "coordinates": [[list(p) for p in r] for r in [z.ring, *z.holes]], "layer": layer}
    props: dict = {"identifier": z.ident, "country": "CZE", "name": [{"text": f"zone {z.ident}", "lang": "en-GB"}],
                   "type": "REQ_AUTHORIZATION" if z.restriction == "REQ_AUTHORISATION" else z.restriction,
                   "variant": "COMMON", "reason": ["OTHER"],
                   "message": [{"text": z.message, "lang": "en-GB"}] if z.message else None,
                   "zoneAuthority": [{"purpose": "AUTHORIZATION", "name": [{"text": "the authority", "lang": "en-GB"}]}]}
    if z.periods:
        props["limitedApplicability"] = [
            {**({"startDateTime": p.start.isoformat()} if p.start else {}),
             **({"endDateTime": p.end.isoformat()} if p.end else {}),
             **({"schedule": [{"day": _days(d.days), "startTime": _time(d.start), "endTime": _time(d.end)}
                              for d in p.schedule]} if p.schedule else {})} for p in z.periods]
    return {"type": "Feature", "id": z.ident, "properties": {k: v for k, v in props.items() if v is not None}, "geometry": geometry}


def write_ed318(path: Path, zones: list[Zone]) -> Path:
    path.write_text(json.dumps({"type": "FeatureCollection", "name": "test zones",
                                "metadata": {"provider": [{"text": "the test", "lang": "en-GB"}]},
                                "features": [ed318_feature(z) for z in zones]}))
    return path


def stretches_inside(legs: list, zone: shapely.Polygon) -> list[tuple[float, float]]:
    """The route's stretches inside `zone` (distance flown, metres), each leg cut by the polygon, touching ones joined."""
    spans, run = [], 0.0
    for leg in legs:
        line = shapely.LineString([leg.a, leg.b])
        if line.length > 0:
            for part in getattr(cut := line.intersection(zone), "geoms", [cut]):
                if part.length > 0:
                    a, b = (line.project(shapely.Point(c)) for c in (part.coords[0], part.coords[-1]))
                    spans.append((run + min(a, b), run + max(a, b)))
        run += line.length
    joined: list[list[float]] = []
    for a, b in sorted(spans):
        if joined and a <= joined[-1][1] + 1e-6:
            joined[-1][1] = max(joined[-1][1], b)
        else:
            joined.append([a, b])
    return [(a, b) for a, b in joined]
