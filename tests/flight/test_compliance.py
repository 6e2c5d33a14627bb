"""`aerosurvey check FLIGHT_FOLDER`: the plan's rules planned vs flown on the SITL logs of tests/data,
whole and cut short, and the failing places they write.

What the flight broke is worked out here without aerosurvey's footprint code: each control
point is counted against the flown photos of events.csv (read with the csv module, positions
through pyproj) as rectangles of the manifest's planned footprint scaled by the photo's
height above ground and turned to its logged yaw, with half a metre of slack either way.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pyproj
import pytest
from click.testing import CliRunner
from csvrows import event_rows
from hypothesis import given
from hypothesis import strategies as st

from aerosurvey.cli import main
from aerosurvey.flight.coverage import photo_runs
from aerosurvey.flight.dataflash import DataFlashLog
from conftest import make_spec, planned

DATA = Path(__file__).resolve().parents[1] / "data"
COPTER_LOG = DATA / "sitl_copter_survey.bin"
PLANE_LOG = DATA / "sitl_plane_kubad.bin"

# rules the copter plan passes (planned: overlaps 75.1 / 60.0 %, GSD 2.50 cm, 2 photos beyond every crossing,
# 8 photos on every point, each GCP on >= 6 photos, 8 check points on 16.9 ha)
PROFILE = """
[profile]
id = "after-flight"
name = "rules the test plan passes"

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
id = "beyond"
statement = "a photo beyond the boundary at every crossing"
check = "images_beyond_boundary"
source = "test"
params = { min = 1 }

[[rules]]
id = "cover"
statement = "every point of the area on at least 5 photos"
check = "coverage_min_images"
source = "test"
params = { min = 5 }

[[rules]]
id = "gcp-seen"
statement = "each GCP on at least 4 photos"
check = "gcp_visibility"
source = "test"
params = { min_images = 4 }

