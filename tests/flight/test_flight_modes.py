"""The flight mode at each camera event, from the three kinds of logs: events.csv's `mode` column and
log_report.json's `modes`. The logs are built here (DataFlash, MAVLink telemetry, PX4 ULog) with
the modes' numbers as the firmwares define them (ArduCopter's mode.h, ArduPlane's defines.h,
PX4's VehicleStatus.msg and px4_custom_mode.h), and the truth is what the test put in."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from csvrows import event_rows
from dfwriter import survey_log
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs
from pymavlink.dialects.v20 import ardupilotmega as mavlink
from ulogwriter import camera_status_log

from aerosurvey.cli import main

# ArduCopter: AUTO 3, RTL 6, LOITER 5; ArduPlane: AUTO 10, RTL 11; ModeReason GCS_COMMAND 2, BATTERY_FAILSAFE 4
COPTER_AUTO, COPTER_RTL, COPTER_LOITER, PLANE_AUTO, PLANE_RTL = 3, 6, 5, 10, 11


def _events(n: int) -> list[tuple[float, float, float, float, float]]:
    return [(100.0 + 2.0 * i, 49.4 + 1e-4 * i, 15.0, 400.0, 100.0) for i in range(n)]


def _ingest(tmp_path: Path, log: Path) -> tuple[list[dict[str, str]], dict]:
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    return event_rows(tmp_path / "out" / "events.csv"), json.loads((tmp_path / "out" / "log_report.json").read_text())


@pytest.mark.parametrize("firmware, auto, rtl", [("ArduCopter V4.5.7 (2a3dc4b7)", COPTER_AUTO, COPTER_RTL),
                                                  ("ArduPlane V4.5.7 (2a3dc4b7)", PLANE_AUTO, PLANE_RTL),
                                                  ("APM:Copter V3.3-dev (ae3192b8)", COPTER_AUTO, COPTER_RTL)])
def test_dataflash_modes_are_named_for_the_firmware_that_wrote_the_log(tmp_path, firmware, auto, rtl):
    log = tmp_path / "f.bin"
    # AUTO from 90 s, RTL by a battery failsafe at 121 s: events 0-10 in AUTO, 11-19 in RTL
    log.write_bytes(survey_log(_events(20), [(90.0, auto, 2), (121.0, rtl, 4)], firmware))
    rows, rep = _ingest(tmp_path, log)
    assert [r["mode"] for r in rows] == ["AUTO"] * 11 + ["RTL"] * 9
    m = rep["modes"]
    assert m["source"] == "MODE" and m["firmware"] == ("ArduPlane" if "Plane" in firmware else "ArduCopter")
    assert m["firmware_from"] == "log"
    assert m["events_by_mode"] == {"AUTO": 11, "RTL": 9} and m["events_in_mission_mode"] == 11
    assert [(c["time_s"], c["mode"], c["reason"]) for c in m["changes"]] == [(90.0, "AUTO", "GCS Command"),
                                                                            (121.0, "RTL", "Battery Failsafe")]


def test_an_event_in_the_loop_of_a_mode_change_has_the_new_mode_and_one_before_any_mode_none(tmp_path):
    log = tmp_path / "f.bin"
    log.write_bytes(survey_log(_events(6), [(102.0, COPTER_AUTO, 2), (106.0, COPTER_LOITER, 1), (106.0, COPTER_LOITER, 1)]))
    rows, rep = _ingest(tmp_path, log)
    assert [r["mode"] for r in rows] == ["", "AUTO", "AUTO", "LOITER", "LOITER", "LOITER"]
    assert rep["modes"]["events_without_mode"] == 1 and rep["modes"]["change_count"] == 2  # the repeat is one change


def test_the_plan_names_the_firmware_when_the_log_does_not(tmp_path):
    """A plane plan: mode 10 is ArduPlane's AUTO (ArduCopter has no mode of that number in use)."""
    from conftest import make_spec

    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}, "vehicle": {"type": "plane", "cruise_speed_ms": 16.0}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    st = json.loads((plan / "manifest.json").read_text())["stations"][:10]
    log = tmp_path / "f.bin"
    log.write_bytes(survey_log([(100.0 + i, s["lat"], s["lon"], 400.0, s["alt_rel_m"]) for i, s in enumerate(st)],
                               [(50.0, PLANE_AUTO, 2), (105.5, PLANE_RTL, 2)], firmware=None))
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert [r["mode"] for r in event_rows(tmp_path / "out" / "events.csv")] == ["AUTO"] * 6 + ["RTL"] * 4
    rep = json.loads((tmp_path / "out" / "log_report.json").read_text())
    assert rep["modes"]["firmware"] == "ArduPlane" and rep["modes"]["firmware_from"] == "plan"
    # without the plan, a mode number means nothing: the column is empty and the report says why
    rows, rep = _ingest(tmp_path, log)
    assert {r["mode"] for r in rows} == {""} and rep["modes"]["events_by_mode"] == {}
    assert "does not name its firmware" in rep["modes"]["note"]


