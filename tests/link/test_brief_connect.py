"""`aerosurvey brief --connect URL`: the connected vehicle's checks (`aerosurvey upload`'s, of the first flight)
in the brief, read only: the fake vehicle gets parameter and position requests and no mission message. A
check that refuses makes the brief no-go (exit 1) and is named; each refusal is listed, not just the first.
Against the fake vehicle as an ArduPilot copter and a PX4 copter."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from fake_vehicle import FakeVehicle, VehicleModel
from test_link_checks import home_of, planned_folder, sent_mission_messages

from aerosurvey.cli import main

FRIDAY = "2026-05-15T09:00+02:00"


def brief(folder: Path, model: VehicleModel, *options: str) -> tuple[int, dict]:
    with FakeVehicle(model, "udp") as fv:
        res = CliRunner().invoke(main, ["brief", str(folder), "--at", FRIDAY, "--json", "--connect", fv.url, *options])
    assert res.exit_code in (0, 1), res.output
    return res.exit_code, json.loads(res.output.split("\nError")[0])


def vehicle_items(got: dict) -> list[dict]:
    return [i for i in got["items"] if i["topic"] == "vehicle"]


@pytest.fixture(scope="module")
def ardupilot(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return planned_folder(tmp_path_factory.mktemp("ap"), {})


@pytest.fixture(scope="module")
def px4(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return planned_folder(tmp_path_factory.mktemp("px4"), {"vehicle": {"firmware": "px4"}})


def test_a_vehicle_set_as_planned_is_go_and_gets_no_mission(ardupilot: Path) -> None:
    model = VehicleModel(storage="ardupilot", home=home_of(ardupilot / "mission.plan"))
    code, got = brief(ardupilot, model)
    assert code == 0, got
    items = vehicle_items(got)
    assert items and all(i["verdict"] == "go" for i in items), items
    texts = " | ".join(i["text"] for i in items)
    assert "ArduPilot" in texts and "mission.plan" in texts and "launch point: the vehicle is 0 m from" in texts
    for check in ("terrain", "camera", "rtl-altitude", "speed", "battery-failsafe"):
        assert any(i["text"].startswith(check) for i in items), (check, texts)
    assert sent_mission_messages(model) == []
    assert model.log.get("got PARAM_REQUEST_READ CAM1_TYPE", 0) > 0


def test_every_refusing_check_is_listed_and_makes_it_no_go(ardupilot: Path) -> None:
    home = home_of(ardupilot / "mission.plan")
    model = VehicleModel(storage="ardupilot", home=home, mav_type=1, params={"CAM1_TYPE": 0})  # a plane, no camera
    code, got = brief(ardupilot, model)
    assert code == 1 and got["verdict"] == "no-go"
    refused = [i["text"] for i in vehicle_items(got) if i["verdict"] == "no-go"]
    assert len(refused) == 2, refused
    assert "MAV_TYPE 1 (a plane)" in refused[0]
    assert "CAM1_TYPE = 0 (no camera)" in refused[1] and "--accept camera" in refused[1]
    assert sent_mission_messages(model) == []


def test_a_vehicle_far_from_the_launch_point_is_no_go_unless_not_compared(ardupilot: Path) -> None:
    lat, lon, alt = home_of(ardupilot / "mission.plan")
    model = VehicleModel(storage="ardupilot", home=(lat + 0.01, lon, alt))  # 1.1 km north
    code, got = brief(ardupilot, model)
    assert code == 1
    assert any("from the planned launch point" in i["text"] and i["verdict"] == "no-go" for i in vehicle_items(got))
    code, got = brief(ardupilot, VehicleModel(storage="ardupilot", home=(lat + 0.01, lon, alt)), "--launch-distance", "off")
    assert code == 0 and all(i["verdict"] == "go" for i in vehicle_items(got))


def test_px4_settings_are_read_and_judged(px4: Path) -> None:
    home = home_of(px4 / "mission.plan")
    model = VehicleModel(px4=True, home=home)
    code, got = brief(px4, model)
    assert code == 0, got
    assert any("TRIG_MODE = 4" in i["text"] for i in vehicle_items(got))
    model = VehicleModel(px4=True, home=home, params={"TRIG_MODE": 0})
    code, got = brief(px4, model)
    assert code == 1
    assert any("TRIG_MODE = 0" in i["text"] and i["verdict"] == "no-go" for i in vehicle_items(got))
    assert sent_mission_messages(model) == []


def test_a_vehicle_that_cannot_be_reached_is_no_go(ardupilot: Path) -> None:
    res = CliRunner().invoke(main, ["brief", str(ardupilot), "--at", FRIDAY, "--json", "--connect", "tcp:127.0.0.1:9"])
    assert res.exit_code == 1, res.output
    items = vehicle_items(json.loads(res.output.split("\nError")[0]))
    assert len(items) == 1 and items[0]["verdict"] == "no-go" and "tcp:127.0.0.1:9" in items[0]["text"]