[[rules]]
id = "cp-density"
statement = "a check point per 3 ha"
check = "check_point_density"
source = "test"
params = { ha_per_point = 3.0 }
"""

GCP_MIN, CP_MIN, COVER_MIN = 4, 2, 5  # the profile's GCP visibility; two photos to measure a check point; coverage
RULES = ["fwd", "side", "gsd", "beyond", "cover", "gcp-seen", "cp-density"]


def _run(*args: str) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


@pytest.fixture(scope="module")
def copter(tmp_path_factory) -> dict[str, Path]:
    """The plan the copter log flew (tests/data/README.md), its control points, the profile folder."""
    tmp = tmp_path_factory.mktemp("copter")
    spec = make_spec(tmp, {"flight": {"heading": 0.0}})
    plan = tmp / "plan"
    assert _run("plan", spec, "-o", plan)[0] == 0
    assert _run("gcp", plan)[0] == 0  # control_points.geojson: the layout both checks read
    profiles = tmp / "profiles"
    profiles.mkdir()
    (profiles / "after-flight.toml").write_text(PROFILE)
    return {"tmp": tmp, "plan": plan, "profiles": profiles}


def _ingest(copter: dict[str, Path], log: Path, name: str) -> Path:
    out = copter["tmp"] / name
    code, output = _run("log", "ingest", log, "--plan", copter["plan"], "-o", out)
    assert code == 0, output
    return out


def _check(copter: dict[str, Path], folder: Path, *more: str) -> tuple[int, dict, str]:
    """check --json and the plain output; both must agree on the exit code."""
    args = ["check", folder, "--profile", "after-flight", "--profile-dir", copter["profiles"], *more]
    code, text = _run(*args)
    jcode, jtext = _run(*args, "--json")
    assert code == jcode, (text, jtext)
    return code, json.loads(jtext), text


def _layer(folder: Path) -> list[dict]:
    return json.loads((folder / "failing_places.geojson").read_text())["features"]


def _control_points(plan: Path) -> list[dict]:
    return json.loads((plan / "control_points.geojson").read_text())["features"]


def _seen(plan: Path, rows: list[dict[str, str]], lon: float, lat: float, slack: float) -> int:
    """Flown photos whose footprint, grown by `slack` metres each side (negative: shrunk), holds the point."""
    m = json.loads((plan / "manifest.json").read_text())
    d = m["derived"]
    to = pyproj.Transformer.from_crs("EPSG:4326", m["crs"]["planning"], always_xy=True)
    px, py = to.transform(lon, lat)
    n = 0
    for r in rows:
        x, y = to.transform(float(r["lon"]), float(r["lat"]))
        k = float(r["agl_m"]) / d["height_agl_m"]
        yaw = math.radians(float(r["yaw"]))
        along = (px - x) * math.sin(yaw) + (py - y) * math.cos(yaw)
        across = (px - x) * math.cos(yaw) - (py - y) * math.sin(yaw)
        n += abs(along) <= d["footprint_along_m"] * k / 2 + slack and abs(across) <= d["footprint_across_m"] * k / 2 + slack
    return n


def _expected_failing(plan: Path, folder: Path, role: str, least: int) -> tuple[set[str], set[str]]:
    """(points that must fail, points that may fail): fewer than `least` photos even with the footprints
    grown by half a metre, and fewer with them shrunk by as much."""
    rows = event_rows(folder / "events.csv")
    must, may = set(), set()
    for f in _control_points(plan):
        if f["properties"]["role"] != role:
            continue
        lon, lat = f["geometry"]["coordinates"]
        if _seen(plan, rows, lon, lat, 0.5) < least:
            must.add(f["properties"]["id"])
        if _seen(plan, rows, lon, lat, -0.5) < least:
            may.add(f["properties"]["id"])
    return must, may


def _check_sample_points(plan: Path, folder: Path, rule: str, least: int) -> list[list[float]]:
    """The sample points where `rule` fails: each seen by fewer than `least` photos even with the footprints shrunk."""
    rows = event_rows(folder / "events.csv")
    pts = [f["geometry"]["coordinates"] for f in _layer(folder) if f["properties"]["rule"] == rule]
    assert pts and all(_seen(plan, rows, lon, lat, -0.5) < least for lon, lat in pts), rule
    return pts


def _failing_points(folder: Path, rule: str) -> set[str]:
    return {f["properties"]["point"] for f in _layer(folder) if f["properties"]["rule"] == rule}


def test_whole_flight_passes_every_rule_it_passed_as_planned(copter):
    folder = _ingest(copter, COPTER_LOG, "whole")
    code, data, text = _check(copter, folder)
    assert code == 0, text
    assert [r["rule"] for r in data["results"]] == RULES
    assert all(r["status"] == "pass" and r["planned"]["status"] == "pass" for r in data["results"]), text
    # one line per rule: planned X / flown Y verdict
    for rule in RULES:
        (line,) = [ln for ln in text.splitlines() if ln.startswith(f"{rule}: ")]
        assert " planned " in f" {line}" and " / flown " in line and " PASS " in line, line
    assert "flat ground assumed" in text and "flat ground assumed" in data["heights"]
    assert _layer(folder) == []
    # GSD from each photo's flown height above home
    agl = max(float(r["agl_m"]) for r in event_rows(folder / "events.csv"))
    assert next(r for r in data["results"] if r["rule"] == "gsd")["measured"] == f"{_gsd_cm(agl):.2f} cm (coarsest photo)"
    # the GCPs are the plan's, each on at least GCP_MIN flown photos by the independent count
    assert _expected_failing(copter["plan"], folder, "gcp", GCP_MIN)[0] == set()


def test_flight_cut_short_fails_the_rules_the_missing_part_breaks_there(copter):
    cut = copter["tmp"] / "cut.bin"
    data = COPTER_LOG.read_bytes()
    cut.write_bytes(data[: len(data) // 2])  # the log ends half way through the flight
    folder = _ingest(copter, cut, "cut")
    code, res, text = _check(copter, folder)
    assert code == 1, text
    status = {r["rule"]: r["status"] for r in res["results"]}
    # what was flown was flown as planned: overlaps and GSD hold
    assert status["fwd"] == status["side"] == status["gsd"] == "pass", text
    assert set(res["failed"]) == {"beyond", "cover", "gcp-seen", "cp-density"}, text
    assert all(r["planned"]["status"] == "pass" for r in res["results"])
    rows = event_rows(folder / "events.csv")
    manifest = json.loads((copter["plan"] / "manifest.json").read_text())
    run_of = {s["id"]: s["line"] for s in manifest["stations"]}
    last_run = run_of[rows[-1]["station"]]
    # the run the log stops on has no photo beyond the boundary where it should leave the area
    beyond = [f for f in _layer(folder) if f["properties"]["rule"] == "beyond"]
    assert last_run in {f["properties"]["run"] for f in beyond}
    line = next(f for f in beyond if f["properties"]["run"] == last_run)["geometry"]
    assert line["type"] == "LineString"
    flown_here = [(float(r["lon"]), float(r["lat"])) for r in rows if run_of[r["station"]] == last_run]
    assert len(line["coordinates"]) == len(flown_here)
    assert max(abs(a - c) + abs(b - d) for (a, b), (c, d) in zip(line["coordinates"], flown_here)) < 1e-6
    # the unflown half: the points of the area there, and its GCPs and check points short of photos, and only they
    last = float(rows[-1]["lon"])
    half_strip = manifest["derived"]["footprint_across_m"] / 2 / (111_320 * math.cos(math.radians(49.4)))  # degrees
    gap = _check_sample_points(copter["plan"], folder, "cover", COVER_MIN)
    assert all(lon < last + half_strip for lon, _ in gap)  # lines are flown from east to west: none in the flown part
    for rule, role, least in (("gcp-seen", "gcp", GCP_MIN), ("cp-density", "check", CP_MIN)):
        must, may = _expected_failing(copter["plan"], folder, role, least)
        assert must, rule
        assert must <= _failing_points(folder, rule) <= may, rule


def _without_photos(log: Path, out: Path, drop) -> Path:
    """A copy of the DataFlash log without the CAM messages whose 0-based number `drop` accepts, byte for byte
    otherwise (the camera took no photo there)."""
    from aerosurvey.flight.dataflash import DataFlashLog

    data = log.read_bytes()
    with DataFlashLog(log) as dfl:
        length = dfl.type_of("CAM").length
        cut = [int(o) for k, o in enumerate(dfl.message_offsets("CAM")) if drop(k)]
    parts, start = [], 0
    for o in cut:
        parts.append(data[start:o])
        start = o + length
    out.write_bytes(b"".join(parts) + data[start:])
    return out


def test_a_line_flown_without_photos_leaves_a_gap_where_it_was(copter):
    """Events removed: the camera took no photo on the fourth line, and only every other one on the second.

    The side overlap rule measures each strip against its nearest parallel strip on each side, so the
    strips on either side of the missing one fail it (their neighbour there is two spacings away);
    the coverage rule finds the gap's ground."""
    manifest = json.loads((copter["plan"] / "manifest.json").read_text())
    runs = list(dict.fromkeys(s["line"] for s in manifest["stations"]))
    run_of_photo = [s["line"] for s in manifest["stations"]]  # the whole log: one photo per station, in order
    second = [k for k, r in enumerate(run_of_photo) if r == runs[1]]
    log = _without_photos(COPTER_LOG, copter["tmp"] / "gaps.bin",
                          lambda k: run_of_photo[k] == runs[3] or (k in second and second.index(k) % 2 == 1))
    folder = _ingest(copter, log, "gaps")
    report = json.loads((folder / "log_report.json").read_text())
    assert report["events"] == 152 - run_of_photo.count(runs[3]) - len(second) // 2
    code, res, text = _check(copter, folder)
    assert code == 1, text
    assert {"fwd", "side", "cover"} <= set(res["failed"]), text
    places = _layer(folder)
    assert {f["properties"]["run"] for f in places if f["properties"]["rule"] == "fwd"} == {runs[1]}
    beside = {r for f in places if f["properties"]["rule"] == "side" for r in f["properties"]["runs"]}
    assert {runs[2], runs[4]} <= beside and runs[3] not in beside
    # two spacings of a 60 % side overlap: about 1 - 2 x (1 - 0.6)
    side = next(r for r in res["results"] if r["rule"] == "side")
    assert float(side["measured"].split(" %")[0]) == pytest.approx(100 * (1 - 2 * (1 - 0.6)), abs=1.5)
    # 2 of the planned forward overlap's 4 photos per point: about 1 - 2 x (1 - 0.751)
    fwd = next(r for r in res["results"] if r["rule"] == "fwd")
    assert float(fwd["measured"].split(" %")[0]) == pytest.approx(100 * (1 - 2 * (1 - 0.751)), abs=1.5)
    # the points short of photos lie where the fourth line was flown without photos
    gap = _check_sample_points(copter["plan"], folder, "cover", COVER_MIN)
    lon4 = np.mean([s["lon"] for s in manifest["stations"] if s["line"] == runs[3]])
    spacing = abs(np.mean([s["lon"] for s in manifest["stations"] if s["line"] == runs[4]]) - lon4)
    assert sum(abs(lon - lon4) < spacing for lon, _ in gap) > 0.8 * len(gap)
    must, may = _expected_failing(copter["plan"], folder, "gcp", GCP_MIN)
    assert must <= _failing_points(folder, "gcp-seen") <= may


