"""`campaign ingest`: logs filed under the block whose mission they record (blocks planned with the default
outputs), a "flown" event each, each log read once; a log of no block is reported, nothing filed; a second
ingest of a log adds no event."""

from __future__ import annotations

import json
from pathlib import Path

import campaigncase as cc
import pytest
from click.testing import CliRunner
from tests.flight.dfwriter import mission_log

from aerosurvey.cli import main


def synthetic_log(block: Path, path: Path, shift_deg: float = 0.0, missed: int = 0) -> Path:
    """A DataFlash log of the block's mission (its .waypoints items written as CMD messages) with a
    camera event at each planned station but those of its first `missed` lines, everything moved east
    by `shift_deg`."""
    rows = [ln.split("\t") for ln in (block / "mission.waypoints").read_text().splitlines()[1:]]
    items = [(int(r[3]), int(r[2]), *(float(v) for v in r[4:8]), float(r[8]), float(r[9]) + shift_deg, float(r[10]))
             for r in rows]
    stations = json.loads((block / "manifest.json").read_text())["stations"]
    lines = list(dict.fromkeys(s["line"] for s in stations))[:missed]
    stations = [s for s in stations if s["line"] not in lines]
    events = [(10.0 + i, s["lat"], s["lon"] + shift_deg, 300.0 + s["alt_rel_m"], s["alt_rel_m"]) for i, s in enumerate(stations)]
    path.write_bytes(mission_log([(1.0, items)], events))
    return path


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    out = cc.planned_campaign(tmp_path_factory.mktemp("ingest"), 3)  # the default outputs: no plan.geojson
    assert not list(out.glob("blocks/*/plan.geojson"))
    return out


def test_logs_filed_under_their_blocks(campaign, tmp_path):
    folders = cc.block_folders(campaign)
    log1 = synthetic_log(folders["t01"], tmp_path / "morning.bin")
    log2 = synthetic_log(folders["t02"], tmp_path / "noon.bin")
    res = CliRunner().invoke(main, ["campaign", "ingest", str(campaign), str(log2), str(log1)])
    assert res.exit_code == 0, res.output
    assert "morning.bin: block t01: morning.bin: the whole mission, recognised by its mission" in res.output
    assert "noon.bin: block t02" in res.output
    for name, log in (("t01", "morning.bin"), ("t02", "noon.bin")):
        report = json.loads((campaign / "flights" / name / log / "log_report.json").read_text())
        assert report["plan"]["mission"] == name
        assert report["matched"] == report["planned"] == len(json.loads((folders[name] / "manifest.json").read_text())["stations"])
    rows, events = cc.register(campaign)
    assert {r["name"]: r["status"] for r in rows} == {"t00": "planned", "t01": "flown", "t02": "flown"}
    flown = [e for e in events if e["event"] == "flown"]
    assert sorted(e["block"] for e in flown) == ["t01", "t02"]
    # again: no second event
    res = CliRunner().invoke(main, ["campaign", "ingest", str(campaign), str(log1)])
    assert res.exit_code == 0, res.output
    assert len([e for e in cc.register(campaign)[1] if e["event"] == "flown"]) == 2
    res = CliRunner().invoke(main, ["campaign", "status", str(campaign)])
    assert "2 flown, 1 planned" in res.output and "t01: flown; next: check the flight" in res.output


def test_log_of_no_block_is_not_filed(campaign, tmp_path):
    folders = cc.block_folders(campaign)
    far = synthetic_log(folders["t00"], tmp_path / "far.bin", shift_deg=0.5)  # ~36 km east: nearest is t02, not its mission
    before = cc.register(campaign)
    res = CliRunner().invoke(main, ["campaign", "ingest", str(campaign), str(far)])
    assert res.exit_code == 1, res.output
    assert "far.bin: not filed: its mission is none of the nearest blocks'" in res.output
    assert not (campaign / "flights" / "t02" / "far.bin").exists() and not (campaign / "flights" / "t00" / "far.bin").exists()
    assert cc.register(campaign) == before
    res = CliRunner().invoke(main, ["campaign", "ingest", str(campaign), str(tmp_path / "none.bin")])
    assert res.exit_code == 1 and "none.bin: not filed: flight" in res.output and "does not exist" in res.output


def test_events_recorded_by_hand(campaign):
    def record(*args: str) -> str:
        res = CliRunner().invoke(main, ["campaign", "record", str(campaign), *args])
        return f"{res.exit_code} {res.output}"

    assert record("t00", "uploaded", "--detail", "pilot A").startswith("0 t00: uploaded recorded; status uploaded")
    assert record("t00", "qa", "--detail", "RMSE 2.1 cm").startswith("0 t00: qa recorded; status qa")
    assert record("t00", "accepted").startswith("0 t00: accepted recorded; status accepted")
    assert "event = 'landed' is not allowed: one of uploaded, compliance, re-fly, qa, accepted" in record("t00", "landed")
    assert "block = 'x9' is not in the campaign's register (3 blocks)" in record("x9", "qa")
    rows, events = cc.register(campaign)
    assert {r["name"]: r["status"] for r in rows}["t00"] == "accepted"
    assert [(e["event"], e["detail"]) for e in events if e["block"] == "t00"] == [
        ("planned", ""), ("uploaded", "pilot A"), ("qa", "RMSE 2.1 cm"), ("accepted", "")]
    res = CliRunner().invoke(main, ["campaign", "status", str(campaign)])
    assert "1 accepted" in res.output and "t00:" not in res.output


def test_each_log_read_once(campaign, tmp_path, monkeypatch):
    """Each flight's readers (camera events, modes, mission) run once per flight, and the log file is
    opened once by each of them, however many candidate blocks its mission is compared with."""
    import aerosurvey.flight.dataflash as dataflash
    import aerosurvey.flight.ingest as ingest_module

    folders = cc.block_folders(campaign)
    calls: list[tuple[str, str]] = []

    def counted(name, real):
        def wrapper(path, *args, **kwargs):
            calls.append((name, Path(path).name))
            return real(path, *args, **kwargs)
        return wrapper

    for name in ("read_events", "read_modes", "read_mission"):
        monkeypatch.setattr(ingest_module, name, counted(name, getattr(ingest_module, name)))
    opened: list[str] = []
    real_init = dataflash.DataFlashLog.__init__

    def counting_init(self, path, *args, **kwargs):
        opened.append(Path(path).name)
        real_init(self, path, *args, **kwargs)

    monkeypatch.setattr(dataflash.DataFlashLog, "__init__", counting_init)
    logs = [synthetic_log(folders["t00"], tmp_path / "a.bin"),
            synthetic_log(folders["t02"], tmp_path / "b.bin"),
            synthetic_log(folders["t00"], tmp_path / "c.bin", shift_deg=0.5)]  # far: compared with 3 blocks, filed under none
    res = CliRunner().invoke(main, ["campaign", "ingest", str(campaign), *map(str, logs)])
    assert res.exit_code == 1, res.output
    assert "a.bin: block t00" in res.output and "b.bin: block t02" in res.output and "c.bin: not filed" in res.output
    assert "(t02 (" in res.output.split("c.bin: not filed", 1)[1]  # its mission was compared with the candidates'
    for log in ("a.bin", "b.bin", "c.bin"):
        assert sorted(n for n, f in calls if f == log) == ["read_events", "read_mission", "read_modes"], (log, calls)
        assert opened.count(log) == 3, (log, opened)
