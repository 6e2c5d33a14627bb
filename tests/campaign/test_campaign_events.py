"""The events the commands that do them record in a campaign's register (docs/campaign.md, "The register"):
`upload` (uploaded), `check FLIGHT` (compliance), `refly` (re-fly), `qa accuracy --campaign BLOCK -o DIR` (qa)
on a block's plan folder; nothing on a plan folder outside a campaign; a warning on a block folder the register
no longer holds; a damaged register named in one line after the command's own work; no event lost when several
processes record at once, or while `campaign plan` and `campaign ingest` run.

The register is read with pyogrio (campaigncase.register), the expected details from the files themselves."""

from __future__ import annotations

import json
import multiprocessing
import re
import shutil
import subprocess
import sys
from pathlib import Path

import campaigncase as cc
import pytest
import shapely
import tomli_w
from click.testing import CliRunner
from test_campaign_ingest import synthetic_log
from tests.link.fake_vehicle import FakeVehicle, VehicleModel

from aerosurvey.cli import main


@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> Path:
    """Three blocks planned with the default outputs (manifest and pilots' files: `check FLIGHT` and `refly`
    read the area and zones from outline.geojson)."""
    return cc.planned_campaign(tmp_path_factory.mktemp("events"), 3)


@pytest.fixture
def campaign(planned, tmp_path) -> Path:
    """A copy of the planned campaign for one test."""
    return Path(shutil.copytree(planned, tmp_path / "campaign"))


