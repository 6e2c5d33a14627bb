"""The flight knows its mission: the mission a log records (DataFlash CMD, a telemetry log's
mission transfers, a ULog's navigator_mission_item), read back and compared with the plan's.

The logs' missions are checked against pymavlink's DataFlash reader; the synthetic logs carry
the items of the plan's .waypoints files (QGroundControl's WPL text, parsed here) and the
expected differences are worked out here from the edits made, distances by pyproj's Geod.
"""

from __future__ import annotations

import json
import math
import shutil
import struct
from pathlib import Path

import numpy as np
import pyproj
import pytest
from click.testing import CliRunner
from dfwriter import mission_log
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink import DFReader
from ulogwriter import ulog

from aerosurvey.cli import main
from aerosurvey.flight import mission_flown as mfl
from aerosurvey.flight.mission_log import read_mission
from aerosurvey.link import mission_protocol as mp
from conftest import REPO, make_spec

DATA = Path(__file__).resolve().parents[1] / "data"
PLANE_LOG = DATA / "sitl_plane_kubad.bin"
PLANE_PLAN = DATA / "sitl_plane_kubad_plan"  # the plan that flight flew (tests/data/README.md)
COPTER_LOG = DATA / "sitl_copter_survey.bin"
GEOD = pyproj.Geod(ellps="WGS84")


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


def _report(folder: Path) -> dict:
    return json.loads((folder / "log_report.json").read_text())


def _waypoints(path: Path, logged: bool = True) -> list[tuple[int, int, float, float, float, float, float, float, float]]:
    """A QGroundControl WPL file's items (home first): command, frame, param1-4, x, y, z; `logged`:
    as ArduPilot's CMD messages log them, an item without a position (frame 2) with frame 0 (as
    in the SITL logs of tests/data; the copter items aerosurvey writes keep their other fields)."""
    lines = path.read_text().splitlines()
    assert lines[0].startswith("QGC WPL")
    out = []
    for line in lines[1:]:
        f = line.split("\t")
        frame = int(f[2])
        out.append((int(f[3]), 0 if logged and frame == 2 else frame, *(float(v) for v in f[4:11])))
    return out


def _plan_survey_waypoints(plan_file: Path) -> list[tuple[float, float]]:
    """(lat, lon) of a .plan file's items tagged with a line, run or station id (P1-L003…)."""
    doc = json.loads(plan_file.read_text())
    items = []
    for it in doc["mission"]["items"]:
        items += it["TransectStyleComplexItem"]["Items"] if it["type"] == "ComplexItem" else [it]
    return [(it["params"][4], it["params"][5]) for it in items
            if it["command"] == 16 and it.get("aerosurveyTag", "").startswith("P1-L")]


def _dataflash_cmds(path: Path) -> list[tuple[int, int, int, float, float, float, float, float, float, float]]:
    """The CMD messages of a DataFlash log, read by pymavlink: CNum, CId, Frame, Prm1-4, Lat, Lng, Alt."""
    log = DFReader.DFReader_binary(str(path))
    out = []
    while (m := log.recv_match(type="CMD")) is not None:
        out.append((m.CNum, m.CId, getattr(m, "Frame", -1), m.Prm1, m.Prm2, m.Prm3, m.Prm4, m.Lat, m.Lng, m.Alt))
    return out


@pytest.mark.parametrize("log", [PLANE_LOG, COPTER_LOG, DATA / "dronekit_la_log171.bin"], ids=lambda p: p.stem)
def test_the_mission_read_back_from_each_dataflash_log_is_the_one_pymavlink_reads(log):
    record = read_mission(log)
    cmds = _dataflash_cmds(log)
    assert record.source == "CMD" and record.autopilot == "ardupilot" and record.later == () and record.superseded == 0
    items = record.flown.items
    assert len(items) == len(cmds) and record.flown.complete
    for it, (num, cid, frame, p1, p2, p3, p4, lat, lng, alt) in zip(items, cmds):
        assert (it.seq, it.command, it.frame) == (num, cid, frame)
        assert [it.param1, it.param2, it.param3, it.param4] == pytest.approx([p1, p2, p3, p4], abs=1e-6)
        assert (it.x * 1e-7, it.y * 1e-7) == pytest.approx((lat, lng), abs=1.1e-7)
        assert it.z == pytest.approx(alt, abs=1e-4)
    # the SITL logs hold their whole missions (home and 70 / 43 items); the ArduCopter 3.3 log of real
    # hardware only the home it logged (CTot 0, an old layout with float Lat/Lng and no Frame)
    assert len(items) == {"sitl_plane_kubad": 71, "sitl_copter_survey": 44, "dronekit_la_log171": 1}[log.stem]


