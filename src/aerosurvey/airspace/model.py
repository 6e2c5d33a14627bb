"""Official UAS geographical zones as plain data: what the ED-269 and ED-318 readers
(airspace/read.py) make of a zone, in no format's terms, and when a zone applies in time.

A zone has an outline (a polygon with its holes, or a circle: centre and radius), a height
band whose two limits each have their own reference (AGL, AMSL, or WGS84 ellipsoidal height)
and are held in metres, the times it applies, its restriction and its message. A limit the
file does not state is None, never 0: a missing lower limit is the surface, a missing upper
limit (or the conventional 99999) no ceiling.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

from shapely.geometry.base import BaseGeometry

#: the restrictions of Regulation 2019/947 Art. 15 as ED-269 spells them (ED-318's
#: REQ_AUTHORIZATION is read as REQ_AUTHORISATION)
RESTRICTIONS = ("PROHIBITED", "REQ_AUTHORISATION", "CONDITIONAL", "NO_RESTRICTION")
REFERENCES = ("AGL", "AMSL", "WGS84")
WEEKDAYS = ("MON", "TUE", "WED", "THU", "FRI", "SAT", "SUN")
#: metres in a foot (the international foot)
FOOT_M = 0.3048
#: a limit of this many units (m or ft) means "no ceiling" in the published files
NO_CEILING = 99999.0


@dataclass(frozen=True)
class Limit:
    """One limit of a zone's band: metres in its reference."""

    value_m: float
    reference: str  # AGL, AMSL or WGS84

    def text(self) -> str:
        return f"{self.value_m:g} m {self.reference}"


@dataclass(frozen=True)
class DailyPeriod:
    """Part of the day on some weekdays: `start` to `end` (an `end` at or before `start` runs into the next day).
    A start or end given by a daylight event (sunrise, sunset, twilight) is None: the day's start or end is taken
    (the zone applies longer, never shorter)."""

    days: tuple[str, ...]  # WEEKDAYS; all seven for ANY
    start: dt.time | None  # timezone-aware; None: from the day's start
    end: dt.time | None  # None: to the day's end

    def intervals(self, first: dt.date, last: dt.date) -> list[tuple[dt.datetime, dt.datetime]]:
        """This period's times on each day from `first` to `last` (dates in the times' own offset)."""
        tz = (self.start or self.end or dt.time(tzinfo=dt.UTC)).tzinfo or dt.UTC
        out = []
        day = first
        while day <= last:
            if WEEKDAYS[day.weekday()] in self.days:
                a = dt.datetime.combine(day, (self.start or dt.time()).replace(tzinfo=tz))
                b = (dt.datetime.combine(day, self.end.replace(tzinfo=tz)) if self.end is not None
                     else dt.datetime.combine(day + dt.timedelta(days=1), dt.time(tzinfo=tz)))
                if b <= a:
                    b += dt.timedelta(days=1)
                out.append((a, b))
            day += dt.timedelta(days=1)
        return out


@dataclass(frozen=True)
class TimePeriod:
    """When a zone applies: from `start` to `end` (None: unbounded), on the schedule's periods when there is one."""

    start: dt.datetime | None
    end: dt.datetime | None
    schedule: tuple[DailyPeriod, ...]

    def meets(self, a: dt.datetime, b: dt.datetime) -> bool:
        """True when this period and the window [a, b] share a moment."""
        lo = a if self.start is None else max(a, self.start)
        hi = b if self.end is None else min(b, self.end)
        if hi < lo:
            return False
        if not self.schedule:
            return True
        # a schedule repeats every week: eight days of the window (a day more either side for
        # periods across midnight and other offsets) hold every moment it can have in it
        last = min(hi, lo + dt.timedelta(days=8))
        for p in self.schedule:
            for s, e in p.intervals((lo - dt.timedelta(days=1)).date(), (last + dt.timedelta(days=1)).date()):
                if s <= hi and e >= lo:
                    return True
        return False


@dataclass(frozen=True)
class Geozone:
    """A UAS geographical zone as read from an ED-269 or ED-318 file."""

    file: str  # the file's name, for messages
    format: str  # "ED-269" or "ED-318"
    index: int  # the feature's place in the file (0-based)
    identifier: str
    name: str
    restriction: str  # RESTRICTIONS
    message: str
    outline: BaseGeometry  # WGS84 lon/lat: a polygon (holes kept), or the circle's centre point
    radius_m: float | None  # a circle's radius (metres on the ground); None for a polygon
    lower: Limit | None  # None: from the surface
    upper: Limit | None  # None: no ceiling
    periods: tuple[TimePeriod, ...]  # () : always (permanent)
    unresolved_times: bool = False  # a schedule bounded by a daylight event: taken as the whole day

    @property
    def label(self) -> str:
        """How messages name the zone: its identifier, its name and its file."""
        named = f" {self.name!r}" if self.name and self.name != self.identifier else ""
        return f"zone {self.identifier}{named} ({self.file})"

    def band_text(self) -> str:
        lo = "the surface" if self.lower is None else self.lower.text()
        hi = "no ceiling" if self.upper is None else self.upper.text()
        return f"{lo} to {hi}"

    def applies_in(self, start: dt.datetime, end: dt.datetime) -> bool:
        """True when the zone applies at some moment of the window."""
        return not self.periods or any(p.meets(start, end) for p in self.periods)


#: the geoid's height above the WGS84 ellipsoid lies between these everywhere (EGM96: −106.2 m
#: south of India, +85.8 m over New Guinea); aerosurvey carries no geoid model, so a WGS84
#: height becomes the span of heights above sea level it can be: h − 85.8 to h + 106.2
GEOID_MIN_M = -106.2
GEOID_MAX_M = 85.8


def amsl_span(limit: Limit) -> tuple[float, float]:
    """The lowest and highest height above mean sea level a limit in AMSL or WGS84 height can mean."""
    if limit.reference == "WGS84":
        return limit.value_m - GEOID_MAX_M, limit.value_m - GEOID_MIN_M
    return limit.value_m, limit.value_m


@dataclass(frozen=True)
class Airspace:
    """What a plan is checked against: the zones read, the zones the operator is authorised for and the planned window."""

    zones: tuple[Geozone, ...]
    files: tuple[str, ...]  # the zone files, as the spec names them
    authorisations: tuple[str, ...]  # zone identifiers
    window: tuple[dt.datetime, dt.datetime] | None  # [conditions] start and end; None: not given

    def applies(self, zone: Geozone) -> bool:
        """True when the zone applies at some moment of the window (always, without a window)."""
        return self.window is None or zone.applies_in(*self.window)

    def blocks(self, zone: Geozone) -> bool | None:
        """True: the zone may not be flown in; False: it advises; None: no restriction (InterUSS's Block, Advise, Neither)."""
        if zone.restriction == "NO_RESTRICTION":
            return None
        if zone.restriction == "REQ_AUTHORISATION":
            return zone.identifier not in self.authorisations
        return zone.restriction == "PROHIBITED"
