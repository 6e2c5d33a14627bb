"""The feature-check table: small ED-269 and ED-318 files the test writes (circles and polygons,
AGL and AMSL limits in m and ft, schedules, holes, authorisations), each planned over a small
area; the verdict of every zone and the legs that meet it are judged by the independent 4-D
check (tests/independent_airspace.py) on the exported missions."""

from __future__ import annotations

import dataclasses
import datetime as dt
from pathlib import Path

import numpy as np
import pyproj
import pytest

import independent_airspace as ia
from aerosurvey.airspace.check import check_airspace
from aerosurvey.errors import CheckFailed
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import mission_programs, write_outputs
from aerosurvey.spec import load_spec
from conftest import make_spec
from independent_legs import Local

UTC = dt.UTC
AREA = [[15.000, 49.400], [15.003, 49.400], [15.003, 49.402], [15.000, 49.402], [15.000, 49.400]]
#: the DEM's ground: a plane rising eastwards in UTM 33N (bilinear sampling of a plane is exact)
GROUND0, SLOPE, X0 = 300.0, 0.05, 499_700.0
_UTM = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32633", always_xy=True)


def ground(lon: float, lat: float) -> float:
    x, _ = _UTM.transform(lon, lat)
    return GROUND0 + SLOPE * (x - X0)


def write_dem(path: Path) -> None:
    import rasterio
    from rasterio.transform import from_origin

    west, north, cell, n = 499_500.0, 5_472_200.0, 10.0, 80
    xs = west + cell * (np.arange(n) + 0.5)
    heights = np.tile(GROUND0 + SLOPE * (xs - X0), (n, 1)).astype("float32")
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs="EPSG:32633",
                       transform=from_origin(west, north, cell, cell), nodata=-9999.0) as ds:
        ds.write(heights, 1)


def box(w: float, s: float, e: float, n: float) -> list[tuple[float, float]]:
    return [(w, s), (e, s), (e, n), (w, n), (w, s)]


WHOLE = box(14.996, 49.397, 15.007, 49.405)  # the area, its launch point and more
EAST = box(15.0018, 49.3995, 15.0035, 49.4025)  # the east part of the area
HOLE = box(14.998, 49.3985, 15.005, 49.4035)  # round the area and its launch point
CENTRE = (15.0015, 49.401)
WEEKENDS = (ia.Period(schedule=(ia.Daily(("SAT", "SUN"), dt.time(8, tzinfo=UTC), dt.time(18, tzinfo=UTC)),)),)
TUESDAY = (dt.datetime(2026, 5, 12, 9, tzinfo=UTC), dt.datetime(2026, 5, 12, 11, tzinfo=UTC))
SATURDAY = (dt.datetime(2026, 5, 16, 9, tzinfo=UTC), dt.datetime(2026, 5, 16, 11, tzinfo=UTC))

# name: (format, zones, authorisations, window, with a DEM)
CASES = {
    # a prohibited circle over every height: the route keeps it clear
    "269-circle-prohibited-all-heights": ("ED-269", [ia.Zone("P1", "PROHIBITED", (0, "m", "AGL"), (99999, "m", "AGL"),
                                                             circle=(*CENTRE, 30.0, "m"))], [], None, False),
    "269-polygon-prohibited-above-the-flight": ("ED-269", [ia.Zone("P2", "PROHIBITED", (100, "m", "AGL"), (200, "m", "AGL"),
                                                                   ring=WHOLE)], [], None, False),
    "269-authorisation-required-not-given": ("ED-269", [ia.Zone("A1", "REQ_AUTHORISATION", (30, "m", "AGL"), (80, "m", "AGL"),
                                                                ring=EAST)], [], None, False),
    "269-authorisation-required-given": ("ED-269", [ia.Zone("A1", "REQ_AUTHORISATION", (30, "m", "AGL"), (80, "m", "AGL"),
                                                            ring=EAST, message="authorised flights only")], ["A1"], None, False),
    "269-band-in-feet-below-the-survey": ("ED-269", [ia.Zone("F1", "PROHIBITED", (0, "ft", "AGL"), (150, "ft", "AGL"),
                                                             ring=EAST)], [], None, False),
    "318-polygon-with-hole-round-the-flight": ("ED-318", [ia.Zone("H1", "CONDITIONAL", None, (120, "m", "AGL"), ring=WHOLE,
                                                                  holes=[HOLE], message="keep to VLOS")], [], None, False),
    "318-polygon-without-hole": ("ED-318", [ia.Zone("H2", "CONDITIONAL", None, (120, "m", "AGL"), ring=WHOLE,
                                                    message="keep to VLOS")], [], None, False),
    "318-circle-feet-conditional": ("ED-318", [ia.Zone("C1", "CONDITIONAL", (0, "ft", "AGL"), (250, "ft", "AGL"),
                                                       circle=(*CENTRE, 160.0, "ft"), message="notify the operator"),
                                               ia.Zone("C2", "CONDITIONAL", (0, "ft", "AGL"), (150, "ft", "AGL"),
                                                       circle=(15.0025, 49.4015, 150.0, "ft"))], [], None, False),
    "318-no-restriction": ("ED-318", [ia.Zone("N1", "NO_RESTRICTION", None, None, ring=WHOLE)], [], None, False),
    "269-schedule-weekends-flown-on-a-tuesday": ("ED-269", [ia.Zone("W1", "PROHIBITED", (30, "m", "AGL"), (80, "m", "AGL"),
                                                                    ring=EAST, periods=WEEKENDS)], [], TUESDAY, False),
    "269-schedule-weekends-flown-on-a-saturday": ("ED-269", [ia.Zone("W1", "PROHIBITED", (30, "m", "AGL"), (80, "m", "AGL"),
                                                                     ring=EAST, periods=WEEKENDS)], [], SATURDAY, False),
    "318-schedule-dates-and-times": ("ED-318", [ia.Zone("S1", "CONDITIONAL", (0, "m", "AGL"), (100, "m", "AGL"), ring=EAST,
                                                        periods=(ia.Period(dt.datetime(2026, 5, 1, tzinfo=UTC),
                                                                           dt.datetime(2026, 5, 31, tzinfo=UTC),
                                                                           (ia.Daily(("TUE",), dt.time(10, 30, tzinfo=UTC),
                                                                                     dt.time(12, tzinfo=UTC)),)),))],
                                     [], TUESDAY, False),
    "318-amsl-band-met-over-sloping-ground": ("ED-318", [ia.Zone("M1", "CONDITIONAL", (340, "m", "AMSL"), (500, "m", "AMSL"),
                                                                 ring=EAST)], [], None, True),
    "269-amsl-band-above-the-flight": ("ED-269", [ia.Zone("M2", "PROHIBITED", (2000, "ft", "AMSL"), (3000, "ft", "AMSL"),
                                                          ring=WHOLE)], [], None, True),
    "269-agl-band-over-sloping-ground": ("ED-269", [ia.Zone("G1", "REQ_AUTHORISATION", (45, "m", "AGL"), (54, "m", "AGL"),
                                                            ring=EAST)], [], None, True),
}