def run(*args: str | Path) -> tuple[int, str, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.stdout, res.stderr


def new_events(campaign: Path, before: list[dict]) -> list[dict]:
    after = cc.register(campaign)[1]
    assert after[:len(before)] == before, "an event recorded before was changed or lost"
    return after[len(before):]


def status_line(campaign: Path, block: str) -> str:
    code, out, _ = run("campaign", "status", campaign)
    assert code == 0, out
    return next(ln.strip() for ln in out.splitlines() if ln.strip().startswith(f"{block}:"))


def home_of(plan: Path) -> tuple[float, float, float]:
    """The .plan's planned home position (lat, lon, alt), read from its JSON."""
    lat, lon, alt = json.loads(plan.read_text())["mission"]["plannedHomePosition"]
    return lat, lon, alt


def fence_vertices(plan: Path) -> int:
    return sum(len(p["polygon"]) for p in json.loads(plan.read_text())["geoFence"]["polygons"])


# --- upload ------------------------------------------------------------------------------------------------------


def test_upload_of_a_block_records_uploaded(campaign):
    block = cc.block_folders(campaign)["t00"]
    plan = block / "mission.plan"
    before = cc.register(campaign)[1]
    model = VehicleModel(storage="ardupilot", home=home_of(plan))
    with FakeVehicle(model, "udp") as fv:
        code, out, err = run("upload", plan, "--connect", fv.url)
    assert code == 0, out + err
    items = len(model.stored[0])  # what the vehicle holds, its home item 0 included, as `upload` counts them
    assert f"mission: {items} items uploaded" in out
    fence = fence_vertices(plan)
    assert fence > 0 and len(model.stored[1]) == fence
    assert new_events(campaign, before) == [{
        "block": "t00", "key": block.name.split(".")[1], "event": "uploaded",
        "detail": f"mission.plan: copter mission for ardupilot, {items} mission items, {fence} fence vertices to system 1 "
                  "(ArduPilot); verified (read back and compared)"}]
    assert f"campaign {campaign.resolve()}: block t00: uploaded recorded; status uploaded" in err
    assert status_line(campaign, "t00").startswith("t00: uploaded; next: fly it")

    # --no-verify: recorded as not verified
    with FakeVehicle(VehicleModel(storage="ardupilot", home=home_of(plan)), "udp") as fv:
        code, out, err = run("upload", plan, "--connect", fv.url, "--no-verify")
    assert code == 0, out + err
    assert cc.register(campaign)[1][-1]["detail"].endswith("; not verified (--no-verify)")


def test_failed_upload_records_nothing(campaign):
    plan = cc.block_folders(campaign)["t01"] / "mission.plan"
    before = cc.register(campaign)
    with FakeVehicle(VehicleModel(storage="ardupilot", home=home_of(plan), fail_item=3), "udp") as fv:
        code, out, err = run("upload", plan, "--connect", fv.url)
    assert code == 1, out + err
    assert cc.register(campaign) == before
    assert "recorded" not in err


def test_plain_plan_folder_records_nothing_and_prints_the_same(campaign, tmp_path):
    """The same mission file uploaded from a block folder and from a copy outside any campaign: the copy's
    output is the block's less the recorded line, and no register anywhere changes."""
    block = cc.block_folders(campaign)["t02"]
    plain = Path(shutil.copytree(block, tmp_path / "plain"))
    before = (campaign / "register.gpkg").read_bytes()
    outputs = []
    for folder in (plain, block):
        plan = folder / "mission.plan"
        with FakeVehicle(VehicleModel(storage="ardupilot", home=home_of(plan)), "udp") as fv:
            code, out, err = run("upload", plan, "--connect", fv.url)
        assert code == 0, out + err
        outputs.append((re.sub(r"\d+(\.\d+)? ?m?s\b", "T", out.replace(str(folder), "F")), err))  # times vary
        if folder == plain:
            assert (campaign / "register.gpkg").read_bytes() == before
            assert not list(plain.glob("**/register.*"))
    (plain_out, plain_err), (block_out, block_err) = outputs
    assert plain_out == block_out and plain_err == ""
    assert block_err.strip() == f"campaign {campaign.resolve()}: block t02: uploaded recorded; status uploaded"


def test_block_folder_of_an_old_key_records_nothing_with_a_warning(campaign):
    """A block planned again under a new key since: its old folder's commands record nothing, and say why."""
    block = cc.block_folders(campaign)["t00"]
    old = block.parent / f"t00.{'0' * 20}"
    shutil.copytree(block, old)
    before = cc.register(campaign)
    plan = old / "mission.plan"
    with FakeVehicle(VehicleModel(storage="ardupilot", home=home_of(plan)), "udp") as fv:
        code, out, err = run("upload", plan, "--connect", fv.url)
    assert code == 0, out + err
    assert cc.register(campaign) == before
    assert err.strip().splitlines() == [
        f"warning: campaign {campaign.resolve()}: uploaded event not recorded: the campaign's register holds no block of "
        f"folder '{old.name}' (planned again since, under a new key)"]


def test_damaged_register_is_named_and_the_upload_is_done(campaign):
    plan = cc.block_folders(campaign)["t00"] / "mission.plan"
    (campaign / "register.gpkg").write_bytes(b"not a geopackage\n" * 20)
    model = VehicleModel(storage="ardupilot", home=home_of(plan))
    with FakeVehicle(model, "udp") as fv:
        code, out, err = run("upload", plan, "--connect", fv.url)
    assert code == 2, out + err
    assert len(model.stored[0]) > 1  # the mission is on the vehicle, verified (stdout says so)
    assert "verified" in out
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: '{campaign.resolve() / 'register.gpkg'}' cannot be read as a "
                                                   "campaign register"), err


# --- check FLIGHT, refly ---------------------------------------------------------------------------------------------


def block_spec(inputs: Path, block: str, folder: Path) -> Path:
    """The campaign's template (in `inputs`, with its blocks file) with the block's polygon as its [area]:
    refly needs a whole spec."""
    import tomllib

    spec = tomllib.loads((inputs / "template.toml").read_text())
    feats = json.loads((inputs / "blocks.geojson").read_text())["features"]
    poly = shapely.geometry.shape(next(f["geometry"] for f in feats if f["properties"]["name"] == block))
    spec["area"] = {"wkt": poly.wkt}
    spec["mission"]["name"] = block
    path = folder / f"{block}.toml"
    path.write_text(tomli_w.dumps(spec))
    return path


