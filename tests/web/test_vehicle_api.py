"""The page's vehicle (`aerosurvey serve --connect URL`): a plan's mission file checked against the fake
vehicle (nothing sent), then uploaded on the pilot's request, read back and compared, as `aerosurvey upload`
does; what the vehicle holds comes back as a .waypoints file. ArduPilot and PX4 flavours of the fake vehicle.
The read-back file is judged against the plan's own .waypoints by the project's reader, item by item."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest
from webutil import client, run_plan, wait_job

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "link"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from fake_vehicle import FakeVehicle, VehicleModel  # noqa: E402

from aerosurvey.mission.formats.wpl import loads_wpl  # noqa: E402
from conftest import make_spec  # noqa: E402


def mission_messages(model: VehicleModel) -> int:
    return sum(v for k, v in model.log.items() if k.startswith("got MISSION_"))


@pytest.fixture(params=["ardupilot", "px4"])
def page(request, tmp_path):
    """The page over a small copter spec for the autopilot, a fake vehicle at its launch point, and the plan made."""
    px4 = request.param == "px4"
    spec = make_spec(tmp_path, {"vehicle": {"firmware": "px4"}} if px4 else {})
    model = VehicleModel(px4=True) if px4 else VehicleModel(storage="ardupilot")
    with FakeVehicle(model, "udp") as fv, client(spec, vehicle=fv.url) as c:
        done = run_plan(c, c.get("/api/state").json()["spec"])
        assert done["state"] == "done", done
        pid = done["result"]["plan_id"]
        plan = loads_wpl(c.get(f"/api/plans/{pid}/files/mission.waypoints").text, "mission.waypoints")
        model.home = plan.home
        yield c, pid, model, plan


def test_check_then_upload_verified_and_what_the_vehicle_holds(page):
    c, pid, model, plan = page
    assert c.get("/api/vehicle").json()["url"].startswith("udpout:")
    checked = wait_job(c, c.post(f"/api/plans/{pid}/vehicle/mission.plan", json={"send": False}))
    assert checked["state"] == "done", checked
    got = checked["result"]
    assert got["refusals"] == [] and got["verified"] is False and "report" not in got
    assert any(line.startswith("launch point: the vehicle is 0 m from") for line in got["checks"]), got["checks"]
    assert any(line.startswith("battery-failsafe") for line in got["checks"])
    assert got["position"] == pytest.approx([plan.home[0], plan.home[1]], abs=1e-6)
    assert mission_messages(model) == 0  # a check sends no mission message
    sent = wait_job(c, c.post(f"/api/plans/{pid}/vehicle/mission.plan", json={"send": True}))
    assert sent["state"] == "done", sent
    got = sent["result"]
    assert got["verified"] is True and any(line.startswith("verified:") for line in got["report"])
    held = loads_wpl(got["held_waypoints"], "held.waypoints")
    assert len(held.items) == len(plan.items)
    for a, b in zip(held.items, plan.items):
        assert a.command == b.command
        if a.command not in (183, 203):  # DO_SET_SERVO / DO_DIGICAM: parameters, not a place
            assert (a.x, a.y) == pytest.approx((b.x, b.y), abs=2e-7)
        assert a.z == pytest.approx(b.z, abs=0.01)


def test_a_refusing_setting_is_listed_by_the_check_and_stops_the_upload(page):
    c, pid, model, plan = page
    setting = {"TRIG_MODE": 0} if "TRIG_MODE" in model.params else {"CAM1_TYPE": 0}  # the PX4 flavour has TRIG_MODE
    model.params.update(setting)
    got = wait_job(c, c.post(f"/api/plans/{pid}/vehicle/mission.plan", json={"send": False}))["result"]
    assert len(got["refusals"]) == 1 and next(iter(setting)) in got["refusals"][0] and "--accept camera" in got["refusals"][0]
    sent = wait_job(c, c.post(f"/api/plans/{pid}/vehicle/mission.plan", json={"send": True}))
    assert sent["state"] == "error" and next(iter(setting)) in sent["error"]["message"], sent
    assert mission_messages(model) == 0


def test_nothing_reaches_the_vehicle_from_another_origin_or_without_the_pilots_request(page):
    c, pid, model, _ = page
    r = c.post(f"/api/plans/{pid}/vehicle/mission.plan", json={"send": True},
               headers={"host": "127.0.0.1:8765", "origin": "https://evil.example"})
    assert r.status_code == 403
    for body in ({}, {"send": "yes"}, None):
        r = c.post(f"/api/plans/{pid}/vehicle/mission.plan", json=body)
        assert r.status_code == 400 and r.json()["key"] == "vehicle", r.text
    bad = wait_job(c, c.post(f"/api/plans/{pid}/vehicle/plan.geojson", json={"send": True}))
    assert bad["state"] == "error" and "not a mission file" in bad["error"]["message"]
    assert c.post("/api/plans/p999/vehicle/mission.plan", json={"send": True}).status_code == 404
    time.sleep(0.3)
    assert mission_messages(model) == 0


def test_without_a_vehicle_the_page_says_how_to_connect(tmp_path):
    spec = make_spec(tmp_path, {})
    with client(spec) as c:
        assert c.get("/api/vehicle").json() == {"url": None}
        r = c.post("/api/plans/p1/vehicle/mission.plan", json={"send": True})
        assert r.status_code == 404 and "serve --connect" in r.json()["error"]


FRIDAY = "2026-05-15T09:00:00+02:00"


def brief_of(c, pid: str) -> tuple[dict, list[dict]]:
    """The page's brief for FRIDAY, and its vehicle items."""
    r = c.post(f"/api/plans/{pid}/brief", json={"at": FRIDAY})
    assert r.status_code == 200, r.text
    got = r.json()
    return got, [i for i in got["items"] if i["topic"] == "vehicle"]


