"""A day of flights as one record: `log ingest` with several logs and photo folders of one plan.

The logs are DataFlash files written by the test's own writer (dfwriter.py), the photo folder
DJI JPEGs written byte by byte (photowriter.py). Every expectation is the test's own: which
stations each record photographed is decided here, the stations nobody photographed are the
complement of their union computed here, the ground fewer photos see than the plan needs is
counted from the test's station positions and the camera's sensor (independent_coverage.py),
the re-fly's photos are replayed from its mission.waypoints.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import re
import shutil
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import rasterio
import shapely
from click.testing import CliRunner
from dfwriter import camera_log, mission_log
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.flight import photowriter as pw

import independent_coverage as ic
from aerosurvey import schemas
from aerosurvey.cli import main
from conftest import make_spec

T0 = dt.datetime(2026, 6, 2, 8, 0, 0, tzinfo=dt.UTC)
SENSOR = (23.5, 15.6, 6000, 4000, 16.0)  # the spec's Sony a6000 with its 16 mm lens, as the camera's data sheet gives it
#: rules the plan passes as planned (75 % forward, 60 % side overlap, 2.5 cm, 8 photos on every point)
PROFILE = """
[profile]
id = "day-rules"
name = "rules of the day test"

[[rules]]
id = "fwd"
statement = "forward overlap at least 74 %"
check = "forward_overlap_min"
source = "test"
params = { min = 0.74 }

[[rules]]
id = "side"
statement = "side overlap at least 59 %"
check = "side_overlap_min"
source = "test"
params = { min = 0.59 }

[[rules]]
id = "gsd"
statement = "GSD at most 2.6 cm"
check = "gsd_max"
source = "test"
params = { max_cm = 2.6 }

