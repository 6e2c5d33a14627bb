"""Sun elevation at a place and time (NOAA's solar position equations, ~0.01° here).

Low sun means long shadows and poor image matching (Remote Sensing 12 (2020) 3831), so the
planner reports the elevation over the planned window.
"""

from __future__ import annotations

import datetime as dt
import math


def sun_elevation_deg(lon: float, lat: float, when: dt.datetime) -> float:
    """Solar elevation above the horizon in degrees (no refraction), `when` timezone-aware."""
    t = when.astimezone(dt.UTC)
    jd = (t - dt.datetime(2000, 1, 1, 12, tzinfo=dt.UTC)).total_seconds() / 86400.0 + 2451545.0
    jc = (jd - 2451545.0) / 36525.0
    l0 = (280.46646 + jc * (36000.76983 + jc * 0.0003032)) % 360.0
    m = 357.52911 + jc * (35999.05029 - 0.0001537 * jc)
    e = 0.016708634 - jc * (0.000042037 + 0.0000001267 * jc)
    mr = math.radians(m)
    c = (math.sin(mr) * (1.914602 - jc * (0.004817 + 0.000014 * jc))
         + math.sin(2 * mr) * (0.019993 - 0.000101 * jc) + math.sin(3 * mr) * 0.000289)
    true_long = l0 + c
    omega = 125.04 - 1934.136 * jc
    app_long = true_long - 0.00569 - 0.00478 * math.sin(math.radians(omega))
    eps0 = 23 + (26 + (21.448 - jc * (46.815 + jc * (0.00059 - jc * 0.001813))) / 60) / 60
    eps = eps0 + 0.00256 * math.cos(math.radians(omega))
    decl = math.asin(math.sin(math.radians(eps)) * math.sin(math.radians(app_long)))
    y = math.tan(math.radians(eps / 2)) ** 2
    l0r = math.radians(l0)
    eq_time = 4 * math.degrees(
        y * math.sin(2 * l0r) - 2 * e * math.sin(mr) + 4 * e * y * math.sin(mr) * math.cos(2 * l0r)
        - 0.5 * y * y * math.sin(4 * l0r) - 1.25 * e * e * math.sin(2 * mr)
    )
    minutes = t.hour * 60 + t.minute + t.second / 60 + t.microsecond / 6e7
    true_solar = (minutes + eq_time + 4 * lon) % 1440
    hour_angle = true_solar / 4 - 180 if true_solar >= 0 else true_solar / 4 + 180
    cos_zen = (math.sin(math.radians(lat)) * math.sin(decl)
               + math.cos(math.radians(lat)) * math.cos(decl) * math.cos(math.radians(hour_angle)))
    return 90.0 - math.degrees(math.acos(max(-1.0, min(1.0, cos_zen))))


def elevation_over_window(lon: float, lat: float, start: dt.datetime, end: dt.datetime,
                          step_min: float = 10.0) -> list[tuple[dt.datetime, float]]:
    """(time, elevation) every `step_min` minutes from start to end, both included."""
    out = []
    t = start
    while t < end:
        out.append((t, sun_elevation_deg(lon, lat, t)))
        t += dt.timedelta(minutes=step_min)
    out.append((end, sun_elevation_deg(lon, lat, end)))
    return out
