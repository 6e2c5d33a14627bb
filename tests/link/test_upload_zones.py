"""`aerosurvey upload --zones`: official UAS zones (ED-269, ED-318) checked at upload against the flight
the vehicle will fly, when it flies it (`--at`, default now), its return at the vehicle's own RTL altitude.

The plan folders are made by `aerosurvey plan` without the zones, so only the upload can refuse. A
zone that blocks refuses with exit code 3 and no mission message sent to the fake vehicle; `--accept
airspace` uploads and says so. The expected verdicts are the test's own: flat ground (no DEM), the
zones' bands against the heights the test reads from the uploaded file and the vehicle's RTL_ALT.
"""

from __future__ import annotations

import datetime as dt
import json
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from fake_vehicle import FakeVehicle, VehicleModel
from test_link_checks import home_of, planned_folder, sent_mission_messages

from aerosurvey.cli import main
from aerosurvey.mission.formats.qgc_plan import loads_plan

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import independent_airspace as ia  # noqa: E402

CEST = dt.timezone(dt.timedelta(hours=2))
FRIDAY = "2026-05-15T09:00+02:00"
SATURDAY = "2026-05-16T09:00+02:00"
#: a ring round the test spec's area (make_spec's rectangle) and its launch point
RING = [(14.99, 49.39), (15.02, 49.39), (15.02, 49.41), (14.99, 49.41), (14.99, 49.39)]


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return planned_folder(tmp_path_factory.mktemp("zones"), {})


def upload(plan: Path, model: VehicleModel, *options: str):
    with FakeVehicle(model, "udp") as fv:
        return CliRunner().invoke(main, ["upload", str(plan), "--connect", fv.url, *options])


def with_zones(plan: Path, zones: Path, *options: str, at: str = FRIDAY, params: dict | None = None):
    """Upload `plan` with `zones` at `at` to an ArduPilot copter at its launch point: (the result, the vehicle)."""
    model = VehicleModel(storage="ardupilot", home=home_of(plan), params=params)
    return upload(plan, model, "--zones", str(zones), "--at", at, *options), model


def flown_heights(plan: Path) -> tuple[float, float]:
    """The lowest and highest altitude above home of the places the uploaded file flies to."""
    m = loads_plan(plan.read_text(), str(plan))
    z = [it.z for it in m.items if it.has_position and it.z > 0]
    return min(z), max(z)


def ground_zone(ident: str, restriction: str, top_m: float, **kw) -> ia.Zone:
    """A zone over the area and its launch point from the ground to `top_m` above it."""
    return ia.Zone(ident, restriction, (0, "m", "AGL"), (top_m, "m", "AGL"), ring=kw.pop("ring", RING), **kw)


def zone_file(tmp: Path, name: str, zone: ia.Zone, fmt: str = "ed269") -> Path:
    path = tmp / name
    if fmt == "ed269":
        return ia.write_ed269(path, [zone])
    return ia.write_ed318(path, [zone])


def test_a_prohibited_zone_refuses_with_nothing_sent_and_accept_uploads(folder: Path, tmp_path: Path) -> None:
    plan = folder / "mission.plan"
    zones = zone_file(tmp_path, "z.json", ground_zone("LKPROH", "PROHIBITED", 40, message="nature reserve"))
    res, model = with_zones(plan, zones)
    assert res.exit_code == 3, res.output
    assert sent_mission_messages(model) == []
    line = res.output.strip()
    assert len(line.splitlines()) == 1
    assert "BLOCK zone LKPROH" in line and "takeoff" in line and "--accept airspace" in line, line
    assert "2026-05-15T09:00+02:00 to" in line
    res, model = with_zones(plan, zones, "--accept", "airspace")
    assert res.exit_code == 0, res.output
    assert "ACCEPTED by the pilot (--accept airspace)" in res.output and "LKPROH" in res.output
    assert "verified:" in res.output and len(model.stored[0]) > 0


def test_a_weekend_zone_uploads_on_friday_and_refuses_on_saturday(folder: Path, tmp_path: Path) -> None:
    plan = folder / "mission.plan"
    saturday = ia.Period(schedule=(ia.Daily(("SAT",), dt.time(0, tzinfo=CEST), dt.time(23, 59, tzinfo=CEST)),))
    for fmt in ("ed269", "ed318"):
        zones = zone_file(tmp_path, f"w.{fmt}.json", ground_zone("LKAIR", "PROHIBITED", 40, periods=(saturday,)), fmt)
        res, model = with_zones(plan, zones)
        assert res.exit_code == 0, res.output
        assert "airspace: 1 zone(s) read" in res.output and "verified:" in res.output
        res, model = with_zones(plan, zones, at=SATURDAY)
        assert res.exit_code == 3 and "BLOCK zone LKAIR" in res.output, res.output
        assert sent_mission_messages(model) == []


