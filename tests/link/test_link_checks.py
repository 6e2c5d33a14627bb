"""`aerosurvey upload` refuses a mission that does not fit the vehicle before it sends anything.

Each refusal is checked for its one line (with the figures), its exit code (3) and that the
vehicle got no mission message at all, against the fake vehicle set up as an ArduPilot
copter, an ArduPilot plane and a PX4 copter. The plan folders are made by `aerosurvey plan`.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from fake_vehicle import FakeVehicle, VehicleModel, survey_mission

from aerosurvey.cli import main
from aerosurvey.link.connection import open_link
from aerosurvey.mission.formats.qgc_plan import dumps_plan, loads_plan
from aerosurvey.mission.formats.wpl import dumps_wpl

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from conftest import make_spec  # noqa: E402

EARTH_M = 6_371_000.0


def great_circle_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Spherical law of cosines: an independent check of the distance the command prints."""
    p1, p2, dl = math.radians(lat1), math.radians(lat2), math.radians(lon2 - lon1)
    return EARTH_M * math.acos(min(1.0, math.sin(p1) * math.sin(p2) + math.cos(p1) * math.cos(p2) * math.cos(dl)))


def run(*args: str):
    return CliRunner().invoke(main, ["upload", *args])


def sent_mission_messages(model: VehicleModel) -> list[str]:
    return [k for k in model.log if k.startswith("got MISSION_")]


def refused(plan: Path, model: VehicleModel, *options: str) -> str:
    """Upload `plan` to `model`; it must be refused (exit 3) with nothing sent. Returns the one line."""
    with FakeVehicle(model, "udp") as fv:
        res = run(str(plan), "--connect", fv.url, *options)
    assert res.exit_code == 3, res.output
    assert sent_mission_messages(model) == []
    lines = res.output.strip().splitlines()
    assert len(lines) == 1
    return lines[0]


def planned_folder(tmp: Path, overrides: dict) -> Path:
    """The folder `aerosurvey plan` writes for the test spec with `overrides`."""
    spec = make_spec(tmp, overrides)
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp / "out")])
    assert res.exit_code == 0, res.output
    return tmp / "out"