def test_check_and_refly_of_a_flight_record_compliance_and_re_fly(planned, campaign, tmp_path):
    block = cc.block_folders(campaign)["t01"]
    log = synthetic_log(block, tmp_path / "gappy.bin", missed=2)  # the first two lines' photos missed
    assert run("campaign", "ingest", campaign, log)[0] == 0
    flight = campaign / "flights" / "t01" / "gappy.bin"
    before = cc.register(campaign)[1]

    code, out, err = run("check", flight, "--json")
    assert code == 1, out + err  # the missed lines leave ground uncovered
    result = json.loads(out)  # stdout is the JSON alone: the recorded line goes to stderr
    passed = sum(r["status"] == "pass" for r in result["results"])  # the flown result, its planned one inside
    assert result["failed"] == ["uncovered-ground"]
    key = block.name.split(".")[1]
    assert new_events(campaign, before) == [{
        "block": "t01", "key": key, "event": "compliance",
        "detail": f"gappy.bin: {len(result['results'])} rules as flown: {passed} passed, 1 failed at error level: "
                  "uncovered-ground"}]
    assert status_line(campaign, "t01").startswith("t01: compliance; next: QA it")

    before = cc.register(campaign)[1]
    out_dir = tmp_path / "refly"
    code, out, err = run("refly", flight, "--plan", block, "--spec", block_spec(planned.parent, "t01", tmp_path), "-o", out_dir)
    assert code == 0, out + err
    gaps = shapely.from_geojson((out_dir / "gaps.geojson").read_text())
    photos = len(json.loads((out_dir / "manifest.json").read_text())["stations"])
    (event,) = new_events(campaign, before)
    assert (event["block"], event["key"], event["event"]) == ("t01", key, "re-fly")
    assert event["detail"].startswith(f"{out_dir}: {photos} photos in ")
    assert " gap(s) seen by fewer than " in event["detail"] and event["detail"].endswith(f"(flight {flight})")
    ha = float(event["detail"].split(" runs over ")[1].split(" ha in ")[0])
    assert len(shapely.get_parts(gaps)) == int(event["detail"].split(" ha in ")[1].split(" gap(s)")[0])
    assert gaps.area > 0 and ha > 0  # gaps.geojson is in WGS84: its area in ha is compared below, in metres
    c = gaps.centroid
    from pyproj import Transformer

    to_m = Transformer.from_crs("EPSG:4326", f"+proj=aeqd +lat_0={c.y} +lon_0={c.x}", always_xy=True)
    area_m2 = shapely.area(shapely.transform(gaps, lambda a: __import__("numpy").column_stack(to_m.transform(a[:, 0], a[:, 1]))))
    assert ha == pytest.approx(area_m2 / 1e4, abs=0.002, rel=0.01)
    assert status_line(campaign, "t01").startswith("t01: re-fly; next: fly the re-fly mission")

    # the same flight against a copy of the block's folder outside the campaign: the same results, nothing recorded
    plain = Path(shutil.copytree(block, tmp_path / "plain"))
    before = (campaign / "register.gpkg").read_bytes()
    code, out, err = run("check", flight, "--json", "--plan", plain)
    assert code == 1 and json.loads(out) == result, out + err
    assert "recorded" not in err
    code, out, err = run("refly", flight, "--plan", plain, "--spec", block_spec(planned.parent, "t01", tmp_path), "-o",
                         tmp_path / "refly-plain")
    assert code == 0 and err == "", out + err
    assert (tmp_path / "refly-plain" / "gaps.geojson").read_text() == (out_dir / "gaps.geojson").read_text()
    code, out, err = run("qa", "accuracy", points_csv(tmp_path / "pts.csv"), "--campaign", plain, "-o", tmp_path / "qa")
    assert code in (0, 3) and "recorded" not in err and "campaign" not in err, out + err
    assert (campaign / "register.gpkg").read_bytes() == before
    assert not list(plain.glob("register.*")) and not list(tmp_path.glob("register.*"))