@pytest.mark.parametrize("fixed", [False, True])
def test_check_agrees_with_the_rules_log_ingest_ran(copter, fixed):
    """events.csv holds what the flown view needs: the rules give what `log ingest` found in memory,
    also with a camera fixed to the body (the copter pitches up to 30° as it speeds up: its footprints move)."""
    tmp = copter["tmp"] / f"agree-{fixed}"
    tmp.mkdir()
    spec = make_spec(tmp, {"flight": {"heading": 0.0}, "rules": {"profiles": ["cz-land-consolidation"]}})
    plan = tmp / "plan"
    assert planned(*_run("plan", spec, "-o", plan))
    folder = tmp / "log"
    assert _run("log", "ingest", COPTER_LOG, "--plan", plan, "-o", folder, *(["--fixed-camera"] if fixed else []))[0] == 0
    ingested = json.loads((folder / "log_report.json").read_text())["rules_on_flown_data"]
    code, text = _run("check", folder, "--json")
    res = json.loads(text)
    assert [(r["rule"], r["status"], r["measured"]) for r in res["results"]] == \
        [(r["rule"], r["status"], r["measured"]) for r in ingested]
    assert code == (1 if res["failed"] else 0)
    assert ("camera fixed to the body" in res["heights"]) == fixed and "the report does not say" not in res["heights"]


