"""`aerosurvey upload` end to end: exit codes, what it prints, and that a failure never says "uploaded"."""

from __future__ import annotations

import io
import socket
from pathlib import Path

from click.testing import CliRunner
from fake_vehicle import FakeVehicle, Faults, SimLink, VehicleModel, survey_mission

from aerosurvey.cli import main
from aerosurvey.commands.upload import TransferProgress
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.upload import upload_mission
from aerosurvey.mission.formats.qgc_plan import dumps_plan
from aerosurvey.mission.formats.wpl import dumps_wpl


def run(*args: str):
    return CliRunner().invoke(main, ["upload", *args])


def write_plan(tmp_path: Path, fence: bool = False, n: int = 12) -> Path:
    p = tmp_path / "sortie-01.plan"
    p.write_text(dumps_plan(survey_mission(n, fence=fence)))
    return p


def test_upload_plan_with_fence_prints_what_was_uploaded_and_verified(tmp_path: Path) -> None:
    plan = write_plan(tmp_path, fence=True)
    model = VehicleModel()
    with FakeVehicle(model, "tcp") as fv:
        res = run(str(plan), "--connect", fv.url, "--timeout", "0.5")
    assert res.exit_code == 0, res.output
    assert "mission: 18 items uploaded" in res.output
    assert "fence: 7 vertices uploaded" in res.output
    assert "verified: 18 mission items and 7 fence vertices read back" in res.output
    assert len(model.stored[0]) == 18 and len(model.stored[1]) == 7


def test_upload_waypoints_file_without_verify(tmp_path: Path) -> None:
    wp = tmp_path / "mission.waypoints"
    wp.write_text(dumps_wpl(survey_mission(6)))
    model = VehicleModel()
    with FakeVehicle(model, "udp") as fv:
        res = run(str(wp), "--connect", fv.url, "--timeout", "0.5", "--no-verify", "--vehicle", "copter")
    assert res.exit_code == 0, res.output
    assert "not verified (--no-verify)" in res.output
    assert "fence: none in the plan" in res.output
    assert "got MISSION_REQUEST_LIST" not in model.log
    assert len(model.stored[0]) == 12


def test_mismatch_exits_1_naming_item_field_and_values(tmp_path: Path) -> None:
    plan = write_plan(tmp_path)
    with FakeVehicle(VehicleModel(alter={4: {"param2": 3.0}}), "udp") as fv:
        res = run(str(plan), "--connect", fv.url, "--timeout", "0.5")
    assert res.exit_code == 1
    assert "Error: verification failed: mission item 4 (NAV_WAYPOINT) param2: planned 0, vehicle has 3" in res.output
    assert "verified:" not in res.output and "items uploaded" not in res.output


def test_connection_refused_exits_1_with_one_line(tmp_path: Path) -> None:
    plan = write_plan(tmp_path)
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    res = run(str(plan), "--connect", f"tcp:127.0.0.1:{port}", "--timeout", "0.5")
    assert res.exit_code == 1
    assert res.output.strip().splitlines() == [
        f"Error: tcp:127.0.0.1:{port}: connection refused (nothing listens there: is the vehicle or SITL running?)"]


def test_silent_vehicle_exits_1_and_reports_nothing_uploaded(tmp_path: Path) -> None:
    plan = write_plan(tmp_path)
    with FakeVehicle(VehicleModel(answer_missions=False), "udp") as fv:
        res = run(str(plan), "--connect", fv.url, "--timeout", "0.1", "--retries", "1")
    assert res.exit_code == 1
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: mission upload failed: no answer to MISSION_COUNT")
    assert "do not fly it" in lines[0]


def test_unreadable_or_bad_plan_exits_2(tmp_path: Path) -> None:
    res = run(str(tmp_path / "missing.plan"), "--connect", "tcp:127.0.0.1:1")
    assert res.exit_code == 2 and "cannot read the plan" in res.output
    bad = tmp_path / "bad.plan"
    bad.write_text("{not json")
    res = run(str(bad), "--connect", "tcp:127.0.0.1:1")
    assert res.exit_code == 2 and "not a QGroundControl plan" in res.output
    res = run(str(write_plan(tmp_path)), "--connect", "tcp:127.0.0.1", "--timeout", "0.2")
    assert res.exit_code == 2 and "--connect 'tcp:127.0.0.1'" in res.output
    res = run(str(write_plan(tmp_path)), "--connect", "tcp:127.0.0.1:1", "--timeout", "0")
    assert res.exit_code == 2


def test_no_heartbeat_exits_1_after_timeout_times_retries_plus_one(tmp_path: Path) -> None:
    plan = write_plan(tmp_path)
    with FakeVehicle(VehicleModel(), "udp", heartbeats=False) as fv:
        res = run(str(plan), "--connect", fv.url, "--timeout", "0.1", "--retries", "2")
    assert res.exit_code == 1
    assert res.output.strip().splitlines() == [
        f"Error: {fv.url}: no heartbeat from a vehicle within 0.3 s (is it powered and is this the right connection string?)"]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


class _Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_progress_shows_on_a_terminal_only_after_a_second() -> None:
    term, clock = _Terminal(), _Clock()
    with TransferProgress(term, clock=clock) as progress:
        clock.t = 0.9
        progress("mission upload", 10, 701)
        assert term.getvalue() == ""
        clock.t = 1.1
        progress("mission upload", 20, 701)
        progress("mission download", 0, 0)  # the count is not known yet
        progress("mission download", 300, 701)
    shown = term.getvalue()
    assert "mission upload" in shown and "mission download" in shown and "300/701" in shown


def test_progress_is_silent_when_stderr_is_not_a_terminal() -> None:
    pipe, clock = io.StringIO(), _Clock()
    with TransferProgress(pipe, clock=clock) as progress:
        clock.t = 5.0
        progress("mission upload", 20, 701)
    assert pipe.getvalue() == ""


def test_upload_reports_progress_of_each_transfer_to_the_callback() -> None:
    calls: list[tuple[str, int, int]] = []
    m = survey_mission(20, fence=True)
    upload_mission(SimLink(VehicleModel(), Faults(drop=0.1, seed=3)), m, mp.Policy(timeout=0.1),
                   progress=lambda what, done, total: calls.append((what, done, total)))
    finals = {what: (done, total) for what, done, total in calls}
    n = len(m.items) + 1
    assert finals == {"mission upload": (n, n), "fence upload": (7, 7), "mission download": (n, n), "fence download": (7, 7)}
    ups = [done for what, done, _ in calls if what == "mission upload"]
    assert ups == sorted(ups) and len(set(ups)) > 2  # it moves forward while the transfer runs


def test_a_long_failing_upload_in_a_pipe_prints_only_the_error(tmp_path: Path) -> None:
    plan = write_plan(tmp_path)
    with FakeVehicle(VehicleModel(answer_missions=False), "udp") as fv:
        res = CliRunner().invoke(main, ["upload", str(plan), "--connect", fv.url, "--timeout", "0.3",
                                                        "--retries", "4"])
    assert res.exit_code == 1
    assert res.stdout == ""
    assert res.stderr.splitlines() == [res.stderr.strip()]  # 1.5 s of silence: still only the error line
    assert res.stderr.startswith("Error: mission upload failed: no answer to MISSION_COUNT for 1.6 s (5 resend(s) in all)")
