"""`aerosurvey upload` reads a plan's rally points (one per launch site): without --rally it says
after uploading the mission that they were not sent (they are not dropped silently); with
--rally it uploads them as MAV_MISSION_TYPE_RALLY and verifies them."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from click.testing import CliRunner
from fake_vehicle import FakeVehicle, VehicleModel

from aerosurvey.cli import main
from aerosurvey.mission.formats.qgc_plan import loads_plan

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from conftest import make_spec  # noqa: E402


def test_rally_points_are_read_and_named_after_the_upload(tmp_path: Path) -> None:
    spec = make_spec(tmp_path, {"battery": {"usable_min": 10.0, "reserve": 0.25}})
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(tmp_path / "out")]).exit_code == 0
    sortie = tmp_path / "out" / "sortie-01.plan"
    m = loads_plan(sortie.read_text(), str(sortie))
    assert len(m.rally) == len(json.loads(sortie.read_text())["rallyPoints"]["points"]) >= 1
    with FakeVehicle(VehicleModel(storage="ardupilot", home=m.home), "udp") as fv:
        res = CliRunner().invoke(main, ["upload", str(sortie), "--connect", fv.url])
    assert res.exit_code == 0, res.output
    assert res.output.strip().splitlines()[-1].startswith(f"note: the plan's {len(m.rally)} rally point(s) were not uploaded")

    model = VehicleModel(storage="ardupilot", home=m.home)
    with FakeVehicle(model, "udp") as fv:
        res = CliRunner().invoke(main, ["upload", str(sortie), "--connect", fv.url, "--rally"])
    assert res.exit_code == 0, res.output
    assert f"rally: {len(m.rally)} points uploaded" in res.output and "note:" not in res.output
    assert [(s.x, s.y) for s in model.stored[2]] == [(round(lat * 1e7), round(lon * 1e7)) for lat, lon, _ in m.rally]
    assert [s.z for s in model.stored[2]] == [float(int(alt)) for _, _, alt in m.rally]  # ArduPilot: whole metres
