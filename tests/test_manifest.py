"""manifest.json: the schema shipped with the package, the one writer, the one reader."""

from __future__ import annotations

import ast
import copy
import json
import re
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aerosurvey import ids, schemas
from aerosurvey import manifest as mf
from aerosurvey.cli import main
from aerosurvey.errors import InputError
from conftest import REPO, make_spec

SCHEMA_FILE = REPO / "src" / "aerosurvey" / "data" / "manifest.schema.json"
EXAMPLES = sorted(p.stem for p in (REPO / "missions").glob("*.toml"))


def _full_validator() -> jsonschema.Draft202012Validator:
    """jsonschema over the shipped file as it is: no fast path, no shared code with aerosurvey.schemas."""
    return jsonschema.Draft202012Validator(json.loads(SCHEMA_FILE.read_text(encoding="utf-8")))


@pytest.fixture(scope="module")
def small_plan(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("small")
    spec = make_spec(tmp, {"flight": {"heading": 0.0}, "battery": {"usable_min": 6.0}})
    out = tmp / "plan"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return out


def test_shipped_schemas_are_valid_json_schemas():
    for name in ("manifest", "events", "log_report"):
        jsonschema.Draft202012Validator.check_schema(schemas.schema(name))
    assert schemas.schema("manifest")["properties"]["schema_version"]["const"] == mf.SCHEMA_VERSION == 3
    assert schemas.schema("manifest")["additionalProperties"] is False


@pytest.mark.slow
@pytest.mark.parametrize("name", EXAMPLES)
def test_every_example_manifest_validates_and_reads(name, tmp_path):
    out = tmp_path / name
    res = CliRunner().invoke(main, ["plan", str(REPO / "missions" / f"{name}.toml"), "-o", str(out)])
    assert res.exit_code == 0, res.output
    raw = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    errors = list(_full_validator().iter_errors(raw))
    assert errors == [], [e.message for e in errors[:3]]
    doc = mf.read_manifest(out)
    assert doc.schema_version == 3 and doc.mission.name == raw["mission"]["name"] and doc.crs == raw["crs"]["planning"]
    assert list(doc.stations.ids) == [s["id"] for s in raw["stations"]]
    assert np.allclose(doc.stations.x, [s["x"] for s in raw["stations"]])
    assert [s.id for s in doc.sorties] == [s["id"] for s in raw["sorties"]]
    assert [ln.id for ln in doc.lines] == [ln["id"] for ln in raw["lines"]]
    # the GSD of each station at its image centre: H·p/f stretched by 1/sin² of the camera's depression (the slant
    # range and the ray's slant on the ground), none for a level camera; worked here from the manifest's camera
    cam = raw["camera"]
    pixel_mm = cam["sensor_mm"][0] / cam["image_px"][0]
    agl = np.array([s["agl_m"] for s in raw["stations"]], float)
    down = np.sin(np.radians(-np.array([s["pitch_deg"] for s in raw["stations"]], float)))
    written = np.array([np.nan if s["gsd_cm"] is None else s["gsd_cm"] for s in raw["stations"]], float)
    assert np.array_equal(np.isnan(written), down <= 0.0)
    look = down > 0.0
    assert np.allclose(written[look], 100.0 * agl[look] * pixel_mm / cam["focal_mm"] / down[look] ** 2, rtol=3e-3, atol=6e-4)
    for s in raw["sorties"]:
        part = doc.sortie_stations(s["id"])
        assert (part.ids[0], part.ids[-1], len(part)) == (s["first_station"], s["last_station"], s["photos"])


def test_writer_output_in_memory_passes_the_schema(small_plan):
    """build_manifest's own output (before `plan` adds rules) through the full jsonschema."""
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.mission.builder import build_mission
    from aerosurvey.spec import load_spec

    spec = load_spec(small_plan.parent / "spec.toml")
    plan = plan_from_files(spec)
    m = mf.build_manifest(plan, spec, len(build_mission(plan).items), {})
    text = mf.dumps(m)
    assert list(_full_validator().iter_errors(json.loads(text))) == []
    assert mf.loads(text, "in memory").mission.name == "test"
    assert len(json.loads(text)["sorties"]) >= 2  # the battery split is exercised


def test_stations_written_from_columns_are_the_rows(small_plan):
    """The text `plan` writes (stations from a StationTable, no rows made) is the text of the
    manifest with its rows, and the table's rows are the manifest's rows."""
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.spec import load_spec

    spec = load_spec(small_plan.parent / "spec.toml")
    plan = plan_from_files(spec)
    full = mf.build_manifest(plan, spec, 7, {"a": "b"})
    bare = mf.build_manifest(plan, spec, 7, {"a": "b"}, with_stations=False)
    table = mf.station_table(plan)
    assert bare["stations"] == [] and table.rows() == full["stations"] and len(full["stations"]) > 10
    assert mf.dumps(bare, table) == mf.dumps(full)
    assert json.loads(mf.dumps(bare, table)) == full
    with pytest.raises(ValueError, match="given twice"):
        mf.dumps(full, table)


def _write(folder: Path, data: dict) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "manifest.json").write_text(json.dumps(data))
    return folder