def test_a_log_without_modes_leaves_the_column_empty_and_says_so(tmp_path):
    from dfwriter import camera_log

    log = tmp_path / "f.bin"
    log.write_bytes(camera_log(_events(5)))
    rows, rep = _ingest(tmp_path, log)
    assert {r["mode"] for r in rows} == {""}
    assert rep["modes"]["source"] is None and rep["modes"]["events_without_mode"] == 5
    assert rep["modes"]["note"] == "the log records no flight modes (no MODE messages)"
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "-o", str(tmp_path / "again")])
    assert "flight modes: none known (the log records no flight modes (no MODE messages)); events.csv's mode is empty" \
        in res.output


def _tlog(path: Path, packets: list[tuple[int, int, object]]) -> None:
    """(system, component, message) records with a time stamp each, as a ground station writes them."""
    out = bytearray()
    for k, (system, component, msg) in enumerate(packets):
        mav = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
        out += struct.pack(">Q", 1_700_000_000_000_000 + k * 100_000) + msg.pack(mav)  # type: ignore[attr-defined]
    path.write_bytes(bytes(out))


def _feedback(i: int) -> object:
    return mavlink.MAVLink_camera_feedback_message(1_700_000_000_000_000 + i * 2_000_000, 1, 0, i, 494000000 + i * 1000,
                                                   150000000, 420.0, 100.0, 0.0, 0.0, 90.0, 16.0, 0, i)


def _heartbeat(kind: int, autopilot: int, custom: int) -> object:
    return mavlink.MAVLink_heartbeat_message(kind, autopilot, 0, custom, 4, 3)


def test_tlog_modes_from_the_autopilots_heartbeats(tmp_path):
    """An ArduCopter quad (MAV_TYPE 2, MAV_AUTOPILOT_ARDUPILOTMEGA 3) in AUTO, then RTL; a ground
    station's heartbeats (MAV_TYPE_GCS 6, MAV_AUTOPILOT_INVALID 8) and a camera's (component 100)
    between them are not the vehicle's."""
    gcs, camera = _heartbeat(6, 8, 0), _heartbeat(30, 3, 99)
    packets = [(1, 1, _heartbeat(2, 3, COPTER_AUTO)), (255, 190, gcs)]
    packets += [(1, 1, _feedback(i)) for i in range(4)]
    packets += [(1, 100, camera), (1, 1, _heartbeat(2, 3, COPTER_RTL)), (255, 190, gcs)]
    packets += [(1, 1, _feedback(i)) for i in range(4, 7)]
    log = tmp_path / "f.tlog"
    _tlog(log, packets)
    rows, rep = _ingest(tmp_path, log)
    assert [r["mode"] for r in rows] == ["AUTO"] * 4 + ["RTL"] * 3
    assert rep["modes"]["source"] == "HEARTBEAT" and rep["modes"]["firmware"] == "ArduCopter"


def test_tlog_of_px4_names_its_modes_as_the_ulog_does(tmp_path):
    """PX4 (MAV_AUTOPILOT_PX4 12): custom_mode's main mode AUTO (4) and sub-mode MISSION (4), then RTL (5)."""
    packets = [(1, 1, _heartbeat(2, 12, (4 << 16) | (4 << 24)))] + [(1, 1, _feedback(i)) for i in range(2)]
    packets += [(1, 1, _heartbeat(2, 12, (4 << 16) | (5 << 24)))] + [(1, 1, _feedback(i)) for i in range(2, 3)]
    log = tmp_path / "f.tlog"
    _tlog(log, packets)
    rows, rep = _ingest(tmp_path, log)
    assert [r["mode"] for r in rows] == ["AUTO_MISSION", "AUTO_MISSION", "AUTO_RTL"]
    assert rep["modes"]["events_in_mission_mode"] == 2