[[rules]]
id = "cover"
statement = "every point of the area on at least 5 photos"
check = "coverage_min_images"
source = "test"
params = { min = 5 }
"""
#: the test area (near 49.4 N 15.0 E) moved about 1,900 km to the south-east
FAR_RING = [[31.000, 37.700], [31.006, 37.700], [31.006, 37.7035], [31.000, 37.7035], [31.000, 37.700]]


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


class Plan:
    """A plan of three sorties (a 9-minute battery) and its stations as the test reads them from manifest.json."""

    def __init__(self, tmp: Path, name: str = "test", area: list | None = None) -> None:
        tmp.mkdir(parents=True, exist_ok=True)
        self.spec = make_spec(tmp, {"mission": {"name": name}, "flight": {"heading": 0.0}, "battery": {"usable_min": 9.0}},
                              area=area)
        self.folder = tmp / "plan"
        code, text = _run("plan", self.spec, "-o", self.folder)
        assert code == 0, text
        m = json.loads((self.folder / "manifest.json").read_text())
        self.rows = m["stations"]
        self.ids = [s["id"] for s in self.rows]
        self.need = m["derived"]["side_images_per_point"] * m["derived"]["forward_images_per_point"]
        self.home = float(m["home"]["ground_amsl_m"])
        #: each sortie's station indices, from its first and last station
        self.sorties = {s["id"]: list(range(self.ids.index(s["first_station"]), self.ids.index(s["last_station"]) + 1))
                        for s in m["sorties"]}
        lon = [s["lon"] for s in self.rows]
        lat = [s["lat"] for s in self.rows]
        self.to_xy = ic.local_projection(float(np.mean(lon)), float(np.mean(lat)))

    def log(self, path: Path, idx: list[int], east_m: float | dict[int, float] = 0.0) -> Path:
        """A DataFlash log whose camera events are at stations `idx`, `east_m` east of them (per station: a dict)."""
        events = []
        t = 0.0
        for k, i in enumerate(idx):
            s = self.rows[i]
            east = east_m.get(i, 0.0) if isinstance(east_m, dict) else east_m
            lon = s["lon"] + east / (111_320.0 * math.cos(math.radians(s["lat"])))
            if k:  # flown at 10 m/s from the photo before, at least 2 s after it
                x0, y0 = self.to_xy.transform(events[-1][2], events[-1][1])
                x1, y1 = self.to_xy.transform(lon, s["lat"])
                t += max(2.0, math.hypot(x1 - x0, y1 - y0) / 10.0)
            events.append((t, s["lat"], lon, 400.0, s["alt_rel_m"]))
        path.write_bytes(camera_log(events))
        return path

    def photos(self, folder: Path, idx: list[int], east_m: float = 0.0) -> Path:
        """A folder of DJI photos at stations `idx`, `east_m` east of them, looking straight down along the line."""
        folder.mkdir(parents=True, exist_ok=True)
        for t, i in enumerate(idx):
            s = self.rows[i]
            lon = s["lon"] + east_m / (111_320.0 * math.cos(math.radians(s["lat"])))
            nxt = self.rows[i + 1] if i + 1 < len(self.rows) and self.rows[i + 1]["line"] == s["line"] else None
            north = nxt is None or nxt["lat"] > s["lat"]
            yaw = 0.0 if north else 180.0
            shot = pw.Shot(s["lat"], lon, self.home + s["alt_rel_m"], s["alt_rel_m"], T0 + dt.timedelta(seconds=2 * t),
                           gimbal_yaw=yaw, flight_yaw=yaw)
            (folder / f"DJI_{t + 1:04d}.JPG").write_bytes(pw.dji_jpeg(shot))
        return folder

    def counts(self, idx: set[int], gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
        """How many of the photos at stations `idx` see each point (local metres), nadir footprints."""
        k = sorted(idx)
        x, y = self.to_xy.transform([self.rows[i]["lon"] for i in k], [self.rows[i]["lat"] for i in k])
        agl = np.array([self.rows[i]["alt_rel_m"] for i in k])
        photos = ic.Photos(np.asarray(x), np.asarray(y), np.full(len(k), math.pi / 2), agl, np.zeros(len(k)))
        return ic.footprint_counts(photos, gx, gy, SENSOR, "landscape")


@pytest.fixture(scope="module")
def plan(tmp_path_factory) -> Plan:
    p = Plan(tmp_path_factory.mktemp("day"))
    assert len(p.sorties) == 3
    return p


def _block(idx: list[int], start: int, n: int) -> list[int]:
    return idx[start:start + n]


def _report(day: Path) -> dict:
    return json.loads((day / "day_report.json").read_text())


def test_a_day_of_three_sorties_a_photo_folder_and_a_refly(plan, tmp_path):
    s1, s2, s3 = plan.sorties["S01"], plan.sorties["S02"], plan.sorties["S03"]
    d1, d2, d3, d4 = _block(s1, 10, 6), _block(s2, 8, 5), _block(s3, 6, 5), _block(s3, 20, 8)
    twice = _block(s1, 2, 3)  # photographed by S01's log 2 m off and by the photo folder 0.5 m off: the folder's kept
    flown = {
        "S01.bin": [i for i in s1 if i not in d1],
        "S02.bin": [i for i in s2 if i not in d2],
        "S03.bin": [i for i in s3 if i not in d3 and i not in d4],
        "dji_S01": sorted(twice + d1),  # in flight order, as the matcher takes photos
        "refly.bin": d2 + d3,
    }
    logs = [plan.log(tmp_path / "S01.bin", flown["S01.bin"], {i: 2.0 for i in twice})]
    logs.append(plan.log(tmp_path / "S02.bin", flown["S02.bin"]))
    logs.append(plan.log(tmp_path / "S03.bin", flown["S03.bin"]))
    logs.append(plan.photos(tmp_path / "dji_S01", flown["dji_S01"], east_m=0.5))
    logs.append(plan.log(tmp_path / "refly.bin", flown["refly.bin"]))
    day = tmp_path / "day"
    code, text = _run("log", "ingest", *logs, "--plan", plan.folder, "-o", day)
    assert code == 0, text
    rep = _report(day)
    assert [(r["name"], r["kind"], r["sortie"]) for r in rep["records"]] == [
        ("S01.bin", "sortie", "S01"), ("S02.bin", "sortie", "S02"), ("S03.bin", "sortie", "S03"),
        ("dji_S01", "sortie", "S01"), ("refly.bin", "re-fly", None)]
    # every record's own outputs in its own folder, nothing overwritten
    for r, name in zip(rep["records"], flown):
        rows = (day / r["folder"] / "events.csv").read_text().splitlines()
        assert len(rows) - 2 == len(flown[name]) == r["events"] == r["matched"]
        assert json.loads((day / r["folder"] / "log_report.json").read_text())["log"] == name
    assert (day / rep["records"][3]["folder"] / "geo.txt").is_file()  # the photo folder's camera poses
    # the union: every station photographed by anyone counts once; the missing ones are the complement
    photographed = set().union(*map(set, flown.values()))
    whole = rep["day"]
    assert whole["planned"] == len(plan.ids) and whole["photographed"] == len(photographed) == whole["photos"]
    assert whole["missing_stations"] == [plan.ids[i] for i in range(len(plan.ids)) if i not in photographed] \
        == [plan.ids[i] for i in d4]
    repeats = {r["station"]: r for r in whole["repeated_stations"]}
    assert set(repeats) == {plan.ids[i] for i in twice}
    for r in repeats.values():
        assert r["kept"]["record"] == 4 and r["kept"]["distance_m"] == pytest.approx(0.5, abs=0.05)
        assert [(d["record"], round(d["distance_m"], 1)) for d in r["dropped"]] == [(1, 2.0)]
    # per sortie: the union of the records recognised as it, against its stations
    by = {g["sortie"]: g for g in rep["sorties"]}
    assert by["S01"]["records"] == [1, 4] and by["S01"]["missing_stations"] == [] and by["S01"]["photos"] == len(s1)
    assert by["S02"]["records"] == [2] and by["S02"]["missing_stations"] == [plan.ids[i] for i in d2]
    assert by["S03"]["missing_stations"] == [plan.ids[i] for i in s3 if i in d3 or i in d4]

    # compliance: `check DAY` per sortie and whole; the whole is `check` of one flight of the same photos
    (tmp_path / "profiles").mkdir()
    (tmp_path / "profiles" / "day-rules.toml").write_text(PROFILE)
    rules = ("--profile", "day-rules", "--profile-dir", tmp_path / "profiles", "--json")
    code, text = _run("check", day, *rules)
    checked = json.loads(text)
    # the ground under d4 is seen by too few photos, and its line has a hole in the forward overlap
    assert code == 1 and checked["failed"] == ["fwd", "cover"], text
    assert [s["sortie"] for s in checked["sorties"]] == ["S01", "S02", "S03"]
    # one log of the photos the day keeps: those of the photo folder 0.5 m east of their stations
    one = plan.log(tmp_path / "one.bin", [i for i in range(len(plan.ids)) if i in photographed],
                   {i: 0.5 for i in flown["dji_S01"]})
    code, text = _run("log", "ingest", one, "--plan", plan.folder, "-o", tmp_path / "one")
    assert code == 0, text
    code, text = _run("check", tmp_path / "one", *rules)
    single = json.loads(text)
    assert code == 1 and single["failed"] == ["fwd", "cover"]
    assert [(r["rule"], r["status"]) for r in checked["results"]] == [(r["rule"], r["status"]) for r in single["results"]]
    assert _figures(checked["results"]) == pytest.approx(_figures(single["results"]), abs=0.11)  # one decimal shown
    # sortie S01 is whole again with the photo folder: its forward overlap is the plan's; S02's re-fly is no sortie of it
    s01 = {r["rule"]: r["status"] for r in checked["sorties"][0]["results"]}
    s02 = {r["rule"]: r["status"] for r in checked["sorties"][1]["results"]}
    assert s01["fwd"] == "pass" and s02["fwd"] == "fail"
    assert json.loads((day / "failing_places.geojson").read_text())["features"]

    # the one re-fly: over the ground the union leaves short, which is where nobody photographed
    code, text = _run("refly", day, "--plan", plan.folder, "--spec", plan.spec, "-o", tmp_path / "refly")
    assert code == 0, text
    gaps_ll = shapely.from_geojson((tmp_path / "refly" / "gaps.geojson").read_text())
    gaps = shapely.transform(gaps_ll, lambda a: np.column_stack(plan.to_xy.transform(a[:, 0], a[:, 1])))
    gx, gy = ic.grid_inside(gaps, 40)
    assert len(gx) > 20
    # the gaps are ground the day's photos see too few times, and the missing stations' photos would fill
    assert (plan.counts(photographed, gx, gy) < plan.need).mean() > 0.9
    assert (plan.counts(photographed | set(d4), gx, gy) >= plan.need).all()
    # and all such ground is in them: the area's points clearly short of photos lie in the gaps
    area = shapely.from_geojson((plan.spec.parent / "area.geojson").read_text())
    area = shapely.transform(area, lambda a: np.column_stack(plan.to_xy.transform(a[:, 0], a[:, 1])))
    ax, ay = ic.grid_inside(shapely.buffer(area, -10.0), 80)
    short = plan.counts(photographed, ax, ay) < plan.need - 1
    assert short.sum() > 10 and shapely.contains_xy(shapely.buffer(gaps, 5.0), ax[short], ay[short]).all()
    home, rows = ic.read_wpl(tmp_path / "refly" / "mission.waypoints")
    again = ic.replay_triggers(rows, plan.to_xy, None, home[2])
    assert ic.footprint_counts(again, gx, gy, SENSOR, "landscape").min() >= plan.need


def _figures(results: list[dict]) -> list[float]:
    """The numbers of each rule's flown measure, in order."""
    return [float(v) for r in results for v in re.findall(r"-?\d+(?:\.\d+)?", str(r["measured"]))]