@pytest.fixture(scope="module")
def split_plan(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copter plan folder whose battery (10 min) splits it into sorties."""
    return planned_folder(tmp_path_factory.mktemp("split"), {"battery": {"usable_min": 10.0, "reserve": 0.25}})


def home_of(plan: Path) -> tuple[float, float, float]:
    return loads_plan(plan.read_text(), str(plan)).home


def test_whole_mission_that_needs_several_batteries_is_refused_naming_the_sorties(split_plan: Path) -> None:
    doc = json.loads((split_plan / "manifest.json").read_text())
    sorties = [s["files"][0] for s in doc["sorties"]]
    assert len(sorties) >= 2
    model = VehicleModel(storage="ardupilot", home=home_of(split_plan / "mission.plan"))
    minutes = doc["estimates"]["total_time_s"] / 60
    assert refused(split_plan / "mission.plan", model) == (
        f"Error: mission.plan is the whole mission, an estimated {minutes:.1f} min of flight, but one battery gives "
        f"10 min (25% kept in reserve): upload its {len(sorties)} sorties one at a time ({', '.join(sorties)})")
    # the same vehicle takes a sortie
    with FakeVehicle(model, "udp") as fv:
        res = run(str(split_plan / sorties[0]), "--connect", fv.url)
    assert res.exit_code == 0, res.output
    assert "checked against manifest.json (sortie S01)" in res.output and "verified:" in res.output


def test_more_items_than_the_spec_allows_is_refused(split_plan: Path, tmp_path: Path) -> None:
    folder = tmp_path / "plan"
    folder.mkdir()
    doc = json.loads((split_plan / "manifest.json").read_text())
    doc["battery"]["max_mission_items"] = 5
    (folder / "manifest.json").write_text(json.dumps(doc))
    sortie = folder / "sortie-01.plan"
    sortie.write_bytes((split_plan / "sortie-01.plan").read_bytes())
    n = len(loads_plan(sortie.read_text()).items) + 1  # home included
    assert refused(sortie, VehicleModel(storage="ardupilot", home=home_of(sortie))) == (
        f"Error: sortie-01.plan has {n} mission items (home included) but the spec's battery.max_mission_items "
        "allows 5: plan it with smaller sorties")


def test_a_file_changed_since_planning_is_checked_on_its_own_fields(split_plan: Path, tmp_path: Path) -> None:
    folder = tmp_path / "plan"
    folder.mkdir()
    (folder / "manifest.json").write_bytes((split_plan / "manifest.json").read_bytes())
    whole = folder / "mission.plan"
    whole.write_text((split_plan / "mission.plan").read_text().replace("    ", "  "))  # same mission, other bytes
    model = VehicleModel(storage="ardupilot", home=home_of(whole))
    with FakeVehicle(model, "udp") as fv:
        res = run(str(whole), "--connect", fv.url, "--no-verify")
    assert res.exit_code == 0, res.output
    assert "checked on its own fields (manifest.json does not list this file as it is)" in res.output


@pytest.mark.parametrize(("mission_vehicle", "model", "said"), [
    ("plane", VehicleModel(storage="ardupilot"), "MAV_TYPE 2 (a copter)"),
    ("copter", VehicleModel(storage="ardupilot", plane=True), "MAV_TYPE 1 (a plane)"),
    ("copter", VehicleModel(storage="ardupilot", mav_type=10), "MAV_TYPE 10 (neither a copter nor a plane)"),
])
def test_a_mission_for_another_vehicle_type_is_refused(tmp_path: Path, mission_vehicle: str, model: VehicleModel,
                                                       said: str) -> None:
    plan = tmp_path / "survey.plan"
    m = survey_mission(10, vehicle=mission_vehicle)
    plan.write_text(dumps_plan(m))
    model.home = m.home
    assert refused(plan, model) == (f"Error: survey.plan is a {mission_vehicle} mission but the vehicle reports {said}: "
                                    "upload a mission planned for this vehicle")


def test_the_kubad_plane_mission_with_its_landing_never_goes_onto_a_copter(tmp_path: Path) -> None:
    spec = make_spec(tmp_path, {"vehicle": {"type": "plane", "cruise_speed_ms": 16.0},
                                "flight": {"end": "land", "wind_from_deg": 270, "approach_m": 400}})
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    plan = tmp_path / "out" / "mission.plan"
    assert 21 in {it.command for it in loads_plan(plan.read_text()).items}  # NAV_LAND
    line = refused(plan, VehicleModel(storage="ardupilot", home=home_of(plan)))
    assert line.startswith("Error: mission.plan is a plane mission but the vehicle reports MAV_TYPE 2 (a copter)")


def test_a_plan_for_ardupilot_is_refused_by_a_px4_vehicle(tmp_path: Path) -> None:
    plan = tmp_path / "survey.plan"
    m = survey_mission(10)
    plan.write_text(dumps_plan(m))
    assert refused(plan, VehicleModel(px4=True, home=m.home)) == (
        "Error: the plan is for ardupilot but the vehicle reports PX4: plan the mission for px4 and upload that")


def test_a_px4_vehicle_takes_a_px4_plan(tmp_path: Path) -> None:
    plan = tmp_path / "survey.plan"
    m = survey_mission(10, firmware="px4")
    plan.write_text(dumps_plan(m))
    model = VehicleModel(px4=True, home=m.home)
    with FakeVehicle(model, "udp") as fv:
        res = run(str(plan), "--connect", fv.url)
    assert res.exit_code == 0, res.output
    assert "PX4, MAV_TYPE 2" in res.output and "verified: 15 mission items" in res.output
    assert len(model.stored[0]) == 15


@pytest.mark.parametrize("px4", [False, True])
def test_a_vehicle_far_from_the_launch_point_is_refused_unless_the_pilot_names_the_distance(tmp_path: Path,
                                                                                           px4: bool) -> None:
    plan = tmp_path / "survey.plan"
    m = survey_mission(10, firmware="px4" if px4 else "ardupilot")
    plan.write_text(dumps_plan(m))
    far = (m.home[0] - 16.7, m.home[1] + 1.0, 0.0)  # about 1,857 km south
    model = VehicleModel(px4=px4, storage="verbatim" if px4 else "ardupilot", home=far)
    d = great_circle_m(m.home[0], m.home[1], far[0], far[1])
    line = refused(plan, model)
    assert line.startswith(f"Error: the vehicle is at {far[0]:.6f}, {far[1]:.6f}, ")
    shown = float(line.split(", ")[2].split(" m from")[0].replace(",", ""))
    assert shown == pytest.approx(d, rel=1e-3)
    assert line.endswith(f"(limit 200 m): move it there, or confirm with --launch-distance {math.ceil(shown)}")
    assert "(limit 1,853,000 m)" in refused(plan, model, "--launch-distance", "1853000")
    with FakeVehicle(model, "udp") as fv:
        res = run(str(plan), "--connect", fv.url, "--launch-distance", str(math.ceil(shown)))
    assert res.exit_code == 0, res.output
    assert f"launch point: the vehicle is {shown:,.0f} m from the planned launch point" in res.output


def test_a_vehicle_without_a_position_is_refused_unless_the_check_is_off(tmp_path: Path) -> None:
    plan = tmp_path / "survey.plan"
    m = survey_mission(10)
    plan.write_text(dumps_plan(m))
    model = VehicleModel(storage="ardupilot", fix=False)
    assert refused(plan, model).startswith("Error: the vehicle reported no position and no home (no GPS fix?), so it "
                                           "cannot be compared with the planned launch point")
    with FakeVehicle(model, "udp") as fv:
        res = run(str(plan), "--connect", fv.url, "--launch-distance", "off")
    assert res.exit_code == 0, res.output
    assert "launch point: not compared (--launch-distance off)" in res.output


def test_bad_launch_distance_and_a_bare_waypoints_file_are_input_errors(tmp_path: Path) -> None:
    wp = tmp_path / "mission.waypoints"
    wp.write_text(dumps_wpl(survey_mission(4)))
    model = VehicleModel(storage="ardupilot")
    with FakeVehicle(model, "udp") as fv:
        res = run(str(wp), "--connect", fv.url)
        assert res.exit_code == 2
        assert "mission.waypoints does not say which vehicle it is for" in res.output and "--vehicle" in res.output
        res = run(str(wp), "--connect", fv.url, "--launch-distance", "far")
        assert res.exit_code == 2 and "--launch-distance = 'far' is not allowed" in res.output
    assert sent_mission_messages(model) == []


def test_the_vehicle_position_is_asked_for() -> None:
    for fix, expected in ((True, (49.41, 15.02)), (False, None)):
        model = VehicleModel(storage="ardupilot", home=(49.41, 15.02, 400.0), fix=fix)
        with FakeVehicle(model, "udp") as fv, open_link(fv.url, 2.0) as link:
            got = link.vehicle_position(2.0)
        assert got == (pytest.approx(expected[0]), pytest.approx(expected[1])) if expected else got is None
        assert model.log["got REQUEST_MESSAGE"] >= 1