def test_ulog_modes_from_vehicle_status(tmp_path):
    """nav_state AUTO_MISSION (3), AUTO_LOITER (4), AUTO_MISSION, AUTO_RTL (5), sampled as PX4
    publishes vehicle_status (at each change and about once a second)."""
    captures = [(10.0 + 2 * i, 49.4 + 1e-4 * i, 15.0, 400.0) for i in range(8)]
    states = [(1.0, 3), (5.0, 3), (13.0, 4), (14.0, 4), (17.0, 3), (24.5, 5), (25.5, 5)]
    log = tmp_path / "f.ulg"
    log.write_bytes(camera_status_log(captures, states))
    rows, rep = _ingest(tmp_path, log)
    # captures at 10, 12 | 14, 16 | 18, 20, 22, 24 | (24.5: RTL)
    assert [r["mode"] for r in rows] == ["AUTO_MISSION"] * 2 + ["AUTO_LOITER"] * 2 + ["AUTO_MISSION"] * 4
    assert rep["modes"]["change_count"] == 4 and rep["modes"]["firmware"] == "PX4"


@pytest.mark.parametrize("name, auto", [("sitl_copter_survey.bin", COPTER_AUTO), ("sitl_plane_kubad.bin", PLANE_AUTO)])
def test_the_sitl_logs_modes_are_those_pymavlink_reads(tmp_path, name, auto):
    """The committed SITL logs (ArduPilot 4.7's layouts): each camera event's mode is the last MODE
    message at or before it, as pymavlink reads them; every photo of these flights is in AUTO."""
    from pymavlink import mavutil

    log = Path(__file__).resolve().parents[1] / "data" / name
    reader = mavutil.mavlink_connection(str(log))
    modes, cams = [], []
    while (m := reader.recv_match(type=["MODE", "CAM"])) is not None:
        (modes if m.get_type() == "MODE" else cams).append(m)
    want = []
    for cam in cams:
        before = [m for m in modes if m.TimeUS <= cam.TimeUS]
        want.append("AUTO" if before and before[-1].ModeNum == auto else "other")
    rows, rep = _ingest(tmp_path, log)
    assert [r["mode"] for r in rows] == want == ["AUTO"] * len(cams)
    assert rep["modes"]["events_in_mission_mode"] == len(cams)


def _mode_truth(data: bytes, path: Path) -> list[tuple[int, float, int]]:
    """(end offset, time s, mode number) of each MODE message, as pymavlink's DFReader reads the intact log."""
    from pymavlink import DFReader

    path.write_bytes(data)
    r = DFReader.DFReader_binary(str(path))
    out = []
    while (m := r.recv_match(type="MODE")) is not None:
        out.append((r.offset, m.TimeUS / 1e6, m.ModeNum))
    return out


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=hs.sampled_from(["cut", "flips", "junk"]), where=hs.floats(0.0, 1.0), seed=hs.integers(0, 2**16))
def test_damaged_logs_keep_the_modes_before_the_damage(tmp_path, kind, where, seed):
    """A log cut off, with bytes flipped or junk inserted from some place on: reading its modes raises
    nothing, and every MODE message wholly before the damage comes back as logged."""
    from aerosurvey.flight.modes import from_dataflash

    changes = [(90.0 + 10 * k, (COPTER_AUTO, COPTER_RTL, COPTER_LOITER)[k % 3], 2) for k in range(12)]
    data = survey_log(_events(60), changes)
    truth = _mode_truth(data, tmp_path / "intact.bin")
    rng = np.random.default_rng(seed)
    at = int(where * (len(data) - 1))
    if kind == "cut":
        damaged = data[:at]
    elif kind == "flips":
        b = bytearray(data)
        for i in rng.integers(at, len(data), 8):
            b[int(i)] ^= 1 << int(rng.integers(8))
        damaged = bytes(b)
    else:
        damaged = data[:at] + rng.bytes(int(rng.integers(1, 200))) + data[at:]
    path = tmp_path / "damaged.bin"
    path.write_bytes(damaged)
    modes = from_dataflash(path)
    names = {COPTER_AUTO: "AUTO", COPTER_RTL: "RTL", COPTER_LOITER: "LOITER"}
    before = [(t, names[number]) for end, t, number in truth if end <= at]
    assert modes.at(np.array([t for t, _ in before])) == [name for _, name in before], (kind, at)