def _one_line(exc: pytest.ExceptionInfo) -> str:
    msg = str(exc.value)
    assert "\n" not in msg and "Traceback" not in msg
    return msg


def test_future_and_older_versions_are_refused_with_what_to_do(small_plan, tmp_path):
    raw = json.loads((small_plan / "manifest.json").read_text())
    newer = _write(tmp_path / "newer", {**raw, "schema_version": 4, "aerosurvey_version": "9.0"})
    with pytest.raises(InputError) as exc:
        mf.read_manifest(newer)
    msg = _one_line(exc)
    assert "aerosurvey 9.0" in msg and "schema 3" in msg and "upgrade aerosurvey" in msg
    older = _write(tmp_path / "older", {**raw, "schema_version": 1})
    with pytest.raises(InputError) as exc:
        mf.read_manifest(older)
    msg = _one_line(exc)
    assert "schema 1" in msg and "re-plan it with `aerosurvey plan SPEC -o DIR`" in msg
    # the commands say the same, exit 2, one line
    for cmd in (["check", str(older)], ["sitl", "fly", str(newer)], ["log", "ingest", "x.bin", "--plan", str(older), "-o",
                                                                      str(tmp_path / "o")]):
        res = CliRunner().invoke(main, cmd)
        assert res.exit_code == 2 and res.output.count("\n") == 1 and "schema" in res.output, (cmd, res.output)
    assert not (tmp_path / "o").exists()


def test_reader_errors_name_the_problem(small_plan, tmp_path):
    raw = json.loads((small_plan / "manifest.json").read_text())
    cases = {
        "empty": (None, "has no manifest.json: give the folder `aerosurvey plan` wrote"),
        "notjson": ("{not json", "is not valid JSON"),
        "list": ("[1, 2]", "not an aerosurvey manifest"),
        "othername": (json.dumps({**raw, "schema": "something-else"}), "schema = 'something-else'"),
    }
    for name, (text, expected) in cases.items():
        folder = tmp_path / name
        folder.mkdir()
        if text is not None:
            (folder / "manifest.json").write_text(text)
        with pytest.raises(InputError) as exc:
            mf.read_manifest(folder, "--plan")
        assert expected in _one_line(exc), (name, str(exc.value))
    with pytest.raises(InputError, match="does not exist"):
        mf.read_manifest(tmp_path / "nowhere")
    bad = copy.deepcopy(raw)
    bad["stations"][3]["agl_m"] = "high"
    with pytest.raises(InputError) as exc:
        mf.from_data(bad, "m.json")
    assert "stations[3].agl_m: 'high' is not of type" in _one_line(exc)
    extra = {**raw, "surprise": 1}
    with pytest.raises(InputError, match=r"\(top level\): Additional properties are not allowed \('surprise'"):
        mf.from_data(extra, "m.json")
    del raw["derived"]["photo_base_m"]
    with pytest.raises(InputError, match="derived: 'photo_base_m' is a required property"):
        mf.from_data(raw, "m.json")


_ROW_MUTATIONS = st.sampled_from(["drop", "extra", "string", "null_id", "bool", "bad_id", "negative_seq", "float_seq",
                                  "none"])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_column_check_agrees_with_jsonschema(small_plan, data):
    """The fast column check of the stations table never accepts what jsonschema refuses."""
    raw = json.loads((small_plan / "manifest.json").read_text())
    keys = list(raw["stations"][0])
    for _ in range(data.draw(st.integers(0, 3))):
        i = data.draw(st.integers(0, len(raw["stations"]) - 1))
        row = raw["stations"][i]
        key = data.draw(st.sampled_from(keys))
        kind = data.draw(_ROW_MUTATIONS)
        if kind == "drop":
            row.pop(key, None)
        elif kind == "extra":
            row["surplus"] = 1
        elif kind == "string":
            row[key] = "x"
        elif kind == "null_id":
            row["id"] = None
        elif kind == "bool":
            row[key] = True
        elif kind == "bad_id":
            row["id"] = data.draw(st.sampled_from(["P1-L1-S0001", "P1-L001-S1", "p1-L001-S0001", "P1-L001-S0001x"]))
        elif kind == "negative_seq":
            row["seq"] = 0
        elif kind == "float_seq":
            row["seq"] = 2.5
    ours = schemas.first_error("manifest", raw)
    theirs = sorted(_full_validator().iter_errors(raw), key=lambda e: len(e.absolute_path))
    assert (ours is None) == (not theirs), (ours, [e.message for e in theirs[:2]])


