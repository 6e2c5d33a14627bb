"""`aerosurvey resume`: the exported missions photograph exactly the stations left, each once, with
the plan's ids, and point the gimbal as the original flight did there; refusals name what is wrong
(exit 2, nothing written). tests/flight/test_resume_after_rtl.py: what a log counts as done."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import independent_coverage as ic
from aerosurvey.cli import main
from conftest import REPO, make_spec

CENTRE = (15.003, 49.4017)


def _plan(tmp: Path, overrides: dict | None = None) -> tuple[Path, Path, dict]:
    spec = make_spec(tmp, {"flight": {"heading": 0.0}, **(overrides or {})})
    out = tmp / "plan"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return spec, out, json.loads((out / "manifest.json").read_text())


def _photos(folder: Path, stem: str) -> np.ndarray:
    files = sorted(folder.glob(f"{stem}-*.waypoints"))
    parts = []
    for f in files:
        home, rows = ic.read_wpl(f)
        p = ic.replay_triggers(rows, ic.local_projection(*CENTRE), None, home[2])
        parts.append(np.column_stack([p.x, p.y]))
    return np.concatenate(parts) if parts else np.zeros((0, 2))


def _stations(manifest: dict) -> tuple[list[str], np.ndarray]:
    st = manifest["stations"]
    x, y = ic.local_projection(*CENTRE).transform([s["lon"] for s in st], [s["lat"] for s in st])
    return [s["id"] for s in st], np.column_stack([x, y])


@pytest.mark.parametrize("overrides, cut", [
    ({}, 0.37),  # one mission, cut mid-line
    ({"battery": {"usable_min": 6.0}}, 0.52),  # the rest in several sorties
    ({"vehicle": {"type": "plane", "cruise_speed_ms": 16.0}}, 0.61),
])
def test_the_resumed_missions_photograph_exactly_the_stations_left(tmp_path: Path, overrides: dict, cut: float) -> None:
    spec, out, manifest = _plan(tmp_path, overrides)
    ids, xy = _stations(manifest)
    k = int(len(ids) * cut)
    res = CliRunner().invoke(main, ["resume", str(out), "--spec", str(spec), "--after", ids[k], "-o", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    photos = _photos(tmp_path / "r", "resume")
    left = xy[k + 1:]
    assert len(photos) == len(left)  # as many photos as stations left, as ArduPilot's trigger takes them
    d = np.hypot(photos[:, None, 0] - xy[None, :, 0], photos[:, None, 1] - xy[None, :, 1])
    nearest = d.argmin(axis=1)
    assert sorted(nearest.tolist()) == list(range(k + 1, len(ids)))  # each station left once, none taken before
    step = manifest["derived"]["speed_ms"] / 50.0  # the 50 Hz trigger check's overshoot
    assert d.min(axis=1).max() < step + 0.05
    doc = json.loads((tmp_path / "r" / "resume.json").read_text())
    assert doc["from_station"] == ids[k + 1] and doc["stations_done"] == k + 1 and doc["stations_left"] == len(left)
    assert doc["sorties"][0]["first_station"] == ids[k + 1] and doc["sorties"][-1]["last_station"] == ids[-1]
    assert doc["counted"] == [f"--after {ids[k]}: the {k + 1} stations up to it in the flight order are taken as photographed"]


def test_resume_from_the_first_station_a_flight_cut_short_did_not_photograph(tmp_path: Path) -> None:
    """The SITL copter log of tests/data (the default area at heading 0, flown in AUTO), cut half
    way: `log ingest` matches its photos to stations, and the resumed missions take the rest."""
    spec, out, manifest = _plan(tmp_path)
    data = (Path(__file__).parent / "data" / "sitl_copter_survey.bin").read_bytes()
    cut = tmp_path / "cut.bin"
    cut.write_bytes(data[: len(data) // 2])
    flight = tmp_path / "flight"
    res = CliRunner().invoke(main, ["log", "ingest", str(cut), "--plan", str(out), "-o", str(flight)])
    assert res.exit_code == 0, res.output
    lines = (flight / "events.csv").read_text().splitlines()
    taken = [r["station"] for r in csv.DictReader(ln for ln in lines if not ln.startswith("#")) if r["station"]]
    ids, xy = _stations(manifest)
    assert 0 < len(taken) < len(ids)
    res = CliRunner().invoke(main, ["resume", str(out), "--spec", str(spec), "--log", str(flight), "-o", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    k = next(i for i, s in enumerate(ids) if s not in taken)  # every photo of this log is in AUTO, within 0.6 m
    assert json.loads((tmp_path / "r" / "resume.json").read_text())["from_station"] == ids[k]
    photos = _photos(tmp_path / "r", "resume")
    assert len(photos) == len(ids) - k


@pytest.mark.parametrize("args, message", [
    (["--after", "P9-L001-S0001"], "station 'P9-L001-S0001' is not a station of this plan"),
    ([], "give one of --after STATION_ID or --log FLIGHT_FOLDER"),
])
def test_refusals_name_what_is_wrong(tmp_path: Path, args: list[str], message: str) -> None:
    spec, out, _ = _plan(tmp_path)
    res = CliRunner().invoke(main, ["resume", str(out), "--spec", str(spec), *args, "-o", str(tmp_path / "r")])
    assert res.exit_code == 2 and message in res.output, res.output
    assert not (tmp_path / "r").exists()


def test_the_last_station_leaves_nothing_to_fly(tmp_path: Path) -> None:
    spec, out, manifest = _plan(tmp_path)
    last = manifest["stations"][-1]["id"]
    res = CliRunner().invoke(main, ["resume", str(out), "--spec", str(spec), "--after", last, "-o", str(tmp_path / "r")])
    assert res.exit_code == 2 and "nothing is left to fly" in res.output


def test_a_spec_that_now_plans_otherwise_is_refused(tmp_path: Path) -> None:
    spec, out, manifest = _plan(tmp_path)
    changed = tmp_path / "changed"
    changed.mkdir()
    shutil.copy(tmp_path / "area.geojson", changed / "area.geojson")
    (changed / "spec.toml").write_text(spec.read_text().replace("gsd_cm = 2.5", "gsd_cm = 2.4"))
    res = CliRunner().invoke(main, ["resume", str(out), "--spec", str(changed / "spec.toml"), "--after",
                                    manifest["stations"][5]["id"], "-o", str(tmp_path / "r")])
    assert res.exit_code == 2 and "resume needs the same plan" in res.output, res.output


def test_resume_json_is_read_back_and_a_bad_one_refused(tmp_path: Path) -> None:
    from aerosurvey import resumefile
    from aerosurvey.errors import InputError

    text = resumefile.dumps("m", "plan", "P1-L001-S0004", 3, ("three photos in AUTO",),
                            [{"files": ["resume-01.plan", "resume-01.waypoints"], "first_station": "P1-L001-S0004",
                              "last_station": "P1-L002-S0009", "photos": 20, "time_s": 61.5}])
    doc = resumefile.loads(text)
    assert doc.from_station == "P1-L001-S0004" and doc.stations_done == 3 and doc.counted == ("three photos in AUTO",)
    assert doc.sorties[0].photos == 20 and doc.sorties[0].files[0] == "resume-01.plan"
    for bad, message in (("{", "not valid JSON"), ('{"schema": "x"}', "is not a resume.json"),
                         (text.replace('"schema_version": 2', '"schema_version": 9'), "schema_version = 9"),
                         (text.replace('"schema_version": 2', '"schema_version": 1'), "run `aerosurvey resume` again"),
                         (text.replace('"photos": 20', '"photos": "many"'), "wrong type"),
                         (text.replace('"three photos in AUTO"', "3"), "counted = \\[3\\] is not a list of texts"),
                         (text.replace('"stations_done": 3', '"stations_done": "x"'), "wrong type")):
        with pytest.raises(InputError, match=message):
            resumefile.loads(bad)


def _first_mount_and_trigger(path: Path) -> tuple[int | None, int, list[float] | None]:
    """(the index of the first DO_MOUNT_CONTROL, of the first DO_SET_CAM_TRIGG_DIST that starts
    the camera, that mount item's row) of a .waypoints file."""
    _, rows = ic.read_wpl(path)
    mount = next((i for i, r in enumerate(rows) if int(r[3]) == 205), None)
    trigger = next(i for i, r in enumerate(rows) if int(r[3]) == 206 and r[4] > 0)
    return mount, trigger, rows[mount] if mount is not None else None


@pytest.mark.parametrize("spec_of, pass_of_cut", [
    (lambda tmp: make_spec(tmp, {"flight": {"heading": 0.0}}), 1),  # nadir: straight down, the mount may look elsewhere
    (lambda tmp: REPO / "missions" / "oblique-block.toml", 2),  # double grid at -45°, cut in its second pass
    # five directions, cut in the nadir pass: the mount may still look where another flight left it
    (lambda tmp: make_spec(tmp, {"pattern": {"kind": "oblique", "scheme": "five-direction", "pitch_deg": -45.0},
                                 "flight": {"heading": 0.0}, "targets": {"gsd_cm": 1.5}},
                           area=[[15.000, 49.400], [15.002, 49.400], [15.002, 49.4012], [15.000, 49.4012], [15.000, 49.400]]), 1),
    (lambda tmp: make_spec(tmp, {"pattern": {"kind": "oblique", "scheme": "five-direction", "pitch_deg": -45.0},
                                 "flight": {"heading": 0.0}, "targets": {"gsd_cm": 1.5}},
                           area=[[15.000, 49.400], [15.002, 49.400], [15.002, 49.4012], [15.000, 49.4012], [15.000, 49.400]]), 4),
])
def test_a_resumed_flight_sets_the_gimbal_before_its_first_photo(tmp_path: Path, spec_of, pass_of_cut: int) -> None:
    """The resumed mission's first mount command comes before its camera starts and points the
    camera as the plan does at the station it resumes from: the pitch below the horizon and the
    yaw relative to the nose (the station's camera bearing less its flight heading)."""
    spec = spec_of(tmp_path)
    out = tmp_path / "plan"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    stations = json.loads((out / "manifest.json").read_text())["stations"]
    in_pass = [i for i, s in enumerate(stations) if s["id"].startswith(f"P{pass_of_cut}-")]
    k = in_pass[len(in_pass) // 2]
    res = CliRunner().invoke(main, ["resume", str(out), "--spec", str(spec), "--after", stations[k]["id"], "-o", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    mount, trigger, row = _first_mount_and_trigger(tmp_path / "r" / "resume-01.waypoints")
    assert mount is not None and mount < trigger and row is not None
    first = stations[k + 1]
    yaw = (first["camera_yaw_deg"] - first["heading_deg"] + 180.0) % 360.0 - 180.0
    assert row[4] == pytest.approx(first["pitch_deg"], abs=0.01)
    assert (row[6] - yaw + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=0.01)
