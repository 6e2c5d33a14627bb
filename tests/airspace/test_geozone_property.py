"""Random zones, bands and windows over random small plans: every zone's verdict is the one the
independent 4-D check (tests/independent_airspace.py) gives from the exported missions, where
that check is firm (no leg within a metre of an outline or half a metre of a limit)."""

from __future__ import annotations

import dataclasses
import datetime as dt

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import independent_airspace as ia
from aerosurvey.airspace.check import check_airspace
from aerosurvey.errors import InputError
from aerosurvey.inputs import plan_from_files
from aerosurvey.outputs import mission_programs, write_outputs
from aerosurvey.spec import load_spec
from conftest import make_spec
from independent_legs import Local

LON0, LAT0 = 15.0, 49.4
UTC = dt.UTC
MONDAY = dt.datetime(2026, 5, 11, tzinfo=UTC)


@st.composite
def zones(draw, n: int) -> ia.Zone:
    restriction = draw(st.sampled_from(["PROHIBITED", "REQ_AUTHORISATION", "CONDITIONAL", "NO_RESTRICTION"]))
    unit = draw(st.sampled_from(["m", "ft"]))
    k = 1 / 0.3048 if unit == "ft" else 1.0
    lo = draw(st.one_of(st.none(), st.floats(0, 120)))
    hi = draw(st.one_of(st.none(), st.floats(10, 200), st.just(99999.0)))
    if lo is not None and hi is not None and hi < lo:
        lo, hi = hi, lo
    lower = None if lo is None else (round(lo * k, 1), unit, "AGL")
    upper = None if hi is None else (hi if hi == 99999.0 else round(hi * k, 1), unit, "AGL")
    cx = LON0 + draw(st.floats(-0.002, 0.006))
    cy = LAT0 + draw(st.floats(-0.002, 0.005))
    periods: tuple[ia.Period, ...] = ()
    if draw(st.booleans()):
        days = tuple(sorted(draw(st.sets(st.sampled_from(ia.DAYS), min_size=1)), key=ia.DAYS.index))
        start = draw(st.integers(0, 23))
        span = draw(st.integers(1, 10))
        periods = (ia.Period(schedule=(ia.Daily(days, dt.time(start, tzinfo=UTC), dt.time((start + span) % 24, 30, tzinfo=UTC)),)),)
    if draw(st.booleans()):
        r = draw(st.floats(20, 250))
        return ia.Zone(f"Z{n}", restriction, lower, upper, circle=(cx, cy, round(r * k, 1), unit), periods=periods)
    w, h = draw(st.floats(0.0005, 0.004)), draw(st.floats(0.0005, 0.003))
    return ia.Zone(f"Z{n}", restriction, lower, upper, ring=[(cx, cy), (cx + w, cy), (cx + w, cy + h), (cx, cy + h), (cx, cy)],
                   periods=periods)


@st.composite
def cases(draw):
    n = draw(st.integers(1, 4))
    zs = [draw(zones(i)) for i in range(n)]
    auth = [z.ident for z in zs if z.restriction == "REQ_AUTHORISATION" and draw(st.booleans())]
    window = None
    if draw(st.booleans()):
        start = MONDAY + dt.timedelta(hours=draw(st.integers(0, 24 * 7)))
        window = (start, start + dt.timedelta(hours=draw(st.integers(1, 30))))
    size = (draw(st.floats(0.0015, 0.004)), draw(st.floats(0.001, 0.003)))
    height = draw(st.floats(40, 110))
    return zs, auth, window, size, height, draw(st.sampled_from(["ED-269", "ED-318"]))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(case=cases())