@given(p=st.integers(1, 9), line=st.integers(0, 99998), n=st.integers(0, 999998), part=st.integers(0, 98))
def test_ids_round_trip_and_match_the_schema(p, line, n, part):
    """ids.py counts lines, stations and parts from 0 (as the planner does); the schema holds its patterns."""
    schema = json.loads(SCHEMA_FILE.read_text())
    defs = schema["$defs"]
    sid, rid, lid = ids.station_id(p, line, n), ids.run_id(p, line, part), ids.line_id(p, line)
    assert ids.parse_station_id(sid) == (p, line, n) and sid.rsplit("-", 1)[0] == lid == rid.rsplit("-", 1)[0]
    assert re.search(defs["station_id"]["pattern"], sid) and re.search(defs["run_id"]["pattern"], rid)
    assert re.search(schema["properties"]["lines"]["items"]["properties"]["line"]["pattern"], lid)
    assert (defs["station_id"]["pattern"], defs["run_id"]["pattern"]) == (ids.STATION_PATTERN.replace(r"\d", "[0-9]"),
                                                                          ids.RUN_PATTERN)
    assert schema["properties"]["sorties"]["items"]["properties"]["id"]["pattern"] == ids.SORTIE_PATTERN
    assert re.search(ids.SORTIE_PATTERN, ids.sortie_id(part + 1))


def test_id_formats_are_the_ones_in_the_files():
    assert ids.station_id(1, 2, 11) == "P1-L003-S0012" and ids.run_id(2, 40, 0) == "P2-L041-R1"
    assert ids.sortie_id(2) == "S02" and ids.sortie_file_stem(2) == "sortie-02" and ids.event_id(7) == "E00007"
    with pytest.raises(ValueError, match="'P1-L3-S12' is not a station id"):
        ids.parse_station_id("P1-L3-S12")


def _manifest_reads(path: Path) -> list[int]:
    """Lines of json.load/json.loads calls that read manifest data: the argument mentions a manifest,
    or a name the same function assigned from something that does. A copy (loads(dumps(x))) is no read."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    src = path.read_text(encoding="utf-8")
    hits = []
    for fn in [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef | ast.Module)]:
        tainted = {t.id for n in ast.walk(fn) if isinstance(n, ast.Assign) and "manifest" in (ast.get_source_segment(src, n.value) or "")
                   for t in n.targets if isinstance(t, ast.Name)}
        for n in ast.walk(fn):
            if (isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and n.func.attr in ("load", "loads")
                    and isinstance(n.func.value, ast.Name) and n.func.value.id == "json" and n.args):
                arg = ast.get_source_segment(src, n.args[0]) or ""
                if arg.startswith("json.dumps("):
                    continue
                names = {x.id for x in ast.walk(n.args[0]) if isinstance(x, ast.Name)}
                if "manifest" in arg or names & tainted:
                    hits.append(n.lineno)
    return sorted(set(hits))


#: Readers of manifests by hand still to move to aerosurvey.manifest (none left). The test fails when
#: one appears, or when a listed one stops reading by hand, so that its entry is removed with it.
PENDING: set[str] = set()


def test_no_manifest_is_read_by_hand_outside_the_reader():
    root = REPO / "src" / "aerosurvey"
    found = {p.relative_to(root).as_posix(): lines for p in sorted(root.rglob("*.py")) if (lines := _manifest_reads(p))}
    found.pop("manifest.py", None)
    assert set(found) == PENDING, found


def test_the_grep_finds_a_hand_read(tmp_path):
    p = tmp_path / "m.py"
    p.write_text("import json\n\ndef f(folder):\n    m_path = folder / 'manifest.json'\n    return json.loads(m_path.read_text())\n"
                 "\ndef g(files):\n    return json.loads(files['manifest.json'])\n\ndef h(x):\n    return json.loads(json.dumps(x))\n")
    assert _manifest_reads(p) == [5, 8]


def test_docs_table_is_generated_from_the_schema():
    doc = (REPO / "docs" / "manifest.md").read_text(encoding="utf-8")
    assert schemas.markdown_table("manifest") in doc
    assert f"version {mf.SCHEMA_VERSION}" in doc.splitlines()[0]


def test_run_stations_are_each_runs_first_last_and_count(small_plan):
    """Against a scan of the stations for each run (the way the lines were found before)."""
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.spec import load_spec

    plan = plan_from_files(load_spec(small_plan.parent / "spec.toml"))
    expected = []
    for i in range(len(plan.route.runs)):
        sel = [k for k, r in enumerate(plan.stations.run.tolist()) if r == i]
        expected.append((sel[0], sel[-1], len(sel)))
    assert mf.run_stations(plan) == expected
    assert len(expected) > 3