def test_the_brief_has_the_vehicles_checks_and_a_refusing_setting_makes_it_no_go(page):
    """As `aerosurvey brief --connect`: the first flight checked as `upload` checks it, a line per check, read
    only; a setting that refuses is a no-go item naming it and makes the brief no-go."""
    c, pid, model, _ = page
    got, items = brief_of(c, pid)
    assert items and all(i["verdict"] == "go" for i in items), items
    assert got["verdict"] in ("go", "advise"), got  # the spec has no official zone file: the airspace is advice
    assert items[0]["text"].endswith("checked as `aerosurvey upload mission.plan` checks it (nothing sent)")
    assert any(i["text"].startswith("launch point: the vehicle is 0 m from") for i in items), items
    for check in ("camera", "rtl-altitude", "speed", "battery-failsafe"):
        assert any(i["text"].startswith(check) for i in items), (check, items)
    setting = {"TRIG_MODE": 0} if "TRIG_MODE" in model.params else {"CAM1_TYPE": 0}  # the PX4 flavour has TRIG_MODE
    model.params.update(setting)
    got, items = brief_of(c, pid)
    assert got["verdict"] == "no-go", got
    refused = [i["text"] for i in items if i["verdict"] == "no-go"]
    assert len(refused) == 1 and f"{next(iter(setting))} = 0" in refused[0] and "--accept camera" in refused[0], refused
    assert model.log.get(f"got PARAM_REQUEST_READ {next(iter(setting))}", 0) > 0
    assert mission_messages(model) == 0  # a brief sends no mission message


def test_a_vehicle_the_server_cannot_reach_makes_the_brief_no_go(tmp_path):
    spec = make_spec(tmp_path, {})
    with client(spec, vehicle="tcp:127.0.0.1:9") as c:
        done = run_plan(c, c.get("/api/state").json()["spec"])
        assert done["state"] == "done", done
        got, items = brief_of(c, done["result"]["plan_id"])
    assert got["verdict"] == "no-go"
    assert len(items) == 1 and items[0]["verdict"] == "no-go" and items[0]["text"].startswith("tcp:127.0.0.1:9: "), items