def _positions(coords):
    """The [x, y] positions of a GeoJSON geometry's coordinates, however deeply nested."""
    if coords and isinstance(coords[0], (int, float)):
        yield coords[:2]
        return
    for c in coords:
        yield from _positions(c)


def test_plane_flight_every_failing_rule_has_its_places(tmp_path):
    plan = DATA / "sitl_plane_kubad_plan"  # the plan it flew (tests/data/README.md)
    folder = tmp_path / "log"
    assert _run("log", "ingest", PLANE_LOG, "--plan", plan, "-o", folder)[0] == 0
    code, text = _run("check", folder, "--profile", "cz-land-consolidation", "--json")
    res = json.loads(text)
    assert code == (1 if res["failed"] else 0)
    layer = _layer(folder)
    failing = {r["rule"] for r in res["results"] if r["status"] in ("fail", "warning")}
    assert failing == {f["properties"]["rule"] for f in layer}
    m = json.loads((plan / "manifest.json").read_text())
    lon = [s["lon"] for s in m["stations"]]
    lat = [s["lat"] for s in m["stations"]]
    for f in layer:
        g = f["geometry"]
        if g is None:
            continue
        pts = np.array(list(_positions(g["coordinates"])), float)
        # every place lies by the flown plan (GCPs 10 m outside the outline; photos beside their stations)
        assert (pts[:, 0] > min(lon) - 0.01).all() and (pts[:, 0] < max(lon) + 0.01).all()
        assert (pts[:, 1] > min(lat) - 0.01).all() and (pts[:, 1] < max(lat) + 0.01).all()


def test_the_layer_is_listed_so_the_folder_can_be_ingested_again(copter):
    folder = _ingest(copter, COPTER_LOG, "again")
    _check(copter, folder)
    assert "failing_places.geojson" in (folder / ".aerosurvey-output").read_text().splitlines()
    _ingest(copter, COPTER_LOG, "again")  # replaced whole, not refused for a file of another run
    assert not (folder / "failing_places.geojson").exists()