def test_the_sitl_plane_log_against_todays_kubad_plan_is_another_mission(tmp_path):
    """The Kubad flight was flown against an earlier version of the example (683 photos; today's
    plan has 664): the vehicle's waypoints are not the plan's, `log ingest` and `check` say so, exit 1."""
    plan = tmp_path / "plan"
    assert _run("plan", REPO / "missions" / "kubad-abad-fixed-wing.toml", "-o", plan)[0] == 0
    folder = tmp_path / "log"
    code, out = _run("log", "ingest", PLANE_LOG, "--plan", plan, "-o", folder)
    assert code == 1, out
    m = _report(folder)["mission"]
    # independently: none of the plan's survey waypoints has a logged waypoint within 2 m, the nearest
    # lie 12-27 m off
    wps = _plan_survey_waypoints(plan / "sortie-01.plan")
    logged = [(c[7], c[8]) for c in _dataflash_cmds(PLANE_LOG) if c[1] == 16]
    near = [min(GEOD.inv(lon, lat, b, a)[2] for a, b in logged) for lat, lon in wps]
    assert len(wps) == m["survey_waypoints"] == 39 and sum(d <= 2.0 for d in near) == m["survey_waypoints_found"] == 0
    assert m["offset_median_m"] == pytest.approx(float(np.median(near)), abs=0.05)
    assert m["offset_max_m"] == pytest.approx(max(near), abs=0.05) and 10 < min(near) and max(near) < 30
    assert m["verdict"] == "other" and m["sortie"] is None and m["file"] == "sortie-01.plan"
    # today's plan also points the gimbal down after the first lead-in (item 4), which the flown mission had not
    assert m["logged_items"] == m["logged_total"] == 71 and m["planned_items"] == 71 and m["compared_items"] == 70
    differs = [d for d in m["differences"] if d["kind"] == "differs"]
    missing = [d for d in m["differences"] if d["kind"] != "differs"]
    assert m["same_items"] + len(differs) == 70
    assert [(d["kind"], d["command"], d["planned_item"]) for d in missing] == [("missing", "DO_MOUNT_CONTROL", 4)]
    assert all(d["command"] == "NAV_WAYPOINT" and d["fields"][0]["field"] == "position" for d in differs)
    assert "another mission than sortie S01 of 'kubad-abad' (sortie-01.plan), or an older version of it" in out
    assert "0 of 39 survey waypoints at their place" in out and "item 3 (NAV_WAYPOINT P1-L001-R1:lead-in): position" in out
    # every output is written all the same, and `check` on the folder fails for the same reason
    assert (folder / "events.csv").is_file() and (folder / "coverage.tif").is_file()
    code, out = _run("check", folder, "--profile", "cz-land-consolidation")
    assert code == 1 and "another mission than sortie S01" in out
    assert not (folder / "failing_places.geojson").exists()


def test_the_sitl_plane_log_against_the_plan_it_flew_passes_the_mission_check(tmp_path):
    folder = tmp_path / "log"
    code, out = _run("log", "ingest", PLANE_LOG, "--plan", PLANE_PLAN, "-o", folder)
    assert code == 0, out
    rep = _report(folder)
    m = rep["mission"]
    assert (m["verdict"], m["sortie"], m["file"], m["differences"], m["changes"]) == ("plan", "S01", "sortie-01.plan", [], [])
    assert m["same_items"] == m["planned_items"] == 70 and m["survey_waypoints_found"] == m["survey_waypoints"] == 39
    assert rep["plan"]["sortie"] == "S01" and rep["planned"] == rep["matched"] == 683
    assert "the vehicle's mission is sortie S01 of 'kubad-abad' (sortie-01.plan): 70 items as planned" in out
    code, out = _run("check", folder, "--profile", "cz-land-consolidation")
    assert "another mission" not in out and "683 flown photos against 683 planned stations of sortie S01 " in out


def test_the_plans_mission_file_in_tests_data_is_the_one_its_manifest_lists():
    """sitl_plane_kubad_plan/sortie-01.plan was remade by the code of that plan (tests/data/README.md):
    its sha256 is the one its manifest recorded when that plan was written."""
    import hashlib

    manifest = json.loads((PLANE_PLAN / "manifest.json").read_text())
    assert hashlib.sha256((PLANE_PLAN / "sortie-01.plan").read_bytes()).hexdigest() == manifest["outputs"]["sortie-01.plan"]


# ---- synthetic logs of a plan split into sorties ---------------------------------------------------------


@pytest.fixture(scope="module")
def split(tmp_path_factory):
    """A copter plan split into sorties by a small battery: its folder, manifest and each sortie's items."""
    tmp = tmp_path_factory.mktemp("split")
    plan = tmp / "plan"
    assert _run("plan", make_spec(tmp, {"flight": {"heading": 0.0}, "battery": {"usable_min": 6.0}}), "-o", plan)[0] == 0
    manifest = json.loads((plan / "manifest.json").read_text())
    assert len(manifest["sorties"]) > 3
    items = {s["id"]: _waypoints(plan / s["files"][1]) for s in manifest["sorties"]}
    return plan, manifest, items


