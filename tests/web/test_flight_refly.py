"""From flight results to the next flight on the page: the unphotographed ground and the rules that
fail as flown are layers, and the re-fly is `aerosurvey refly`'s mission, file for file."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import shapely
from click.testing import CliRunner
from webutil import REPO, client, run_plan

from aerosurvey.cli import main
from conftest import make_spec

sys.path.insert(0, str(REPO / "tests" / "flight"))  # the DataFlash writer of the flight tests
from dfwriter import camera_log  # noqa: E402


def _damaged_flight(tmp: Path) -> tuple[Path, Path, Path]:
    """A plan and a log of it whose fourth line lost two of three triggers: spec, plan folder, ingested folder."""
    spec = make_spec(tmp, {"flight": {"heading": 0.0}})
    plan = tmp / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    manifest = json.loads((plan / "manifest.json").read_text())
    runs = list(dict.fromkeys(s["line"] for s in manifest["stations"]))
    events = [(float(i), s["lat"], s["lon"], 400.0, s["alt_rel_m"]) for i, s in enumerate(manifest["stations"])
              if not (s["line"] == runs[3] and i % 3)]
    (tmp / "flight.bin").write_bytes(camera_log(events))
    res = CliRunner().invoke(main, ["log", "ingest", str(tmp / "flight.bin"), "--plan", str(plan), "-o", str(tmp / "log")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["check", str(tmp / "log"), "--profile", "cz-land-consolidation"])
    assert (tmp / "log" / "failing_places.geojson").is_file(), res.output
    return spec, plan, tmp / "log"


def _upload(folder: Path) -> list[tuple[str, tuple[str, bytes]]]:
    names = ("events.csv", "coverage.tif", "log_report.json", "failing_places.geojson")
    return [("files", (n, (folder / n).read_bytes())) for n in names]


def test_flight_layers_and_the_refly_of_the_cli(tmp_path):
    spec, plan, log = _damaged_flight(tmp_path)
    res = CliRunner().invoke(main, ["refly", str(log), "--plan", str(plan), "--spec", str(spec), "-o", str(tmp_path / "refly")])
    assert res.exit_code == 0, res.output
    cli_gaps = shapely.from_geojson((tmp_path / "refly" / "gaps.geojson").read_text())
    with client(spec) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        assert st["state"] == "done", st
        pid = st["result"]["plan_id"]
        r = c.post(f"/api/plans/{pid}/flight", files=_upload(log))
        assert r.status_code == 200, r.text
        flown = r.json()
        # the unphotographed ground: the gaps `refly` re-flies
        gaps = shapely.union_all([shapely.geometry.shape(f["geometry"]) for f in flown["gaps"]["features"]])
        assert gaps.area > 0 and gaps.symmetric_difference(cli_gaps).area < 1e-6 * cli_gaps.area
        # the rules that fail as flown, and their places
        places = json.loads((log / "failing_places.geojson").read_text())["features"]
        failing = {f["properties"]["rule"] for f in places}
        assert failing and {x["rule"] for x in flown["rules"]} == failing
        assert len(flown["failing"]["features"]) == sum(1 for f in places if f["geometry"])
        # one button: the re-fly mission, with the downloads of `aerosurvey refly`
        r = c.post(f"/api/plans/{pid}/refly", files=_upload(log))
        assert r.status_code == 200, r.text
        out = r.json()
        assert sorted(out["files"]) == sorted(p.name for p in (tmp_path / "refly").iterdir() if not p.name.startswith("."))
        for name in ("mission.waypoints", "mission.plan", "gaps.geojson"):
            got = c.get(f"/api/plans/{out['plan_id']}/files/{name}")
            assert got.status_code == 200 and got.text == (tmp_path / "refly" / name).read_text(), name
        cli_lines = [f for f in json.loads((tmp_path / "refly" / "plan.geojson").read_text())["features"]
                     if f["properties"]["role"] == "line"]
        assert out["lines"]["features"] == cli_lines and cli_lines  # drawn on the map
        assert "gap(s)" in out["summary"] and math.isfinite(float(out["summary"].split(" ha")[0]))


def test_refly_needs_the_plan_of_the_saved_spec(tmp_path):
    spec, _plan, log = _damaged_flight(tmp_path)
    with client(spec) as c:
        data = c.get("/api/state").json()["spec"]
        data["targets"]["side_overlap"] = 0.7  # edited on the page, not saved
        st = run_plan(c, data)
        r = c.post(f"/api/plans/{st['result']['plan_id']}/refly", files=_upload(log))
        assert r.status_code == 400 and r.json()["key"] == "refly" and "save the spec" in r.json()["error"]
    with client(None) as c:  # no spec file at all
        st = run_plan(c, data | {"area": {"wkt": shapely.box(14.95, 49.43, 14.952, 49.431).wkt}})
        r = c.post(f"/api/plans/{st['result']['plan_id']}/refly", files=_upload(log))
        assert r.status_code == 400 and r.json()["key"] == "refly"


def test_resume_of_a_flight_cut_short_is_the_commands(tmp_path):
    """The SITL copter log cut half way: the page's Resume gives `aerosurvey resume --log`'s missions."""
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    data = (REPO / "tests" / "data" / "sitl_copter_survey.bin").read_bytes()
    (tmp_path / "cut.bin").write_bytes(data[: len(data) // 2])
    log = tmp_path / "log"
    res = CliRunner().invoke(main, ["log", "ingest", str(tmp_path / "cut.bin"), "--plan", str(plan), "-o", str(log)])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["resume", str(plan), "--spec", str(spec), "--log", str(log), "-o", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    names = ("events.csv", "log_report.json")
    with client(spec) as c:
        st = run_plan(c, c.get("/api/state").json()["spec"])
        pid = st["result"]["plan_id"]
        r = c.post(f"/api/plans/{pid}/resume", files=[("files", (n, (log / n).read_bytes())) for n in names])
        assert r.status_code == 200, r.text
        out = r.json()
        assert out["summary"] in res.output  # the command's own line
        assert out["notes"] == json.loads((tmp_path / "r" / "resume.json").read_text())["counted"]  # what was counted, why
        cli = sorted(p.name for p in (tmp_path / "r").iterdir() if not p.name.startswith("."))
        assert sorted(out["files"]) == cli
        for name in cli:
            got = c.get(f"/api/plans/{out['plan_id']}/files/{name}").text
            want = (tmp_path / "r" / name).read_text()
            if name == "resume.json":  # names the plan: a folder for the command, the page's plan here
                got, want = json.loads(got), json.loads(want)
                assert got.pop("plan") == "the page's plan" and want.pop("plan") == str(plan)
            assert got == want, name
        # without a log's matched photo: one line, about the loaded folder
        r = c.post(f"/api/plans/{pid}/resume", files=[("files", ("events.csv", (log / "events.csv").read_bytes()))])
        assert r.status_code == 400 and r.json()["key"] == "resume" and "the loaded folder" in r.json()["error"]