def test_bad_flight_folders_are_refused_with_one_line(copter, tmp_path):
    plain = tmp_path / "no-plan"
    assert _run("log", "ingest", COPTER_LOG, "-o", plain)[0] == 0
    code, out = _run("check", plain)
    assert code == 2 and "ingested without --plan" in out
    assert not (plain / "failing_places.geojson").exists()
    folder = _ingest(copter, COPTER_LOG, "moved")
    report = json.loads((folder / "log_report.json").read_text())
    report["plan"]["folder"] = str(tmp_path / "gone" / "manifest.json")
    (folder / "log_report.json").write_text(json.dumps(report))
    code, out = _run("check", folder)
    assert code == 2 and "give the plan folder with --plan" in out
    code, out = _run("check", folder, "--plan", copter["plan"], "--profile", "after-flight",
                     "--profile-dir", copter["profiles"])
    assert code == 0, out
    other = tmp_path / "other"
    assert _run("plan", make_spec(tmp_path, {"mission": {"name": "other"}, "flight": {"heading": 0.0}}), "-o", other)[0] == 0
    code, out = _run("check", folder, "--plan", other)
    assert code == 2 and "mission 'other'" in out and len(out.strip().splitlines()) == 1
    code, out = _run("check", copter["plan"], "--plan", copter["plan"])
    assert code == 2 and "is for a flight folder" in out


@given(st.lists(st.sampled_from(["a1", "a2", "b1", None]), max_size=30))
def test_an_extra_trigger_joins_the_run_it_lies_within(stations):
    run_of = {"a1": "A", "a2": "A", "b1": "B"}
    runs = photo_runs(stations, run_of)
    assert len(runs) == len(stations)
    for i, (s, r) in enumerate(zip(stations, runs)):
        if s is not None:
            assert r == run_of[s]
            continue
        before = next((run_of[t] for t in reversed(stations[:i]) if t is not None), None)
        after = next((run_of[t] for t in stations[i + 1:] if t is not None), None)
        assert r == (before if before is not None and before == after else None)  # None: an extra, in no run


def _gsd_cm(agl_m: float) -> float:
    """GSD of the Sony a6000 with its 16 mm lens (23.5 mm over 6000 px) at `agl_m` above ground."""
    return agl_m * (23.5 / 6000) / 16.0 * 100


def test_gsd_is_judged_at_each_photo_from_its_height_above_the_dem(copter):
    """A DEM whose ground falls 8 m from the area's east edge to its west edge: the photos over the low
    ground are farther above it than planned, and their GSD fails there."""
    import rasterio
    from rasterio.transform import from_origin

    dem = copter["tmp"] / "valley.tif"
    res, west, north = 0.0001, 14.99, 49.41
    cols = west + (np.arange(300) + 0.5) * res

    def ground(lon):
        return np.clip(-8.0 * (15.006 - np.asarray(lon)) / 0.006, -8.0, 0.0)

    with rasterio.open(dem, "w", driver="GTiff", width=300, height=200, count=1, dtype="float64", crs="EPSG:4326",
                       transform=from_origin(west, north, res, res)) as ds:
        ds.write(np.tile(ground(cols), (200, 1)), 1)
    folder = copter["tmp"] / "dem"
    code, out = _run("log", "ingest", COPTER_LOG, "--plan", copter["plan"], "--dem", dem, "-o", folder)
    assert code == 0, out
    code, res_, text = _check(copter, folder)
    assert "heights above the DEM valley.tif" in text.splitlines()[1]
    rows = event_rows(folder / "events.csv")
    agl = np.array([float(r["agl_m"]) for r in rows])
    # the heights are above the DEM: the logged altitude less the ground under the photo (bilinear on a ramp)
    lon = np.array([float(r["lon"]) for r in rows])
    assert np.abs(agl - (np.array([float(r["alt_m"]) for r in rows]) - ground(lon))).max() < 0.1
    gsd = next(r for r in res_["results"] if r["rule"] == "gsd")
    assert gsd["planned"]["status"] == "pass" and gsd["status"] == "fail" and code == 1
    assert gsd["measured"] == f"{_gsd_cm(agl.max()):.2f} cm (coarsest photo)"
    failing = {f["properties"]["photo"] for f in _layer(folder) if f["properties"]["rule"] == "gsd"}
    must = {f"E{int(r['event']):05d}" for r, h in zip(rows, agl) if _gsd_cm(h) > 2.6 + 1e-3}
    may = {f"E{int(r['event']):05d}" for r, h in zip(rows, agl) if _gsd_cm(h) > 2.6 - 1e-3}
    assert must and must <= failing <= may and len(must) < len(rows)


