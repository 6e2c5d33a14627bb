"""MAVLink telemetry logs and PX4 ULogs."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from aerosurvey.errors import InputError
from aerosurvey.flight.events import read_events

DATA = Path(__file__).resolve().parents[1] / "data"


def _tlog(path: Path, n: int, junk_at: int | None = None) -> None:
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    for i in range(n):
        msg = mav.camera_feedback_encode(1_700_000_000_000_000 + i * 2_000_000, 1, 0, i, 494000000 + i * 1000,
                                         150000000, 420.0 + i, 100.0, 1.0, -2.0, 90.0, 16.0, i, 1)
        out += struct.pack(">Q", 1_700_000_000_000_000 + i * 2_000_000) + msg.pack(mav)
        if junk_at is not None and i == junk_at:
            out += b"\x01\x02\x03garbage\xfe\xfd"
    path.write_bytes(bytes(out))


def test_tlog_camera_feedback(tmp_path):
    _tlog(tmp_path / "f.tlog", 20)
    ev, info = read_events(tmp_path / "f.tlog")
    assert len(ev) == 20 and ev.source == "CAMERA_FEEDBACK"
    assert ev.lat[3] == pytest.approx(49.4003, abs=1e-7) and ev.alt_m[19] == pytest.approx(439.0)
    assert ev.yaw[0] == pytest.approx(90.0)


def test_tlog_with_garbage_keeps_the_events(tmp_path):
    _tlog(tmp_path / "g.tlog", 20, junk_at=7)
    ev, info = read_events(tmp_path / "g.tlog")
    assert len(ev) == 20 and info["skipped_bytes"] == len(b"\x01\x02\x03garbage\xfe\xfd")


def test_public_px4_ulog_without_camera_events():
    with pytest.raises(InputError, match="no camera_capture topic"):
        read_events(DATA / "px4_sample_events.ulg")


def test_unknown_log_type(tmp_path):
    (tmp_path / "x.csv").write_text("a")
    with pytest.raises(InputError, match="unknown log type"):
        read_events(tmp_path / "x.csv")