def _uploaded(plan: Path, sortie: str) -> list[tuple]:
    """A sortie's items as a ground station sends them (its .waypoints file as it is)."""
    return _waypoints(plan / f"sortie-{int(sortie[1:]):02d}.waypoints", logged=False)


def _photos(manifest: dict, sortie: str, t0: float = 100.0) -> list[tuple[float, float, float, float, float]]:
    """A camera event at each station of a sortie, 2.5 s apart: (time_s, lat, lon, alt AMSL, rel_alt)."""
    s = next(s for s in manifest["sorties"] if s["id"] == sortie)
    ids = [st["id"] for st in manifest["stations"]]
    stations = manifest["stations"][ids.index(s["first_station"]): ids.index(s["last_station"]) + 1]
    ground = manifest["home"]["ground_amsl_m"]
    return [(t0 + 2.5 * k, st["lat"], st["lon"], ground + st["alt_rel_m"], st["alt_rel_m"]) for k, st in enumerate(stations)]


def _ingest(tmp: Path, plan: Path, data: bytes, *extra: object, suffix: str = ".bin") -> tuple[int, str, dict]:
    log = tmp / f"flight{suffix}"
    log.write_bytes(data)
    folder = tmp / "log"
    code, out = _run("log", "ingest", log, "--plan", plan, "-o", folder, *extra)
    return code, out, (_report(folder) if (folder / "log_report.json").is_file() else {})


def test_the_sortie_is_recognised_from_the_mission_without_sortie(split, tmp_path):
    plan, manifest, items = split
    photos = _photos(manifest, "S02")
    code, out, rep = _ingest(tmp_path, plan, mission_log([(50.0, items["S02"])], photos))
    assert code == 0, out
    m = rep["mission"]
    assert (m["verdict"], m["sortie"], m["file"]) == ("plan", "S02", "sortie-02.plan")
    assert rep["plan"]["sortie"] == "S02" and rep["planned"] == rep["matched"] == len(photos) and rep["missed_stations"] == []
    assert m["same_items"] == m["planned_items"] == len(items["S02"]) - 1  # home (item 0) aside
    # --sortie naming another sortie than the one the vehicle was given is refused, with the right one
    (tmp_path / "other").mkdir()
    code, out, _ = _ingest(tmp_path / "other", plan, mission_log([(50.0, items["S02"])], photos), "--sortie", "S03")
    assert code == 2 and "the mission its vehicle was given is sortie S02's (sortie-02.plan); give --sortie S02" in out


def _moved(lat: float, lon: float, az: float, dist: float) -> tuple[float, float]:
    lon2, lat2, _ = GEOD.fwd(lon, lat, az, dist)
    return lat2, lon2


