"""Flight data matched to the wrong plan is refused: `log ingest`, `refly` and the web page name
both missions and the distance, exit 2 with one line, and leave no output folder."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner
from dfwriter import camera_log

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.flight import records
from conftest import make_spec

LOG = Path(__file__).resolve().parents[1] / "data" / "sitl_copter_survey.bin"
#: the test area (near 49.4 N 15.0 E) moved about 1,900 km to the south-east
FAR_RING = [[31.000, 37.700], [31.006, 37.700], [31.006, 37.7035], [31.000, 37.7035], [31.000, 37.700]]


def _plan(folder: Path, name: str, area: list | None = None) -> tuple[Path, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    spec = make_spec(folder, {"mission": {"name": name}, "flight": {"heading": 0.0}}, area=area)
    out = folder / "plan"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return spec, out


@pytest.fixture(scope="module")
def plans(tmp_path_factory) -> dict[str, tuple[Path, Path]]:
    tmp = tmp_path_factory.mktemp("plans")
    return {"home": _plan(tmp / "home", "home-field"), "far": _plan(tmp / "far", "far-field", FAR_RING)}


def _single_error_line(res) -> str:
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and res.output.startswith("Error: ") and res.output.count("\n") == 1, res.output
    return res.output


def test_log_of_another_mission_is_refused(plans, tmp_path):
    _, far = plans["far"]
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "--plan", str(far), "-o", str(tmp_path / "o")])
    msg = _single_error_line(res)
    assert "'sitl_copter_survey.bin'" in msg and "'far-field'" in msg and "more than one footprint" in msg
    km = float(msg.split("a median ")[1].split(" km")[0].replace(",", ""))
    assert 1700 < km < 2000  # the distance between the two areas
    assert not (tmp_path / "o").exists()


def test_log_of_its_own_plan_passes_with_the_distance_reported(plans, tmp_path):
    _, home = plans["home"]
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "--plan", str(home), "-o", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    rep = records.read_report(tmp_path / "o" / "log_report.json")
    assert rep["plan"]["mission"] == "home-field" and rep["plan"]["median_distance_m"] < 1.5


def test_a_sortie_the_log_did_not_fly_is_refused(tmp_path):
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}, "battery": {"usable_min": 6.0}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    manifest = json.loads((plan / "manifest.json").read_text())
    s1, s2 = manifest["sorties"][:2]
    ids = [s["id"] for s in manifest["stations"]]
    first = manifest["stations"][ids.index(s1["first_station"]): ids.index(s1["last_station"]) + 1]
    log = tmp_path / "s1.bin"
    log.write_bytes(camera_log([(float(i), s["lat"], s["lon"], 400.0, s["alt_rel_m"]) for i, s in enumerate(first)]))
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "--sortie", s1["id"], "-o", str(tmp_path / "a")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "--sortie", s2["id"], "-o", str(tmp_path / "b")])
    msg = _single_error_line(res)
    assert f"not of --sortie {s2['id']}" in msg and f"{len(first)} of its {len(first)} camera events" in msg
    assert f"give --sortie {s1['id']}" in msg
    assert not (tmp_path / "b").exists()
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "--sortie", "S99", "-o", str(tmp_path / "c")])
    assert "--sortie 'S99' is not a sortie of" in _single_error_line(res) and "S01" in res.output


@pytest.mark.parametrize("content,expected", [
    (None, "has no manifest.json: give the folder `aerosurvey plan` wrote"),
    ("{", "is not valid JSON"),
    ('{"schema": "aerosurvey-manifest", "schema_version": 1, "aerosurvey_version": "0.1.0"}', "re-plan it with"),
])
def test_plan_folder_without_a_readable_manifest(tmp_path, content, expected):
    folder = tmp_path / "plan"
    folder.mkdir()
    if content is not None:
        (folder / "manifest.json").write_text(content)
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "--plan", str(folder), "-o", str(tmp_path / "o")])
    assert expected in _single_error_line(res)
    assert "'--plan" in res.output or "--plan '" in res.output or "manifest.json" in res.output
    assert not (tmp_path / "o").exists()


def _damaged(plan: Path, tmp: Path) -> Path:
    """A log of `plan` with two of three triggers missed on the fourth line: coverage gaps to re-fly."""
    manifest = json.loads((plan / "manifest.json").read_text())
    runs = list(dict.fromkeys(s["line"] for s in manifest["stations"]))
    events = [(float(i), s["lat"], s["lon"], 400.0, s["alt_rel_m"]) for i, s in enumerate(manifest["stations"])
              if not (s["line"] == runs[3] and i % 3)]
    log = tmp / "damaged.bin"
    log.write_bytes(camera_log(events))
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "-o", str(tmp / "flown")])
    assert res.exit_code == 0, res.output
    return tmp / "flown"


def test_refly_with_another_missions_spec_or_plan_is_refused(plans, tmp_path):
    spec, home = plans["home"]
    far_spec, far = plans["far"]
    flown = _damaged(home, tmp_path)
    res = CliRunner().invoke(main, ["refly", str(flown), "--plan", str(home), "--spec", str(far_spec), "-o", str(tmp_path / "r")])
    msg = _single_error_line(res)
    assert "'far-field'" in msg and "'home-field'" in msg and "give the spec the plan was made from" in msg
    res = CliRunner().invoke(main, ["refly", str(flown), "--plan", str(far), "--spec", str(far_spec), "-o", str(tmp_path / "r")])
    msg = _single_error_line(res)
    assert "coverage of mission 'home-field'" in msg and "'far-field'" in msg
    assert not (tmp_path / "r").exists()
    # the right three: the re-fly and its gaps, written together
    res = CliRunner().invoke(main, ["refly", str(flown), "--plan", str(home), "--spec", str(spec), "-o", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    assert {"gaps.geojson", "manifest.json", "mission.plan"} <= {p.name for p in (tmp_path / "r").iterdir()}
    assert json.loads((tmp_path / "r" / "manifest.json").read_text())["mission"]["name"] == "home-field-refly"


def test_refly_needs_an_ingest_folder_with_a_plan(plans, tmp_path):
    spec, home = plans["home"]
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "-o", str(tmp_path / "noplan")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["refly", str(tmp_path / "noplan"), "--plan", str(home), "--spec", str(spec), "-o",
                                    str(tmp_path / "r")])
    assert "ingested without --plan" in _single_error_line(res)
    assert not (tmp_path / "r").exists()


def test_web_page_refuses_results_of_another_plan(plans, tmp_path):
    """The page's flight upload: results of the far mission against the home plan's page."""
    from aerosurvey.web.flown import flown_layers
    from aerosurvey.web.mapproj import MapFrame

    _, home = plans["home"]
    far_spec, far = plans["far"]
    far_log = tmp_path / "far.bin"
    manifest = json.loads((far / "manifest.json").read_text())
    far_log.write_bytes(camera_log([(float(i), s["lat"], s["lon"], 400.0, s["alt_rel_m"])
                                    for i, s in enumerate(manifest["stations"])]))
    res = CliRunner().invoke(main, ["log", "ingest", str(far_log), "--plan", str(far), "-o", str(tmp_path / "flown")])
    assert res.exit_code == 0, res.output
    files = {n: tmp_path / "flown" / n for n in ("events.csv", "coverage.tif", "log_report.json")}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from starlette.testclient import TestClient

        from aerosurvey.web.app import create_app

        with TestClient(create_app(home.parent / "spec.toml")) as c:
            spec = c.get("/api/state").json()["spec"]
            job = c.post("/api/plan", json={"spec": spec}).json()["job"]
            for _ in range(60):
                st = c.get(f"/api/jobs/{job}?wait=2").json()
                if st["state"] not in ("queued", "running"):
                    break
            assert st["state"] == "done", st
            pid = st["result"]["plan_id"]
            r = c.post(f"/api/plans/{pid}/flight", files=[("files", (n, p.read_bytes())) for n, p in files.items()])
    assert r.status_code == 400, r.text
    err = r.json()["error"]
    assert "mission 'far-field'" in err and "not of this plan" in err and " km " in err
    # with the page's plan at hand, the same refusal names both missions (as `log ingest` does)
    from aerosurvey import manifest as mf
    from aerosurvey.area import planning_crs

    doc = mf.read_manifest(home)
    frame = MapFrame.around(_area(home), planning_crs(doc.crs, _area(home)))
    with pytest.raises(InputError, match="mission 'far-field' are not of this plan, mission 'home-field'"):
        flown_layers(files, frame, doc)
    own = {n: p for n, p in files.items() if n == "events.csv"}
    with pytest.raises(InputError, match=r"not of this plan, mission 'home-field': their camera events lie a median [0-9,.]+ km"):
        flown_layers(own, frame, mf.loads((home / "manifest.json").read_text(), "the home plan"))


def _area(plan: Path):
    import shapely

    fc = json.loads((plan / "plan.geojson").read_text())
    return shapely.geometry.shape(next(f for f in fc["features"] if f["properties"]["role"] == "area")["geometry"])


def test_events_and_report_files_are_versioned(tmp_path, plans):
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "-o", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    text = (tmp_path / "o" / "events.csv").read_text()
    assert len(records.loads_events(text)) == 152
    for bad, expected in [(text.split("\n", 1)[1], "does not start with '# aerosurvey-events 2'"),
                          (text.replace("# aerosurvey-events 2", "# aerosurvey-events 3", 1), "upgrade aerosurvey"),
                          (text.replace("# aerosurvey-events 2", "# aerosurvey-events 1", 1), "run `aerosurvey log ingest` again"),
                          (text.replace(",AUTO,", ",auto mode,", 1), "does not match"),
                          (text.replace(",alt_m,", ",altitude,", 1), "columns"),
                          (text.replace("\n1,", "\nx,", 1), "event = 'x' is not a number")]:
        with pytest.raises(InputError, match=expected):
            records.loads_events(bad)
    rep = json.loads((tmp_path / "o" / "log_report.json").read_text())
    assert rep["schema"] == "aerosurvey-log-report" and rep["schema_version"] == records.REPORT_VERSION
    for doc, expected in [({**rep, "schema_version": records.REPORT_VERSION + 1}, "upgrade aerosurvey"),
                          ({**rep, "schema_version": records.REPORT_VERSION - 1}, "run `aerosurvey log ingest` again"),
                          ({k: v for k, v in rep.items() if k != "schema"}, "run it again"),
                          ({**rep, "events": "many"}, "events: 'many' is not of type 'integer'")]:
        with pytest.raises(InputError, match=expected):
            records.loads_report(json.dumps(doc))


def test_flight_log_docs_are_generated_from_the_schemas():
    from aerosurvey import schemas
    from conftest import REPO

    doc = (REPO / "docs" / "flight-logs.md").read_text(encoding="utf-8")
    assert schemas.markdown_columns("events", "rows") in doc and schemas.markdown_table("log_report") in doc
    assert list(records.COLUMNS) == [ln.split("`")[1] for ln in schemas.markdown_columns("events", "rows").splitlines()[2:]]