def test_random_zones_get_the_independent_verdict(case, tmp_path_factory):
    zs, auth, window, (w, h), height, fmt = case
    tmp = tmp_path_factory.mktemp("gz")
    (ia.write_ed269 if fmt == "ED-269" else ia.write_ed318)(tmp / "zones.json", zs)
    over: dict = {"targets": {"height_m": round(height, 1)}, "flight": {"exclusion_margin_m": 5.0},
                  "airspace": {"zones": ["zones.json"], "authorisations": auth}}
    if window:
        over["conditions"] = {"start": window[0].isoformat(), "end": window[1].isoformat()}
    area = [[LON0, LAT0], [LON0 + w, LAT0], [LON0 + w, LAT0 + h], [LON0, LAT0 + h], [LON0, LAT0]]
    p = make_spec(tmp, over, area=area)
    p.write_text(p.read_text().replace("gsd_cm = 2.5\n", ""))
    spec = load_spec(p)
    try:
        plan = plan_from_files(spec)
    except InputError as exc:  # zones that leave nothing to survey, or no launch point outside them
        assert "exclusion zones" in str(exc) or "launch" in str(exc), str(exc)
        event("refused: the zones leave no survey or no launch point")
        return
    report = check_airspace(plan, mission_programs(plan))
    assert report is not None
    out = tmp / "out"
    write_outputs(dataclasses.replace(plan, airspace=None), spec, out)
    local = Local(LON0 + w / 2, LAT0 + h / 2)
    flights = [ia.flight_legs(f, local) for f in [out / "mission.waypoints", *sorted(out.glob("sortie-*.waypoints"))]]
    got = {v.zone.identifier: v.verdict for v in report.verdicts}
    home = plan.launch.home[2]
    for z in zs:
        verdicts = {ia.expected_verdict(z, legs, local, home, lambda lon, lat: home, set(auth), window).verdict
                    for legs, _ in flights}
        if None in verdicts:
            event("a zone not firm (a leg on its edge)")
            continue  # a leg on the zone's edge or a limit: not firm
        expected = "block" if "block" in verdicts else "advise" if "advise" in verdicts else "neither"
        event(f"verdict {expected}")
        assert got.get(z.ident, "neither") == expected, (z, got, report.notes)


def test_every_zone_near_a_leg_is_listed(tmp_path):
    """A zone 500 m off the flights is listed (neither); one 5 km off is not."""
    near = ia.Zone("NEAR", "PROHIBITED", None, None, ring=[(15.010, 49.400), (15.011, 49.400), (15.011, 49.401), (15.010, 49.401)])
    far = ia.Zone("FAR", "PROHIBITED", None, None, ring=[(15.08, 49.40), (15.081, 49.40), (15.081, 49.401), (15.08, 49.401)])
    ia.write_ed318(tmp_path / "z.json", [near, far])
    p = make_spec(tmp_path, {"airspace": {"zones": ["z.json"]}})
    plan = plan_from_files(load_spec(p))
    report = check_airspace(plan, mission_programs(plan))
    assert report is not None
    assert [(v.zone.identifier, v.verdict) for v in report.verdicts] == [("NEAR", "neither")]
    assert report.rule_record()["status"] == "pass"


@pytest.mark.parametrize("fmt", ["ED-269", "ED-318"])
def test_plan_and_check_take_zones_from_the_command_line(fmt, tmp_path):
    from click.testing import CliRunner

    from aerosurvey.cli import main

    band = ia.Zone("B1", "PROHIBITED", (0, "m", "AGL"), (40, "m", "AGL"),
                   ring=[(14.99, 49.39), (15.02, 49.39), (15.02, 49.41), (14.99, 49.41), (14.99, 49.39)])
    (ia.write_ed269 if fmt == "ED-269" else ia.write_ed318)(tmp_path / "z.json", [band])
    spec = make_spec(tmp_path)
    runner = CliRunner()
    r = runner.invoke(main, ["plan", str(spec), "-o", str(tmp_path / "out"), "--zones", str(tmp_path / "z.json")])
    assert r.exit_code == 1, r.output
    assert "zone B1" in r.output and "takeoff" in r.output and "m AGL" in r.output
    assert not (tmp_path / "out").exists()
    r = runner.invoke(main, ["check", str(spec), "--zones", str(tmp_path / "z.json")])
    assert r.exit_code == 1 and "FAIL airspace" in r.output, r.output
    r = runner.invoke(main, ["plan", str(spec), "-o", str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    r = runner.invoke(main, ["check", str(tmp_path / "out"), "--zones", str(tmp_path / "z.json")])
    assert r.exit_code == 2 and "--zones is for a mission spec" in r.output