def test_a_mission_changed_in_the_field_is_reported_item_by_item(split, tmp_path):
    """The items of the sortie with the most waypoints with an altitude changed, a waypoint moved
    35 m, the speed changed, an item added and one left out: each is reported as that item, with
    what changed and by how much."""
    plan, manifest, items = split
    sortie = max(items, key=lambda s: sum(it[0] == 16 for it in items[s]))
    src = items[sortie]
    wps = [k for k, it in enumerate(src) if it[0] == 16 and k > 0]
    assert len(wps) >= 6
    edited = list(src)
    a, b = wps[2], wps[4]
    edited[a] = (*src[a][:8], src[a][8] - 20.0)  # 20 m lower
    lat, lon = _moved(src[b][6], src[b][7], 90.0, 35.0)
    edited[b] = (*src[b][:6], lat, lon, src[b][8])  # 35 m east
    speed = next(k for k, it in enumerate(src) if it[0] == 178)
    edited[speed] = (*src[speed][:3], 7.0, *src[speed][4:])  # param2, the speed: 7 m/s
    gone = wps[-1]  # the last waypoint left out
    del edited[gone]
    added_at = wps[1] + 1
    edited.insert(added_at, (16, 3, 0, 0, 0, 0, src[wps[1]][6] + 0.001, src[wps[1]][7], 60.0))  # a waypoint added
    photos = _photos(manifest, sortie)
    code, out, rep = _ingest(tmp_path, plan, mission_log([(50.0, edited)], photos), "--sortie", sortie)
    assert code == 0, out
    m = rep["mission"]
    # a survey waypoint moved and one left out: it is that sortie's mission changed, but its photos are not
    # taken for that sortie's stations unless --sortie says so (it is kept)
    assert (m["verdict"], m["sortie"], m["file"]) == ("changed", None, f"sortie-{int(sortie[1:]):02d}.plan")
    assert rep["plan"]["sortie"] == sortie and rep["matched"] == len(photos)
    diffs = {(d["kind"], d["planned_item"], d["logged_item"]): d for d in m["differences"]}
    shift = lambda k: k + (k >= added_at) - (k > gone)  # noqa: E731 - a planned item's number in the edited list
    expected = {("differs", a, shift(a)), ("differs", b, shift(b)), ("differs", speed, shift(speed)),
                ("added", None, added_at), ("missing", gone, None)}
    assert set(diffs) == expected, m["differences"]
    assert diffs[("differs", a, shift(a))]["fields"] == [{"field": "altitude", "planned": src[a][8], "logged": src[a][8] - 20.0}]
    (pos,) = diffs[("differs", b, shift(b))]["fields"]
    assert pos["field"] == "position" and pos["offset_m"] == pytest.approx(35.0, abs=0.1)
    assert pos["planned"] == pytest.approx([src[b][6], src[b][7]], abs=1e-7) and pos["logged"] == pytest.approx([lat, lon], abs=1e-7)
    assert diffs[("differs", speed, shift(speed))]["fields"] == [{"field": "param2", "planned": src[speed][3], "logged": 7.0}]
    assert diffs[("added", None, added_at)]["command"] == "NAV_WAYPOINT"
    assert diffs[("missing", gone, None)]["tag"].startswith("P1-L")
    assert m["same_items"] == len(src) - 1 - 4  # home aside, three changed, one left out
    # and on the console, one line each
    assert f"planned item {a} (the log's {shift(a)}) (NAV_WAYPOINT P1-L" in out and "altitude planned 102.13, logged 82.13" in out
    assert "position 35.0 m off" in out and "param2 planned 10, logged 7" in out
    assert f"the log's item {added_at} (NAV_WAYPOINT) is not planned" in out and f"planned item {gone} (NAV_WAYPOINT" in out
    assert "changed, survey waypoints moved" in out


def test_a_mission_flown_lower_is_its_sortie_changed(split, tmp_path):
    """Every altitude 10 m lower (a height limit met in the field): the same survey waypoints at their
    places, so the sortie is recognised, each item reported with its altitude."""
    plan, manifest, items = split
    src = items["S04"]
    lower = [(*it[:8], it[8] - 10.0) if it[0] in (16, 22) and k > 0 else it for k, it in enumerate(src)]
    code, out, rep = _ingest(tmp_path, plan, mission_log([(50.0, lower)], _photos(manifest, "S04")))
    assert code == 0, out
    m = rep["mission"]
    assert (m["verdict"], m["sortie"]) == ("changed", "S04") and rep["plan"]["sortie"] == "S04"
    changed = [k for k, it in enumerate(src) if it[0] in (16, 22) and k > 0]
    assert [d["planned_item"] for d in m["differences"]] == changed
    assert all(d["fields"] == [{"field": "altitude", "planned": src[d["planned_item"]][8],
                                "logged": pytest.approx(src[d["planned_item"]][8] - 10.0, abs=1e-4)}]
               for d in m["differences"])
    assert m["survey_waypoints_found"] == m["survey_waypoints"] > 0


def test_an_upload_that_stopped_is_named_so(split, tmp_path):
    """The vehicle holds S02's first line and nothing after it (ArduPilot keeps the items received)."""
    plan, manifest, items = split
    src = items["S02"]
    cut = next(k for k, it in enumerate(src) if it[0] == 206 and it[2] == 0) + 1  # after the first camera-off
    code, out, rep = _ingest(tmp_path, plan, mission_log([(50.0, src[:cut])], _photos(manifest, "S02")[:10]))
    m = rep["mission"]
    assert m["partial_upload"] and m["same_items"] == cut - 1 and m["logged_total"] == cut and m["sortie"] == "S02"
    assert {d["kind"] for d in m["differences"]} == {"missing"}
    assert [d["planned_item"] for d in m["differences"]] == list(range(cut, len(src)))
    assert "an upload that stopped" in out
    assert m["verdict"] == "changed" and code == 0


def test_a_mission_changed_after_the_first_photo_is_listed_as_a_change(split, tmp_path):
    plan, manifest, items = split
    src = items["S03"]
    photos = _photos(manifest, "S03")
    k = next(k for k, it in enumerate(src) if it[0] == 16 and k > 1)
    later = list(src)
    later[k] = (*src[k][:8], 80.0)
    code, out, rep = _ingest(tmp_path, plan, mission_log([(50.0, src), (photos[3][0] + 0.5, later)], photos))
    assert code == 0, out
    m = rep["mission"]
    assert m["verdict"] == "plan" and m["sortie"] == "S03"  # the mission flown from the first photo
    (change,) = m["changes"]
    assert change["at"] == f"{photos[3][0] + 0.5:.3f} s"
    (d,) = change["differences"]
    assert (d["kind"], d["planned_item"], d["logged_item"], d["fields"]) == \
        ("differs", k, k, [{"field": "altitude", "planned": src[k][8], "logged": 80.0}])
    assert f"mission changed after the first photo (recorded at {change['at']}): 1 item(s)" in out


