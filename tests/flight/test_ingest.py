"""`aerosurvey log ingest`: the real SITL log against the plan it flew."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner
from csvrows import event_rows

from aerosurvey.cli import main
from conftest import make_spec

LOG = Path(__file__).resolve().parents[1] / "data" / "sitl_copter_survey.bin"


def _plan(tmp: Path) -> Path:
    # the plan the committed log flew (tests/data/README.md)
    spec = make_spec(tmp, {"flight": {"heading": 0.0}})
    out = tmp / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)]).exit_code == 0
    return out


def test_every_event_matches_its_station(tmp_path):
    plan = _plan(tmp_path)
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "--plan", str(plan), "-o", str(tmp_path / "log")])
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "log" / "log_report.json").read_text())
    assert rep["events"] == rep["planned"] == rep["matched"] == 152
    assert rep["missed_stations"] == [] and rep["extra_triggers"] == [] and rep["max_distance_m"] < 1.5
    # the flown photos cover the area as planned: 4 forward x 2 side on every cell
    assert rep["coverage"]["min_images_in_area"] >= 8 and rep["coverage"]["uncovered_share"] == 0.0
    assert (tmp_path / "log" / "coverage.tif").exists()
    rz = rep["realized"]
    assert rz["forward_overlap_min"] >= 0.74 and rz["side_overlap_min"] >= 0.59
    assert 2.4 < rz["gsd_cm_min"] <= rz["gsd_cm_max"] < 2.6
    rows = event_rows(tmp_path / "log" / "events.csv")
    manifest = json.loads((plan / "manifest.json").read_text())
    assert [r["station"] for r in rows] == [s["id"] for s in manifest["stations"]]


def test_truncated_log_reports_the_missed_stations(tmp_path):
    plan = _plan(tmp_path)
    data = LOG.read_bytes()
    cut = tmp_path / "cut.bin"
    cut.write_bytes(data[: len(data) // 2])
    res = CliRunner().invoke(main, ["log", "ingest", str(cut), "--plan", str(plan), "-o", str(tmp_path / "log")])
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "log" / "log_report.json").read_text())
    assert 0 < rep["events"] < 152
    assert len(rep["missed_stations"]) == 152 - rep["matched"]
    assert rep["read"]["skipped_bytes"] < 200


def test_log_without_camera_events_is_bad_input(tmp_path):
    (tmp_path / "x.bin").write_bytes(b"\x00" * 1000)
    res = CliRunner().invoke(main, ["log", "ingest", str(tmp_path / "x.bin"), "-o", str(tmp_path / "o")])
    assert res.exit_code == 2 and "no CAM or TRIG camera events" in res.output
    assert not (tmp_path / "o").exists()


def test_rules_rerun_on_flown_data(tmp_path):
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}, "rules": {"profiles": ["eu-open"]},
                                "targets": {"forward_overlap": 0.75, "side_overlap": 0.6}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "--plan", str(plan), "-o", str(tmp_path / "log")])
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "log" / "log_report.json").read_text())
    (rule,) = rep["rules_on_flown_data"]
    assert rule["rule"] == "eu-open-height" and rule["status"] == "pass" and rule["measured"].startswith("102.1 m")


PLANE_LOG = Path(__file__).resolve().parents[1] / "data" / "sitl_plane_kubad.bin"
#: the plan that flight flew (manifest.json and plan.geojson): the example as planned before the
#: stations were laid in ArduPilot's metres, so not what `aerosurvey plan` makes of it now
PLANE_PLAN = Path(__file__).resolve().parents[1] / "data" / "sitl_plane_kubad_plan"


def test_plane_example_flown_in_sitl(tmp_path):
    """The Kubad Abad example mission as ArduPlane SITL flew it (tests/data/README.md)."""
    plan = PLANE_PLAN
    res = CliRunner().invoke(main, ["log", "ingest", str(PLANE_LOG), "--plan", str(plan), "-o", str(tmp_path / "log")])
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "log" / "log_report.json").read_text())
    assert rep["events"] == rep["planned"] == rep["matched"] == 683
    assert rep["missed_stations"] == [] and rep["extra_triggers"] == [] and rep["read"]["skipped_bytes"] == 0
    # every trigger within the default tolerance (a quarter base) of its station: the lead-in works
    assert rep["max_distance_m"] < 5.5 and rep["far_triggers"] == []
    rows = event_rows(tmp_path / "log" / "events.csv")
    first, last = rows[0], rows[-1]
    assert (first["station"], last["station"]) == ("P1-L001-S0001", "P1-L013-S0052")
    assert (float(first["lat"]), float(first["lon"]), float(first["alt_m"])) == (37.77154, 31.548007, 158.62)
    assert (float(last["lat"]), float(last["lon"]), float(last["alt_m"])) == (37.7804783, 31.5631346, 158.82)
    manifest = json.loads((plan / "manifest.json").read_text())
    assert [r["station"] for r in rows] == [s["id"] for s in manifest["stations"]]
    assert rep["coverage"]["uncovered_share"] == 0.0 and rep["realized"]["forward_overlap_min"] >= 0.79


def test_a_log_that_lost_more_than_its_share_fails_with_the_counts(tmp_path):
    # 5 % of the log overwritten by zeros in the middle: the bytes are lost, outputs still written, exit 1
    data = bytearray(LOG.read_bytes())
    a = len(data) // 2
    data[a:a + len(data) // 20] = bytes(len(data) // 20)
    bad = tmp_path / "zeros.bin"
    bad.write_bytes(bytes(data))
    res = CliRunner().invoke(main, ["log", "ingest", str(bad), "-o", str(tmp_path / "log")])
    assert res.exit_code == 1, res.output
    rep = json.loads((tmp_path / "log" / "log_report.json").read_text())
    lost = rep["read"]["lost_bytes"]
    assert lost >= len(data) // 25 and f"{lost} of {len(data)} bytes skipped as damage" in res.output
    assert f"{rep['events']} camera events (CAM)" in res.output


def test_a_copied_chunk_loses_nothing_and_passes(tmp_path):
    # a tenth of the log copied again before itself: every event once, nothing lost, exit 0
    data = LOG.read_bytes()
    a, b = len(data) // 2, len(data) // 2 + len(data) // 10
    dup = tmp_path / "dup.bin"
    dup.write_bytes(data[:a // 2] + data[a:b] + data[a // 2:])
    res = CliRunner().invoke(main, ["log", "ingest", str(dup), "-o", str(tmp_path / "log")])
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "log" / "log_report.json").read_text())
    assert rep["events"] == 152 and rep["read"]["implausible_events"] == 0
    kinds = [s["kind"] for s in rep["read"]["skipped"]]
    assert kinds.count("repeat") == 1 and set(kinds) <= {"repeat", "damage"}  # the splices cut a message each
    assert rep["read"]["lost_bytes"] < 0.01 * rep["read"]["bytes"]
