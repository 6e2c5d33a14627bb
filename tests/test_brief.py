"""`aerosurvey brief`: the zones that apply at the time flown, the batteries, the sun and sunset; go or no-go."""

from __future__ import annotations

import datetime as dt
import json
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import example, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parent / "airspace"))
import independent_airspace as ia  # noqa: E402
from aerosurvey.brief import Sortie, flying_window, sunset_after  # noqa: E402
from aerosurvey.cli import main  # noqa: E402
from conftest import make_spec  # noqa: E402

CEST = dt.timezone(dt.timedelta(hours=2))
BST = dt.timezone(dt.timedelta(hours=1))


def test_sunset_is_the_published_one():
    # London on the 2024 solstice: 21:21 BST (timeanddate.com, to the minute)
    got = sunset_after(-0.1278, 51.5074, dt.datetime(2024, 6, 21, 12, tzinfo=BST))
    want = dt.datetime(2024, 6, 21, 21, 21, tzinfo=BST)
    assert got is not None and abs((got - want).total_seconds()) <= 90, got


@settings(max_examples=60, deadline=None)
@given(lat=st.floats(-55, 55), lon=st.floats(-179, 179), day=st.dates(dt.date(2020, 1, 1), dt.date(2035, 12, 31)))
@example(lat=0.0, lon=-89.75, day=dt.date(2020, 12, 19))  # sunset at 00:00 UTC: on neither UTC date for astral
def test_sunset_agrees_with_astral(lat, lon, day):
    """astral (its own implementation of the solar equations, refraction 0.833°) as the independent reference, asked
    for the sunset of the local day (its zone the longitude's whole hours: a sunset near midnight UTC falls on no UTC
    date astral will name)."""
    from astral import Observer
    from astral.sun import sunset

    want = sunset(Observer(latitude=lat, longitude=lon), day, tzinfo=dt.timezone(dt.timedelta(hours=round(lon / 15.0))))
    got = sunset_after(lon, lat, want - dt.timedelta(hours=3))
    assert got is not None and abs((got - want).total_seconds()) <= 60, (got, want)


def test_the_window_is_the_flights_and_the_battery_changes():
    at = dt.datetime(2026, 5, 14, 9, tzinfo=CEST)
    first, last = flying_window(at, [Sortie("S01", 600, 90, 70), Sortie("S02", 900, 95, 75)], 5.0)
    assert first == at and last == at + dt.timedelta(seconds=600 + 300 + 900)


@pytest.fixture
def planned(tmp_path):
    ring = [(14.99, 49.39), (15.02, 49.39), (15.02, 49.41), (14.99, 49.41), (14.99, 49.39)]
    # an airfield zone over the area, prohibited on Saturdays only, from the ground to 40 m AGL: the take-off climbs through it
    saturday = ia.Period(schedule=(ia.Daily(("SAT",), dt.time(0, tzinfo=CEST), dt.time(23, 59, tzinfo=CEST)),))
    ia.write_ed269(tmp_path / "zones.json", [ia.Zone("LKAIR", "PROHIBITED", (0, "m", "AGL"), (40, "m", "AGL"), ring=ring,
                                                     periods=(saturday,), message="airfield: weekend gliding")])
    spec = make_spec(tmp_path, {"battery": {"usable_min": 20, "reserve": 0.25}})
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    return tmp_path


def _brief(tmp: Path, *args: str):
    return CliRunner().invoke(main, ["brief", str(tmp / "out"), "--json", "--zones", str(tmp / "zones.json"), *args])


def test_a_zone_blocks_the_day_it_applies_and_not_the_day_before(planned):
    friday = _brief(planned, "--at", "2026-05-15T09:00+02:00")
    assert friday.exit_code == 0, friday.output
    got = json.loads(friday.output)
    assert got["verdict"] == "go"
    assert {i["topic"]: i["verdict"] for i in got["items"]} == {"airspace": "go", "batteries": "go", "daylight": "go"}
    saturday = _brief(planned, "--at", "2026-05-16T09:00+02:00")
    assert saturday.exit_code == 1
    got = json.loads(saturday.output.split("\nError")[0])
    zone = next(i for i in got["items"] if i["topic"] == "airspace")
    assert zone["verdict"] == "no-go" and "LKAIR" in zone["text"]


def test_a_flight_into_the_night_is_no_go_and_says_when_the_sun_sets(planned):
    late = _brief(planned, "--at", "2026-05-15T20:33+02:00")  # sunset there 20:37 CEST (astral: the test above)
    assert late.exit_code == 1
    day = next(i for i in json.loads(late.output.split("\nError")[0])["items"] if i["topic"] == "daylight")
    assert day["verdict"] == "no-go" and "sunset 2026-05-15T20:37" in day["text"]


def test_without_zone_files_the_airspace_is_said_unchecked(planned):
    res = CliRunner().invoke(main, ["brief", str(planned / "out"), "--at", "2026-05-15T09:00+02:00"])
    assert res.exit_code == 0, res.output
    assert "ADVISE airspace: no official zone file was given" in res.output


def test_bad_input_is_refused_in_one_line(planned):
    res = CliRunner().invoke(main, ["brief", str(planned / "out"), "--at", "9am"])
    assert res.exit_code == 2 and "--at = '9am' is not allowed" in res.output
    (planned / "spec.toml").write_text((planned / "spec.toml").read_text() + "\n# changed\n")
    res = CliRunner().invoke(main, ["brief", str(planned / "out"), "--at", "2026-05-15T09:00+02:00"])
    assert res.exit_code == 2 and "is not the spec" in res.output


def test_a_wind_of_the_day_is_planned_in_and_one_too_strong_is_no_go(tmp_path):
    spec = make_spec(tmp_path, {"battery": {"usable_min": 20, "reserve": 0.25},
                                "vehicle": {"cruise_speed_ms": 10.0, "max_airspeed_ms": 12.0}})
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "out")]).exit_code == 0
    at = ["--at", "2026-05-15T09:00+02:00", "--json"]
    calm = json.loads(CliRunner().invoke(main, ["brief", str(tmp_path / "out"), *at]).output)
    windy = CliRunner().invoke(main, ["brief", str(tmp_path / "out"), *at, "--wind", "6@240"])
    assert windy.exit_code == 0, windy.output
    got = json.loads(windy.output)
    wind = next(i for i in got["items"] if i["topic"] == "wind")
    assert wind["verdict"] == "go" and wind["text"].startswith("6 m/s from 240° true")
    assert dt.datetime.fromisoformat(got["end"]) > dt.datetime.fromisoformat(calm["end"])  # the flights take longer
    gale = CliRunner().invoke(main, ["brief", str(tmp_path / "out"), *at, "--wind", "13@240"])
    assert gale.exit_code == 1
    item = next(i for i in json.loads(gale.output.split("\nError")[0])["items"] if i["topic"] == "plan")
    assert item["verdict"] == "no-go" and "conditions.wind" in item["text"]