def test_a_mission_replaced_before_the_first_photo_is_not_the_one_flown(split, tmp_path):
    """The log starts with S01's mission, S04's is uploaded before the first photo: S04 is recognised."""
    plan, manifest, items = split
    photos = _photos(manifest, "S04")
    code, out, rep = _ingest(tmp_path, plan, mission_log([(10.0, items["S01"]), (60.0, items["S04"])], photos))
    assert code == 0, out
    m = rep["mission"]
    assert (m["verdict"], m["sortie"], m["changes"]) == ("plan", "S04", []) and "1 mission(s) recorded before it" in m["note"]


def test_a_resumed_mission_flies_part_of_the_plan(split, tmp_path):
    """`aerosurvey resume` splits the rest of a cut flight into sorties of its own: a log of one is
    neither a sortie of the plan nor another mission; its photo runs start at planned stations."""
    plan, manifest, _ = split
    ids = [st["id"] for st in manifest["stations"]]

    def span(s: dict) -> set[int]:
        return set(range(ids.index(s["first_station"]), ids.index(s["last_station"]) + 1))

    # resumed after a station where the second resumed sortie flies the whole of a planned sortie and more (the case
    # this guards: its photos of the other sortie's stations were once extras, the log named after the planned sortie
    # it held); which station gives it depends on where the battery split cuts, so it is looked for
    for after in ids[5:len(ids) // 2:5]:
        resumed = tmp_path / f"resumed-{after}"
        code, out = _run("resume", plan, "--spec", plan.parent / "spec.toml", "--after", after, "-o", resumed)
        assert code == 0, out
        resumed_sorties = json.loads((resumed / "resume.json").read_text())["sorties"][:2]
        if len(resumed_sorties) == 2 and any(span(s) < span(resumed_sorties[1]) for s in manifest["sorties"]):
            break
    else:
        pytest.fail("no resumed plan whose second sortie flies a whole planned sortie and more")
    for k, rs in enumerate(resumed_sorties):
        stations = [manifest["stations"][i] for i in sorted(span(rs))]
        photos = [(100.0 + 2.5 * i, st["lat"], st["lon"], st["alt_rel_m"], st["alt_rel_m"]) for i, st in enumerate(stations)]
        (tmp_path / str(k)).mkdir()
        code, out, rep = _ingest(tmp_path / str(k), plan, mission_log([(50.0, _waypoints(resumed / rs["files"][1]))], photos))
        assert code == 0, out
        m = rep["mission"]
        assert (m["verdict"], m["sortie"]) == ("changed", None) and m["photo_runs_from_stations"] == m["photo_runs"] > 0
        assert "the vehicle's mission flies part of the plan" in out
        assert rep["matched"] == len(photos) and rep["extras"]["count"] == 0


def test_a_log_without_a_mission_says_so_and_keeps_sortie(split, tmp_path):
    plan, manifest, _ = split
    photos = _photos(manifest, "S02")
    code, out, rep = _ingest(tmp_path, plan, mission_log([], photos), "--sortie", "S02")
    assert code == 0, out
    m = rep["mission"]
    assert (m["verdict"], m["sortie"], m["source"]) == ("not-recorded", None, None) and "no CMD messages" in m["note"]
    assert "mission not compared: flight.bin has no CMD messages" in out
    assert rep["plan"]["sortie"] == "S02" and rep["matched"] == len(photos)


def test_a_plan_folder_without_its_mission_files_is_not_compared(split, tmp_path):
    plan, manifest, items = split
    bare = tmp_path / "bare"
    shutil.copytree(plan, bare)
    for f in bare.glob("*.plan"):
        f.unlink()
    code, out, rep = _ingest(tmp_path, bare, mission_log([(50.0, items["S02"])], _photos(manifest, "S02")), "--sortie", "S02")
    assert code == 0, out
    m = rep["mission"]
    assert m["verdict"] == "not-compared" and m["logged_items"] == len(items["S02"])
    assert "the plan folder has no mission file (sortie-01.plan, sortie-02.plan" in m["note"]


def test_damaged_cmd_messages_cost_only_their_items(tmp_path):
    """The plane log's mission with CMD messages zeroed, one with a flipped bit in its latitude, and
    a copied chunk of them: the items lost are not recorded (not reported missing), the flipped one
    is reported where it is, the copies count once."""
    data = bytearray(PLANE_LOG.read_bytes())
    from aerosurvey.flight.dataflash import DataFlashLog

    with DataFlashLog(PLANE_LOG) as log:
        offs = log.message_offsets("CMD").tolist()
        size = log.type_of("CMD").length
    for o in offs[40:46]:  # items 40-45 lost
        data[o:o + size] = bytes(size)
    lat_at = 3 + 8 + 2 * 3 + 4 * 4  # TimeUS, CTot/CNum/CId, Prm1-4
    (lat,) = struct.unpack_from("<i", data, offs[19] + lat_at)
    struct.pack_into("<i", data, offs[19] + lat_at, lat ^ (1 << 12))  # item 19, a waypoint: 4096e-7 degrees north or south
    chunk = bytes(data[offs[10]: offs[30]])
    data[offs[-1] + size: offs[-1] + size] = chunk  # items 10-29 copied after the write
    code, out, rep = _ingest(tmp_path, PLANE_PLAN, bytes(data))
    m = rep["mission"]
    assert m["compared_items"] == 70 - 6 and m["unrecorded_items"] == 6 and not m["complete"]
    (d,) = m["differences"]
    assert (d["kind"], d["planned_item"], d["logged_item"]) == ("differs", 19, 19)
    off = GEOD.inv(0, (lat ^ (1 << 12)) * 1e-7, 0, lat * 1e-7)[2]
    assert d["fields"][0]["field"] == "position" and d["fields"][0]["offset_m"] == pytest.approx(off, abs=0.05)
    # the moved waypoint is a survey waypoint: the events are matched to every station (this plan's one sortie's)
    assert m["verdict"] == "changed" and m["sortie"] is None and code == 0 and rep["matched"] == 683


# ---- telemetry logs and ULogs -----------------------------------------------------------------------------


def _tlog(items: list[tuple], photos: list[tuple], stop_at: int | None = None, autopilot: int = 3) -> bytes:
    """A telemetry log: the vehicle's HEARTBEAT, an upload (MISSION_COUNT and MISSION_ITEM_INT, cut
    after `stop_at` items), then CAMERA_FEEDBACK for each photo."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    gcs, vehicle = mavlink.MAVLink(None, srcSystem=255, srcComponent=190), mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    msgs = [vehicle.heartbeat_encode(2, autopilot, 0, 0, 0).pack(vehicle), gcs.heartbeat_encode(6, 8, 0, 0, 0).pack(gcs),
            gcs.mission_count_encode(1, 1, len(items), 0).pack(gcs)]
    for k, (cmd, frame, p1, p2, p3, p4, x, y, z) in enumerate(items[:stop_at]):
        xi, yi = (0, 0) if frame == 2 else (round(x * 1e7), round(y * 1e7))
        msgs.append(gcs.mission_item_int_encode(1, 1, k, frame, cmd, 0, 1, p1, p2, p3, p4, xi, yi, z, 0).pack(gcs))
    for k, (t, lat, lon, alt, rel) in enumerate(photos):
        msgs.append(vehicle.camera_feedback_encode(int(t * 1e6), 1, 0, k, round(lat * 1e7), round(lon * 1e7), alt, rel,
                                                   0.0, 0.0, 0.0, 0.0, k, 1).pack(vehicle))
    return b"".join(struct.pack(">Q", 1_700_000_000_000_000 + 1000 * k) + m for k, m in enumerate(msgs))


def test_a_telemetry_logs_upload_names_the_sortie(split, tmp_path):
    plan, manifest, items = split
    photos = _photos(manifest, "S06")
    code, out, rep = _ingest(tmp_path, plan, _tlog(_uploaded(plan, "S06"), photos), suffix=".tlog")
    assert code == 0, out
    m = rep["mission"]
    assert (m["verdict"], m["sortie"], m["source"]) == ("plan", "S06", "MISSION_ITEM_INT") and m["complete"]
    assert rep["matched"] == len(photos)
    # an upload that stopped after 5 items: the log records 5 of them, the rest not recorded
    (tmp_path / "cut").mkdir()
    code, out, rep = _ingest(tmp_path / "cut", plan, _tlog(_uploaded(plan, "S06"), photos, stop_at=5), "--sortie", "S06",
                             suffix=".tlog")
    m = rep["mission"]
    assert "1 of them stop short of their count" in m["note"] and not m["complete"]
    assert m["compared_items"] == 4 and m["unrecorded_items"] == len(items["S06"]) - 5 and m["differences"] == []


NAV_TOPIC = [("uint64_t", "timestamp"), ("uint16_t", "sequence_current"), ("uint16_t", "nav_cmd"), ("float", "latitude"),
             ("float", "longitude"), ("float", "time_inside"), ("float", "acceptance_radius"), ("float", "loiter_radius"),
             ("float", "yaw"), ("float", "altitude"), ("uint8_t", "frame"), ("uint8_t", "origin"),
             ("bool", "loiter_exit_xtrack"), ("bool", "force_heading"), ("bool", "altitude_is_relative"),
             ("bool", "autocontinue"), ("bool", "vtol_back_transition")]
RESULT_TOPIC = [("uint64_t", "timestamp"), ("uint16_t", "seq_reached"), ("uint16_t", "seq_current"), ("uint16_t", "seq_total")]
CAMERA_TOPIC = [("uint64_t", "timestamp"), ("double", "lat"), ("double", "lon"), ("float", "alt"), ("float", "ground_distance"),
                ("float", "q[0]"), ("float", "q[1]"), ("float", "q[2]"), ("float", "q[3]")]


def test_a_ulog_records_the_items_flown(tmp_path):
    """A PX4 plan: the ULog's navigator_mission_item records the items PX4 reached (its first
    two lines), float32 positions, a DO item's parameters; the sortie is recognised from them."""
    plan = tmp_path / "plan"
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}, "vehicle": {"firmware": "px4"}, "battery": {"usable_min": 6.0}})
    assert _run("plan", spec, "-o", plan)[0] == 0
    manifest = json.loads((plan / "manifest.json").read_text())
    src = _waypoints(plan / "sortie-03.waypoints", logged=False)[1:]  # PX4 keeps no home: item 0 is the first after it
    photos = _photos(manifest, "S03")
    reached = next(k for k, it in enumerate(src) if it[0] == 206 and it[2] == 0 and k > 6)  # the second camera-off
    rows = [("mission_result", {"timestamp": 1, "seq_total": len(src)})]
    for k, (cmd, frame, p1, p2, p3, p4, x, y, z) in enumerate(src[:reached + 1]):
        rec = {"timestamp": 50_000_000 + k, "sequence_current": k, "nav_cmd": cmd, "frame": frame, "autocontinue": True}
        if frame == 2:
            rec.update(time_inside=p1, acceptance_radius=p2, loiter_radius=p3, yaw=p4, altitude=z)
        else:
            rec.update(latitude=x, longitude=y, altitude=z, altitude_is_relative=frame == 3, time_inside=p1,
                       acceptance_radius=p2, yaw=math.radians(p4))
        rows.append(("navigator_mission_item", rec))
    rows += [("camera_capture", {"timestamp": int(t * 1e6), "lat": lat, "lon": lon, "alt": alt, "ground_distance": rel,
                                 "q[0]": 1.0}) for t, lat, lon, alt, rel in photos]
    data = ulog({"navigator_mission_item": NAV_TOPIC, "mission_result": RESULT_TOPIC, "camera_capture": CAMERA_TOPIC}, rows)
    code, out, rep = _ingest(tmp_path, plan, data, suffix=".ulg")
    assert code == 0, out
    m = rep["mission"]
    assert (m["verdict"], m["sortie"], m["source"]) == ("plan", "S03", "navigator_mission_item")
    assert m["compared_items"] == m["logged_items"] == reached + 1 and m["logged_total"] == len(src)
    assert m["unrecorded_items"] == len(src) - reached - 1 and not m["complete"]
    assert f"(the log records {reached + 1} of them)" in out