def test_a_conditional_zone_advises_with_its_message(folder: Path, tmp_path: Path) -> None:
    plan = folder / "mission.plan"
    zones = zone_file(tmp_path, "c.json", ground_zone("LKCOND", "CONDITIONAL", 500, message="call the tower on 123.45"))
    res, _ = with_zones(plan, zones)
    assert res.exit_code == 0, res.output
    advice = [ln for ln in res.output.splitlines() if "ADVISE zone LKCOND" in ln]
    assert len(advice) == 1 and "call the tower on 123.45" in advice[0]


def test_the_return_is_checked_at_the_vehicles_rtl_altitude(folder: Path, tmp_path: Path) -> None:
    """A band above every place the flight goes: the planned flight stays under it, the vehicle's RTL climbs into it."""
    plan = folder / "mission.plan"
    doc = json.loads((folder / "manifest.json").read_text())
    assert doc["sorties"] == [] or len(doc["sorties"]) == 1  # one flight: mission.plan is what flies
    low, high = flown_heights(plan)
    base = high + 40.0
    zones = zone_file(tmp_path, "r.json", ia.Zone("LKHIGH", "PROHIBITED", (base, "m", "AGL"), (base + 200, "m", "AGL"),
                                                  ring=RING))
    inside_cm = round((base + 60.0) * 100)  # the vehicle returns 60 m inside the band
    below_cm = round((high - 10.0) * 100)  # below the flight: it returns where it is
    res, model = with_zones(plan, zones, params={"RTL_ALT": inside_cm})
    assert res.exit_code == 3, res.output
    assert "BLOCK zone LKHIGH" in res.output and "(rtl" in res.output, res.output
    assert sent_mission_messages(model) == []
    res, model = with_zones(plan, zones, params={"RTL_ALT": below_cm})
    assert res.exit_code == 0, res.output
    assert "verified:" in res.output


def test_zone_options_are_checked_as_input(folder: Path, tmp_path: Path) -> None:
    plan = folder / "mission.plan"
    model = VehicleModel(storage="ardupilot", home=home_of(plan))
    res = upload(plan, model, "--at", FRIDAY)
    assert res.exit_code == 2 and "--at" in res.output and "--zones" in res.output
    res = upload(plan, model, "--accept", "airspace")
    assert res.exit_code == 2 and "--accept 'airspace' is not a check of upload" in res.output
    broken = tmp_path / "broken.json"
    broken.write_text('{"features": [ {"identifier": ')
    res = upload(plan, model, "--zones", str(broken), "--at", FRIDAY)
    assert res.exit_code == 2 and "broken.json" in res.output, res.output
    bare = tmp_path / "bare"
    bare.mkdir()
    (bare / "mission.plan").write_text(plan.read_text())
    res = upload(bare / "mission.plan", model, "--zones", str(broken), "--at", FRIDAY)
    assert res.exit_code == 2 and "manifest.json" in res.output, res.output
    assert sent_mission_messages(model) == []


def test_zones_that_change_the_route_refuse_the_file_planned_without_them(folder: Path, tmp_path: Path) -> None:
    """A zone from the ground to 1 km over a corner of the area: the route keeps clear of it, so the file planned
    without it is not the flight the zones were checked on."""
    plan = folder / "mission.plan"
    corner = [(15.000, 49.400), (15.002, 49.400), (15.002, 49.401), (15.000, 49.401), (15.000, 49.400)]
    corner = [(x + 0.003, y + 0.002) for x, y in corner]
    zones = zone_file(tmp_path, "k.json", ground_zone("LKWALL", "PROHIBITED", 1000, ring=corner))
    res, model = with_zones(plan, zones)
    assert res.exit_code == 3, res.output
    assert "the zones change the route" in res.output, res.output
    assert sent_mission_messages(model) == []


def test_px4_a_prohibited_zone_refuses_before_anything_is_sent(tmp_path: Path) -> None:
    folder = planned_folder(tmp_path, {"vehicle": {"firmware": "px4"}})
    plan = folder / "mission.plan"
    zones = zone_file(tmp_path, "z.json", ground_zone("LKPX4", "REQ_AUTHORISATION", 40))
    model = VehicleModel(px4=True, home=home_of(plan))
    res = upload(plan, model, "--zones", str(zones), "--at", FRIDAY)
    assert res.exit_code == 3, res.output
    assert "BLOCK zone LKPX4" in res.output and "authorisation required" in res.output, res.output
    assert sent_mission_messages(model) == []