def _without(path: Path, name: str) -> bytes:
    """A DataFlash log without its messages of one type, every other message byte for byte in its order."""
    with DataFlashLog(path) as log:
        left_out = log.type_of(name)
        assert left_out is not None
        return b"".join(log.record(o) for o in sorted(o for t, offs in log.offsets.items() if t != left_out.type for o in offs))


def test_a_sortie_is_judged_against_its_own_planned_stations(tmp_path):
    """A log of the first sortie of a plan split by a small battery: the planned side is that sortie's stations."""
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}, "battery": {"usable_min": 6.0}})
    plan = tmp_path / "plan"
    assert _run("plan", spec, "-o", plan)[0] == 0
    manifest = json.loads((plan / "manifest.json").read_text())
    s01 = manifest["sorties"][0]
    ids = [s["id"] for s in manifest["stations"]]
    own = ids[ids.index(s01["first_station"]): ids.index(s01["last_station"]) + 1]
    assert len(manifest["sorties"]) > 1 and len(own) < len(ids)
    log = tmp_path / "s01.bin"
    # the first line and a bit: photos of S01's stations only. The log's CMD messages are left out: they
    # record the whole mission this flight was given, which `log ingest` would take over --sortie S01
    data = _without(COPTER_LOG, "CMD")
    log.write_bytes(data[: int(len(data) * 0.27)])
    folder = tmp_path / "log"
    assert _run("log", "ingest", log, "--plan", plan, "--sortie", s01["id"], "-o", folder)[0] == 0
    profiles = tmp_path / "profiles"
    profiles.mkdir()
    (profiles / "after-flight.toml").write_text(PROFILE)
    code, text = _run("check", folder, "--profile", "after-flight", "--profile-dir", profiles, "--json")
    res = {r["rule"]: r for r in json.loads(text)["results"]}
    whole, _ = _run("check", plan, "--profile", "after-flight", "--profile-dir", profiles, "--json")
    assert whole == 0  # the whole plan passes every rule
    # as planned, the sortie's own stations already leave most of the area short of photos
    assert res["cover"]["planned"]["status"] == "fail"
    photos = len(event_rows(folder / "events.csv"))
    plain = _run("check", folder, "--profile", "after-flight", "--profile-dir", profiles)[1]
    assert plain.splitlines()[0].startswith(f"{photos} flown photos against {len(own)} planned stations of sortie {s01['id']} ")


def test_a_flight_checked_without_a_profile_is_judged_on_the_planners_own_rule(copter):
    """As `check PLAN_FOLDER` does: no profile given, none in the plan's spec: the planner's own
    rule (every point of the area on two photos or more) planned vs flown, and a warning that
    lists the profiles. The whole flight passes it; the flight cut short fails it where no flown
    photo pair sees the ground (the independent count, footprints shrunk by half a metre)."""
    whole = _ingest(copter, COPTER_LOG, "whole-no-profile")
    res = CliRunner().invoke(main, ["check", str(whole)])
    assert res.exit_code == 0, res.output
    assert "no rule profile chosen (none given, none in the plan's spec): only the planner's own rules are checked; " \
           "add --profile ID, one of: asprs-2014, asprs-2023, cz-land-consolidation" in res.stderr
    (line,) = [ln for ln in res.stdout.splitlines() if ln.startswith("uncovered-ground: ")]
    assert " / flown " in line and " PASS (required >= 2 photos on every point of the area)" in line, line
    cut = copter["tmp"] / "cut-no-profile.bin"
    data = COPTER_LOG.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    folder = _ingest(copter, cut, "cut-no-profile")
    res = CliRunner().invoke(main, ["check", str(folder), "--json"])
    assert res.exit_code == 1, res.output
    result = json.loads(res.stdout)
    assert result["failed"] == ["uncovered-ground"] and result["results"][0]["planned"]["status"] == "pass"
    assert result["results"][0]["profile"] == "plan"
    assert _check_sample_points(copter["plan"], folder, "uncovered-ground", 2)