def test_the_sample_px4_ulog_records_no_mission():
    record = read_mission(DATA / "px4_sample_events.ulg")
    assert record.flown is None and record.autopilot == "px4" and "no navigator_mission_item topic" in record.note


# ---- the comparison on its own -----------------------------------------------------------------------------


def _mission(seed: int, n_lines: int) -> tuple[list[mp.WireItem], list[str]]:
    """A survey mission as aerosurvey writes them: take-off, speed, then per line lead-in, start,
    camera on, end, camera off; positions in 1e-7 degrees near 49.4 N, altitudes relative."""
    rng = np.random.default_rng(seed)
    items = [(22, 3, 0, 0, 0, 0, 49.4, 15.0, 100.0, "takeoff"), (178, 2, 1, 10, -1, 0, 0, 0, 0, "speed")]
    for k in range(n_lines):
        lon = 15.0 + 0.001 * k + rng.uniform(-1e-5, 1e-5)
        line = f"P1-L{k + 1:03d}-R1"
        items += [(16, 3, 0, 0, 0, 0, 49.399, lon, 100.0, f"{line}:lead-in"), (16, 3, 0, 0, 0, 0, 49.3995, lon, 100.0,
                                                                                  f"P1-L{k + 1:03d}-S0001"),
                  (206, 2, 24.7, 0, 1, 0, 0, 0, 0, f"{line}:camera-on"), (16, 3, 0, 0, 0, 0, 49.404, lon, 100.0, f"{line}:end"),
                  (206, 2, 0, 0, 0, 0, 0, 0, 0, f"{line}:camera-off")]
    wire = [mp.WireItem(k, c, f, p1, p2, p3, p4, round(x * 1e7), round(y * 1e7), z)
            for k, (c, f, p1, p2, p3, p4, x, y, z, _) in enumerate(items)]
    return wire, [it[-1] for it in items]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31), n_lines=st.integers(2, 8), data=st.data())