# --- qa accuracy -------------------------------------------------------------------------------------------------------


def points_csv(path: Path) -> Path:
    rows = ["id,role,dx_cm,dy_cm,dz_cm"] + [f"C{i},check,{(-1) ** i * 1.5},{(-1) ** (i // 2) * 1.2},{(-1) ** (i // 3) * 2.0}"
                                            for i in range(20)]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_qa_accuracy_of_a_block_files_its_verdict(campaign, tmp_path):
    block = cc.block_folders(campaign)["t02"]
    before = cc.register(campaign)[1]
    out_dir = tmp_path / "qa-t02"
    code, out, err = run("qa", "accuracy", points_csv(tmp_path / "pts.csv"), "--class-h", "5", "--class-v", "10",
                         "--campaign", block, "-o", out_dir)
    assert code in (0, 3), out + err  # a valid test, or one whose statement lacks inputs: its verdict is filed either way
    doc = json.loads((out_dir / "accuracy.json").read_text())
    (event,) = new_events(campaign, before)
    assert (event["block"], event["event"]) == ("t02", "qa")
    rx, ry, rz = (doc["statistics"][a]["rmse_m"] * 100 for a in "xyz")
    assert rx == pytest.approx(1.5) and ry == pytest.approx(1.2) and rz == pytest.approx(2.0)
    assert event["detail"].startswith(f"{doc['standard']}: RMSE x 1.50 y 1.20 z 2.00 cm, 20 check points, 0 control points; "
                                      "class h 5 cm, class v 10 cm: ")
    filed = campaign / "qa" / block.name / "accuracy.json"
    assert filed.read_bytes() == (out_dir / "accuracy.json").read_bytes()
    assert status_line(campaign, "t02").startswith("t02: qa; next: accept it")

    # accepted stays by hand
    assert run("campaign", "record", campaign, "t02", "accepted")[0] == 0
    assert cc.register(campaign)[1][-1]["event"] == "accepted"

    # without -o there is no file to file: nothing recorded, a warning says why
    before = cc.register(campaign)
    code, out, err = run("qa", "accuracy", tmp_path / "pts.csv", "--campaign", block)
    assert cc.register(campaign) == before
    assert "warning: campaign" in err and "qa event not recorded: give -o DIR" in err


# --- the lock ---------------------------------------------------------------------------------------------------------


def _record(args: tuple[str, int]) -> int:
    from aerosurvey.campaign.register import now_utc, record

    campaign, i = args
    record(Path(campaign), f"t0{i % 3}", "uploaded", f"process {i}", now_utc())
    return i


def test_twenty_processes_recording_at_once_lose_no_event(campaign):
    before = cc.register(campaign)[1]
    with multiprocessing.get_context("spawn").Pool(8) as pool:
        assert sorted(pool.map(_record, [(str(campaign), i) for i in range(20)], chunksize=1)) == list(range(20))
    added = new_events(campaign, before)
    assert sorted(e["detail"] for e in added) == sorted(f"process {i}" for i in range(20))
    assert all(e["block"] == f"t0{int(e['detail'].split()[1]) % 3}" and e["event"] == "uploaded" for e in added)


