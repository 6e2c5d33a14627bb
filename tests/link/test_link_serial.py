"""Serial links (`--connect /dev/ttyACM0`): a pseudo-terminal stands for the autopilot's USB port.

pymavlink opens serial devices through pyserial, imported only then; these tests open real
tty devices, so a missing pyserial or a broken serial path fails them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from fake_vehicle import FakeVehicle, VehicleModel, survey_mission

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.link.connection import LinkError, open_link, serial_device
from aerosurvey.mission.formats.qgc_plan import dumps_plan


def run(*args: str):
    return CliRunner().invoke(main, ["upload", *args])


def write_plan(tmp_path: Path) -> Path:
    p = tmp_path / "sortie-01.plan"
    p.write_text(dumps_plan(survey_mission(12, fence=True)))
    return p


def test_upload_over_a_serial_device_uploads_and_verifies(tmp_path: Path) -> None:
    model = VehicleModel()
    with FakeVehicle(model, "pty") as fv:
        assert fv.url.startswith("/dev/") and serial_device(fv.url) == fv.url
        res = run(str(write_plan(tmp_path)), "--connect", fv.url, "--timeout", "0.5")
    assert res.exit_code == 0, res.output
    assert "verified: 18 mission items and 7 fence vertices read back" in res.output
    assert len(model.stored[0]) == 18 and len(model.stored[1]) == 7
    assert model.completed_uploads == 2


def test_serial_device_with_a_baud_rate() -> None:
    with FakeVehicle(VehicleModel(), "pty") as fv, open_link(f"{fv.url},57600", 2.0) as link:
        assert link.vehicle is not None and link.vehicle.system == 1
        assert link.conn.port.baudrate == 57600


def test_which_connection_strings_are_serial_devices() -> None:
    assert serial_device("/dev/ttyUSB0,57600") == "/dev/ttyUSB0"
    assert serial_device("/dev/ttyACM0") == "/dev/ttyACM0"
    assert serial_device("COM3") == "COM3"
    for url in ("tcp:127.0.0.1:5760", "udpin:0.0.0.0:14550", "UDPOUT:10.0.0.1:14550", "127.0.0.1:14550", __file__):
        assert serial_device(url) is None


@pytest.mark.parametrize(("device", "why"), [
    ("/dev/ttyACM_aerosurvey_missing", "no such device (is the autopilot plugged in?"),
    ("/dev/null", "not a serial port ("),
    ("/", "not a serial port (Is a directory)"),
])
def test_missing_or_invalid_serial_device_exits_2_with_one_line_naming_it(tmp_path: Path, device: str, why: str) -> None:
    res = run(str(write_plan(tmp_path)), "--connect", device, "--timeout", "0.2")
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1, res.output
    assert lines[0].startswith(f"Error: --connect '{device}': cannot open the serial device {device}: {why}")
    assert "Traceback" not in res.output


def test_bad_baud_rate_exits_2(tmp_path: Path) -> None:
    res = run(str(write_plan(tmp_path)), "--connect", "/dev/ttyACM_aerosurvey_missing,fast", "--timeout", "0.2")
    assert res.exit_code == 2
    assert "the baud rate after the comma must be a whole number" in res.output


def test_missing_pyserial_is_one_line_naming_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "serial", None)  # `import serial` now raises ImportError
    with pytest.raises(InputError, match=r"--connect '/dev/ttyACM0' names a serial device, and serial devices need pyserial"):
        open_link("/dev/ttyACM0", 0.2)


def test_serial_device_that_is_not_an_autopilot_is_no_heartbeat() -> None:
    master, slave = os.openpty()
    try:
        with pytest.raises(LinkError, match=rf"{os.ttyname(slave)}: no heartbeat from a vehicle within 0.3 s"):
            open_link(os.ttyname(slave), 0.3)
    finally:
        os.close(master)
        os.close(slave)