def test_a_sortie_flown_twice_partly_counts_each_station_once(plan, tmp_path):
    s2 = plan.sorties["S02"]
    first = plan.log(tmp_path / "S02.bin", s2)
    again = plan.log(tmp_path / "S02-again.bin", s2[: len(s2) // 2], 1.0)
    code, text = _run("log", "ingest", first, again, "--plan", plan.folder, "-o", tmp_path / "day")
    assert code == 0, text
    rep = _report(tmp_path / "day")
    assert [(r["kind"], r["sortie"], r["kept"]) for r in rep["records"]] == [("sortie", "S02", len(s2)), ("sortie", "S02", 0)]
    (g,) = rep["sorties"]
    assert g["records"] == [1, 2] and g["photos"] == g["photographed"] == g["planned"] == len(s2)
    assert [r["station"] for r in g["repeated_stations"]] == [plan.ids[i] for i in s2[: len(s2) // 2]]
    assert all(r["kept"]["record"] == 1 and r["dropped"][0]["record"] == 2 for r in g["repeated_stations"])
    # the day's coverage is the first flight's alone: the repeats add nothing
    code, text = _run("log", "ingest", first, "--plan", plan.folder, "-o", tmp_path / "once")
    assert code == 0, text
    with rasterio.open(tmp_path / "day" / "coverage.tif") as a, rasterio.open(tmp_path / "once" / "coverage.tif") as b:
        assert a.transform == b.transform and np.array_equal(a.read(1), b.read(1))


def test_a_record_of_another_plan_is_refused_by_name(plan, tmp_path):
    far = Plan(tmp_path / "far", "far-field", FAR_RING)
    ours = plan.log(tmp_path / "S01.bin", plan.sorties["S01"])
    theirs = far.log(tmp_path / "far.bin", far.sorties["S01"])
    code, text = _run("log", "ingest", ours, theirs, "--plan", plan.folder, "-o", tmp_path / "day")
    assert code == 2 and text.count("\n") == 1, text
    assert "record 2 of 2 ('far.bin')" in text and "is not of mission 'test'" in text and "more than one footprint" in text
    assert not (tmp_path / "day").exists()


def _items(path: Path) -> list[tuple]:
    """A .waypoints file's items as ArduPilot's CMD messages log them: command, frame (0 for an item
    without a position), param1-4, lat, lon, alt."""
    out = []
    for line in path.read_text().splitlines()[1:]:
        f = line.split("\t")
        out.append((int(f[3]), 0 if int(f[2]) == 2 else int(f[2]), *(float(v) for v in f[4:11])))
    return out


def _mission_log(plan: Plan, path: Path, items: list[tuple], idx: list[int]) -> Path:
    """A log recording a mission (`items`, written at 50 s) and a photo at each station of `idx` after it."""
    photos = [(100.0 + 2.5 * t, plan.rows[i]["lat"], plan.rows[i]["lon"], plan.home + plan.rows[i]["alt_rel_m"],
               plan.rows[i]["alt_rel_m"]) for t, i in enumerate(idx)]
    path.write_bytes(mission_log([(50.0, items)], photos))
    return path


def test_a_log_recording_its_mission_is_that_sortie_and_another_mission_is_refused(plan, tmp_path):
    s2 = plan.sorties["S02"]
    # S02's mission uploaded, but only its first half photographed: the mission names the sortie, not the photos' votes
    named = _mission_log(plan, tmp_path / "S02.bin", _items(plan.folder / "sortie-02.waypoints"), s2[: len(s2) // 3])
    photos = plan.log(tmp_path / "S01.bin", plan.sorties["S01"])
    code, text = _run("log", "ingest", photos, named, "--plan", plan.folder, "-o", tmp_path / "day")
    assert code == 0, text
    rec = _report(tmp_path / "day")["records"]
    assert [(r["sortie"], r["recognised_by"]) for r in rec] == [("S01", "photos"), ("S02", "mission")]
    assert "sortie-02.plan" in rec[1]["recognised"]
    # our photos, but the vehicle was given another plan's mission: refused, exit 1, nothing written
    far = Plan(tmp_path / "far", "far-field", FAR_RING)
    other = _mission_log(plan, tmp_path / "other.bin", _items(far.folder / "sortie-01.waypoints"), s2)
    code, text = _run("log", "ingest", photos, other, "--plan", plan.folder, "-o", tmp_path / "day2")
    assert code == 1 and "record 2 of 2 ('other.bin') refused, nothing written" in text and "another mission" in text, text
    assert not (tmp_path / "day2").exists()


@pytest.mark.parametrize(("damage", "exit_code"), [("garbage", 2), ("cut", 2), ("flipped", 2), ("zeroed", 1)])
def test_a_damaged_record_in_the_middle_is_refused_and_nothing_half_written(plan, tmp_path, damage, exit_code):
    """Unreadable (random bytes, cut after its header, a tenth of its bits flipped): exit 2 as for one
    log; readable but with more lost to damage than `log ingest` accepts (a twentieth zeroed): exit 1."""
    a = plan.log(tmp_path / "S01.bin", plan.sorties["S01"])
    b = plan.log(tmp_path / "S02.bin", plan.sorties["S02"])
    c = plan.log(tmp_path / "S03.bin", plan.sorties["S03"])
    data = bytearray(b.read_bytes())
    if damage == "garbage":
        data = bytearray(np.random.default_rng(1).integers(0, 256, len(data), dtype=np.uint8).tobytes())
    elif damage == "cut":
        data = data[:40]
    elif damage == "flipped":
        rng = np.random.default_rng(2)
        for k in rng.choice(len(data), len(data) // 10, replace=False):
            data[k] ^= 0xFF
    else:
        data[len(data) // 2: len(data) // 2 + len(data) // 20] = bytes(len(data) // 20)
    b.write_bytes(bytes(data))
    day = tmp_path / "day"
    code, _ = _run("log", "ingest", a, c, "--plan", plan.folder, "-o", day)  # a day written before
    assert code == 0
    before = {p.relative_to(day): p.read_bytes() for p in day.rglob("*") if p.is_file()}
    code, text = _run("log", "ingest", a, b, c, "--plan", plan.folder, "-o", day)
    assert code == exit_code and text.count("\n") == 1 and "Traceback" not in text, text
    assert "record 2 of 3 ('S02.bin') refused, nothing written" in text, text
    assert {p.relative_to(day): p.read_bytes() for p in day.rglob("*") if p.is_file()} == before


def test_the_day_report_schema_is_valid_and_documented():
    jsonschema.Draft202012Validator.check_schema(schemas.schema("day_report"))
    doc = (Path(__file__).resolve().parents[2] / "docs" / "flight-logs.md").read_text(encoding="utf-8")
    assert schemas.markdown_table("day_report") in doc


def test_one_record_is_todays_ingest(plan, tmp_path):
    log = plan.log(tmp_path / "S01.bin", plan.sorties["S01"])
    code, text = _run("log", "ingest", log, "--plan", plan.folder, "-o", tmp_path / "o")
    assert code == 0, text
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == [".aerosurvey-output", "coverage.tif", "events.csv",
                                                                  "log_report.json"]


def test_several_records_need_the_plan_and_refuse_one_log_options(plan, tmp_path):
    a = plan.log(tmp_path / "a.bin", plan.sorties["S01"])
    b = plan.log(tmp_path / "b.bin", plan.sorties["S02"])
    code, text = _run("log", "ingest", a, b, "-o", tmp_path / "o")
    assert code == 2 and "give --plan" in text, text
    code, text = _run("log", "ingest", a, b, "--plan", plan.folder, "--sortie", "S01", "-o", tmp_path / "o")
    assert code == 2 and "--sortie" in text and "recognised" in text, text
    assert not (tmp_path / "o").exists()


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_partition_with_dropouts_leaves_missing_the_complement(plan, tmp_path_factory, data):
    """Stations dealt at random to 2-4 records, each dropping some at random (and some dealt twice):
    the day's photographed stations are their union, the missing ones its complement, and its
    coverage that of one flight photographing the union once."""
    from aerosurvey.flight.day import ingest_day
    from aerosurvey.flight.ingest import ingest
    from aerosurvey.rules.planview import PlanView

    n = len(plan.ids)
    k = data.draw(st.integers(2, 4), label="records")
    owner = data.draw(st.lists(st.integers(0, k - 1), min_size=n, max_size=n), label="owner")
    dropped = data.draw(st.lists(st.booleans(), min_size=n, max_size=n), label="dropped")
    twice = data.draw(st.lists(st.integers(0, k - 1), min_size=n, max_size=n), label="also")
    tmp = tmp_path_factory.mktemp("partition")
    paths, sets = [], []
    for r in range(k):
        idx = [i for i in range(n) if (owner[i] == r and not dropped[i]) or (twice[i] == r and owner[i] != r and i % 5 == 0)]
        if not idx:
            idx = [r]  # a record holds at least one photo
        sets.append(set(idx))
        paths.append(plan.log(tmp / f"r{r}.bin", idx))
    day = ingest_day(paths, PlanView.from_outdir(plan.folder, "--plan"))
    union = set().union(*sets)
    assert day.report["day"]["missing_stations"] == [plan.ids[i] for i in range(n) if i not in union]
    assert day.report["day"]["photographed"] == len(union) == day.report["day"]["photos"]
    shared = {i for i in union if sum(i in s for s in sets) > 1}
    assert {r["station"] for r in day.report["day"]["repeated_stations"]} == {plan.ids[i] for i in shared}
    once = ingest(plan.log(tmp / "once.bin", sorted(union)), PlanView.from_outdir(plan.folder, "--plan"))
    assert once.coverage is not None and np.array_equal(day.coverage.counts, once.coverage.counts)
    shutil.rmtree(tmp)