def test_event_recorded_while_campaign_plan_runs_survives(planned, campaign, tmp_path, monkeypatch):
    """One event recorded while the blocks are planned (the plan has read nothing yet), one by another process
    while the plan holds the lock between reading the register and writing it: both are in the register after."""
    import aerosurvey.campaign.register as register
    import aerosurvey.campaign.run as run_module

    real_run, real_after = run_module.run_campaign, register.after_planning
    waited: list[str] = []

    def planning(*args, **kwargs):
        out = real_run(*args, **kwargs)
        register.record(campaign, "t00", "uploaded", "while planning", register.now_utc())
        return out

    def writing(*args, **kwargs):
        proc = subprocess.Popen([str(Path(sys.executable).parent / "aerosurvey"), "campaign", "record", str(campaign), "t01",
                                 "uploaded", "--detail", "while writing"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        try:
            proc.wait(timeout=10)  # without the lock it records now, and the plan's write below would drop it
            waited.append("finished")
        except subprocess.TimeoutExpired:
            waited.append("blocked")
        writing.proc = proc  # type: ignore[attr-defined]
        return real_after(*args, **kwargs)

    monkeypatch.setattr(run_module, "run_campaign", planning)
    monkeypatch.setattr(register, "after_planning", writing)
    blocks = cc.write_blocks(tmp_path / "more.geojson", 4, size_deg=(0.003, 0.002))  # t00-t02 as planned, t03 new
    code, out, err = run("campaign", "plan", blocks, "-o", campaign, "--spec", planned.parent / "template.toml",
                         "--workers", "1")
    proc = writing.proc  # type: ignore[attr-defined]
    assert proc.wait(timeout=60) == 0, proc.stdout.read() if proc.stdout else ""
    assert code == 0, out + err
    assert waited == ["blocked"], "the recording process was not held by the plan's lock"
    details = {e["detail"]: e["block"] for e in cc.register(campaign)[1] if e["event"] == "uploaded"}
    assert details == {"while planning": "t00", "while writing": "t01"}
    rows = {r["name"]: r["status"] for r in cc.register(campaign)[0]}
    assert rows == {"t00": "uploaded", "t01": "uploaded", "t02": "planned", "t03": "planned"}


def test_event_recorded_while_campaign_ingest_reads_survives(campaign, tmp_path, monkeypatch):
    import aerosurvey.campaign.flights as flights

    real = flights.ingest_flights

    def reading(*args, **kwargs):
        from aerosurvey.campaign.register import now_utc, record

        out = real(*args, **kwargs)
        record(campaign, "t02", "qa", "while ingesting", now_utc())
        return out

    monkeypatch.setattr(flights, "ingest_flights", reading)
    log = synthetic_log(cc.block_folders(campaign)["t01"], tmp_path / "day.bin")
    assert run("campaign", "ingest", campaign, log)[0] == 0
    events = [(e["block"], e["event"], e["detail"].split(":")[0]) for e in cc.register(campaign)[1] if e["event"] != "planned"]
    assert events == [("t02", "qa", "while ingesting"), ("t01", "flown", "day.bin")]


def test_damaged_register_after_check_and_qa_is_named_and_their_files_are_written(campaign, tmp_path):
    block = cc.block_folders(campaign)["t01"]
    log = synthetic_log(block, tmp_path / "full.bin")
    assert run("campaign", "ingest", campaign, log)[0] == 0
    flight = campaign / "flights" / "t01" / "full.bin"
    register = campaign / "register.gpkg"
    register.write_bytes(b"\x00" * 1000)
    error = f"Error: '{register.resolve()}' cannot be read as a campaign register"
    code, out, err = run("check", flight)
    assert code == 2 and (flight / "failing_places.geojson").is_file(), out + err
    assert "1 rules as flown: 1 passed, 0 failed" in out
    assert [ln for ln in err.splitlines() if not ln.startswith("warning: no rule profile")] == [err.splitlines()[-1]]
    assert err.splitlines()[-1].startswith(error), err
    out_dir = tmp_path / "qa"
    code, out, err = run("qa", "accuracy", points_csv(tmp_path / "pts.csv"), "--campaign", block, "-o", out_dir)
    assert code == 2 and (out_dir / "accuracy.json").is_file(), out + err
    assert len(err.strip().splitlines()) == 1 and err.startswith(error), err
    assert register.read_bytes() == b"\x00" * 1000