def _spec(tmp: Path, files: list[str], auth: list[str], window: tuple[dt.datetime, dt.datetime] | None, dem: bool) -> Path:
    over: dict = {"targets": {"height_m": 60.0}, "flight": {"exclusion_margin_m": 5.0}}
    if files:
        over["airspace"] = {"zones": files, "authorisations": auth}
    if window:
        over["conditions"] = {"start": window[0].isoformat(), "end": window[1].isoformat()}
    if dem:
        write_dem(tmp / "dem.tif")
        over["terrain"] = {"dem": "dem.tif", "mode": "fixed"}
    p = make_spec(tmp, over, area=AREA)
    text = p.read_text().replace("gsd_cm = 2.5\n", "")  # the spec takes one of gsd_cm and height_m
    p.write_text(text)
    return p


@pytest.mark.parametrize("case", list(CASES))
def test_feature_table(case, tmp_path):
    fmt, zones, auth, window, dem = CASES[case]
    write = ia.write_ed269 if fmt == "ED-269" else ia.write_ed318
    write(tmp_path / "zones.json", zones)
    spec = load_spec(_spec(tmp_path, ["zones.json"], auth, window, dem))
    plan = plan_from_files(spec)
    report = check_airspace(plan, mission_programs(plan))
    assert report is not None
    # the flights as exported (the same route; the airspace gate is what is judged here)
    out = tmp_path / "out"
    write_outputs(dataclasses.replace(plan, airspace=None), spec, out)
    local = Local(15.0015, 49.401)
    got = {v.zone.identifier: v for v in report.verdicts}
    flights = {f.stem: ia.flight_legs(f, local) for f in [out / "mission.waypoints", *sorted(out.glob("sortie-*.waypoints"))]}
    flat = (lambda lon, lat: plan.launch.home[2]) if not dem else ground
    for z in zones:
        expected_by_flight = {stem: ia.expected_verdict(z, legs, local, home, flat, set(auth), window)
                              for stem, (legs, home) in flights.items()}
        verdicts = {e.verdict for e in expected_by_flight.values()}
        assert None not in verdicts, f"{case}: zone {z.ident} has a leg on its edge: change the case"
        expected = "block" if "block" in verdicts else "advise" if "advise" in verdicts else "neither"
        verdict = got[z.ident].verdict if z.ident in got else "neither"
        assert verdict == expected, (case, z.ident, got.get(z.ident) and got[z.ident].text())
        # per leg: every leg the independent check finds in the zone's band carries a meeting the plan reports,
        # and every meeting reported lies on such a leg (within a metre)
        for stem, e in expected_by_flight.items():
            reported = [m for m in (got[z.ident].meetings if z.ident in got else ()) if m.flight == stem]
            pts = [local.xy(*m.lonlat) for m in reported]
            for leg in e.legs:
                assert any(_on(p, leg) for p in pts), (case, z.ident, stem, leg)
            maybe = [leg for leg in flights[stem][0] if ia.meets(z, leg, local, flights[stem][1], flat, 1.0)]
            for p, m in zip(pts, reported):
                assert any(_on(p, leg) for leg in maybe), (case, z.ident, stem, m.text())
    if any(v.verdict == "block" for v in report.verdicts):
        with pytest.raises(CheckFailed, match=r"may not enter: BLOCK zone " + report.of("block")[0].zone.identifier):
            write_outputs(plan, spec, tmp_path / "refused")
        assert not (tmp_path / "refused").exists()
    else:
        write_outputs(plan, spec, tmp_path / "written")
        assert (tmp_path / "written" / "manifest.json").exists()


def _on(p: tuple[float, float], leg: ia.Leg3, tol: float = 1.0) -> bool:
    (ax, ay), (bx, by) = leg.a, leg.b
    dx, dy = bx - ax, by - ay
    t = 0.0 if dx == dy == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)))
    return float(np.hypot(ax + t * dx - p[0], ay + t * dy - p[1])) <= tol
