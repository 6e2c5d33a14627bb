"""DataFlash reading: the real SITL log, agreement with pymavlink, damaged logs."""

from __future__ import annotations

import collections
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink import DFReader

from aerosurvey.flight.dataflash import DataFlashLog

LOG = Path(__file__).resolve().parents[1] / "data" / "sitl_copter_survey.bin"


def _pymavlink_counts(path: Path) -> collections.Counter[str]:
    r = DFReader.DFReader_binary(str(path))
    c: collections.Counter[str] = collections.Counter()
    while (m := r.recv_msg()) is not None:
        c[m.get_type()] += 1
    return c


def test_real_sitl_log_events() -> None:
    with DataFlashLog(LOG) as log:
        cam = log.messages("CAM")
        assert len(cam["Lat"]) == 152
        assert log.skipped_bytes == 0
        # first and last camera event of the flight (degrees, metres above home)
        assert cam["Lat"][0] == pytest.approx(49.3997437, abs=1e-7) and cam["Lng"][0] == pytest.approx(15.005891, abs=1e-7)
        assert 100.0 < float(cam["RelAlt"][-1]) < 104.0
        assert np.all(np.diff(cam["TimeUS"].astype(np.int64)) > 0)
        gps = log.messages("GPS")
        assert len(gps["Lat"]) > 100 and gps["Lat"].min() > 49.39


def test_counts_agree_with_pymavlink() -> None:
    with DataFlashLog(LOG) as log:
        ours = log.counts()
    theirs = _pymavlink_counts(LOG)
    for name, n in theirs.items():
        assert ours.get(name) == n, name


def test_values_agree_with_pymavlink() -> None:
    r = DFReader.DFReader_binary(str(LOG))
    cams = []
    while (m := r.recv_match(type="CAM")) is not None:
        cams.append((m.TimeUS, m.Lat, m.Lng, m.Alt))
    with DataFlashLog(LOG) as log:
        cam = log.messages("CAM")
    assert len(cams) == len(cam["TimeUS"])
    for i, (t, lat, lng, alt) in enumerate(cams):
        assert int(cam["TimeUS"][i]) == t
        assert cam["Lat"][i] == pytest.approx(lat, abs=1e-9) and cam["Lng"][i] == pytest.approx(lng, abs=1e-9)
        assert float(cam["Alt"][i]) == pytest.approx(alt, abs=1e-4)


def _cam_times_before(data: bytes, limit: int) -> int:
    """CAM events wholly before byte `limit` in the intact log."""
    with DataFlashLog(LOG) as log:
        t = log.type_of("CAM")
        assert t is not None
        offs = np.frombuffer(log.offsets[t.type], dtype=np.uint64)
        return int(np.sum(offs + t.length <= limit))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.integers(1, LOG.stat().st_size - 1))
def test_truncated_log_keeps_everything_before_the_cut(tmp_path_factory: pytest.TempPathFactory, cut: int) -> None:
    data = LOG.read_bytes()
    p = tmp_path_factory.mktemp("cut") / "cut.bin"
    p.write_bytes(data[:cut])
    with DataFlashLog(p) as log:
        cam = log.messages("CAM")
        assert len(cam.get("Lat", [])) == _cam_times_before(data, cut)
        assert log.skipped_bytes < 200  # at most the half-written last message


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.integers(4000, LOG.stat().st_size - 1), min_size=1, max_size=20), st.integers(0, 255))
def test_corrupted_bytes_never_crash_and_keep_the_events_before(tmp_path_factory: pytest.TempPathFactory, positions: list[int],
                                                                 value: int) -> None:
    data = bytearray(LOG.read_bytes())
    for p in positions:
        data[p] = value if data[p] != value else (value + 1) % 256
    path = tmp_path_factory.mktemp("flip") / "flip.bin"
    path.write_bytes(bytes(data))
    with DataFlashLog(path) as log:
        cam = log.messages("CAM")
        first_damage = min(positions)
        assert len(cam.get("Lat", [])) >= _cam_times_before(bytes(data), first_damage) - 0
        for s in log.skipped:
            assert 0 <= s.offset < len(data) and s.length > 0


def test_empty_and_garbage_files(tmp_path: Path) -> None:
    (tmp_path / "empty.bin").write_bytes(b"")
    with DataFlashLog(tmp_path / "empty.bin") as log:
        assert log.counts() == {} and log.messages("CAM") == {}
    (tmp_path / "junk.bin").write_bytes(bytes(range(256)) * 40)
    with DataFlashLog(tmp_path / "junk.bin") as log:
        assert log.counts() == {} and log.skipped_bytes == 256 * 40