def test_every_edit_is_reported_as_the_item_it_touched(seed, n_lines, data):
    """Random altitude changes and moves of waypoints (more than the tolerance) and items left
    out: each change reported at its item with its field and distance, each item left out as
    missing (one of its alike items, for a camera item), the rest one by meaning."""
    items, tags = _mission(seed, n_lines)
    wps = [k for k, it in enumerate(items) if it.command == 16]
    touched = data.draw(st.sets(st.sampled_from(wps), max_size=len(wps) // 3))
    # moves short of half the 55 m between waypoints: each stays the nearest to where it was
    moves = {k: data.draw(st.floats(3.0, 25.0)) for k in touched if data.draw(st.booleans())}
    lowered = {k: data.draw(st.floats(0.5, 50.0)) for k in touched if k not in moves}
    dropped = data.draw(st.sets(st.sampled_from([k for k in range(len(items)) if k not in touched]), max_size=4))
    logged = []
    for it in items:
        if it.seq in dropped:
            continue
        x, y, z = it.x, it.y, it.z
        if it.seq in moves:
            lon2, lat2, _ = GEOD.fwd(y * 1e-7, x * 1e-7, 45.0, moves[it.seq])
            x, y = round(lat2 * 1e7), round(lon2 * 1e7)
        if it.seq in lowered:
            z -= lowered[it.seq]
        logged.append(mp.WireItem(len(logged), it.command, it.frame, it.param1, it.param2, it.param3, it.param4, x, y, z))
    c = mfl.compare(mfl.PlannedMission("S01", "s.plan", tuple(items), tuple(tags)), logged, True, lambda it: it, False)
    changed = {d.planned: d for d in c.differences if d.kind == "differs"}
    missing = [d for d in c.differences if d.kind == "missing"]
    assert {d.kind for d in c.differences} <= {"differs", "missing"}
    assert set(changed) == set(moves) | set(lowered)
    assert sorted((items[d.planned].command, tags[d.planned].split(":")[0]) for d in missing) == \
        sorted((items[k].command, tags[k].split(":")[0]) for k in dropped)
    for k, dist in moves.items():
        (f,) = changed[k].fields
        assert f["field"] == "position" and f["offset_m"] == pytest.approx(dist, rel=2e-3, abs=0.05)
    for k, dz in lowered.items():
        (f,) = changed[k].fields
        assert (f["field"], f["planned"]) == ("altitude", 100.0) and f["logged"] == pytest.approx(100.0 - dz, abs=1e-4)
    assert c.same == len(items) - len(changed) - len(dropped)
    survey = [k for k, (it, t) in enumerate(zip(items, tags)) if t.startswith("P1-L") and it.command == 16]
    assert c.survey_waypoints == len(survey) and c.found == len(survey) - len(set(moves) | (dropped & set(survey)))


def test_a_mission_resumed_far_into_the_plan_has_its_photos_matched(split, tmp_path):
    """A flight resumed after a station far into the plan (past the matcher's window from the plan's start): its
    log names no sortie and its mission is none of the plan's, so its photos are matched to the stations they lie
    nearest, every one of them (0 of 13 were matched before)."""
    plan, manifest, _ = split
    ids = [st["id"] for st in manifest["stations"]]
    starts = {s["first_station"] for s in manifest["sorties"]}
    after = next(a for a in ids[len(ids) // 2:] if ids[ids.index(a) + 1] not in starts)  # mid-sortie: none of the plan's
    resumed = tmp_path / "resumed"
    code, out = _run("resume", plan, "--spec", plan.parent / "spec.toml", "--after", after, "-o", resumed)
    assert code == 0, out
    first = json.loads((resumed / "resume.json").read_text())["sorties"][0]
    span = range(ids.index(first["first_station"]), ids.index(first["last_station"]) + 1)
    assert span.start > 60
    stations = [manifest["stations"][i] for i in span]
    photos = [(100.0 + 2.5 * i, st["lat"], st["lon"], st["alt_rel_m"], st["alt_rel_m"]) for i, st in enumerate(stations)]
    code, out, rep = _ingest(tmp_path, plan, mission_log([(50.0, _waypoints(resumed / first["files"][1]))], photos))
    assert code == 0, out
    assert (rep["mission"]["verdict"], rep["mission"]["sortie"]) == ("changed", None)
    assert rep["matched"] == len(photos) and rep["extras"]["count"] == 0
