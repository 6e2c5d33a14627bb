"""Extra photos are extra: triggers on no planned line (in turns, past a line's end, test shots on
the ground) are counted and placed, keep their footprints in the flown coverage, and are never a
run; side overlaps pair neighbouring flown lines, each pair once.

The synthetic flights put a photo on every planned station and the extras where a turn, a line's
end or the ground is (offsets by pyproj's Geod); what each extra's place and neighbours are is
known from how it was made.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pyproj
import pytest
import rasterio
from click.testing import CliRunner
from dfwriter import camera_log

from aerosurvey.cli import main
from aerosurvey.flight.compliance import open_flight
from aerosurvey.rules.footprints import footprints, side_overlaps
from conftest import REPO, make_spec

DATA = Path(__file__).resolve().parents[1] / "data"
GEOD = pyproj.Geod(ellps="WGS84")


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


@pytest.fixture(scope="module")
def copter(tmp_path_factory):
    """A copter plan of 8 north-south lines (heading 0, one flight: no sorties)."""
    tmp = tmp_path_factory.mktemp("extras")
    plan = tmp / "plan"
    assert _run("plan", make_spec(tmp, {"flight": {"heading": 0.0}}), "-o", plan)[0] == 0
    return plan, json.loads((plan / "manifest.json").read_text())


def _fwd(lat: float, lon: float, az: float, dist: float) -> tuple[float, float]:
    lon2, lat2, _ = GEOD.fwd(lon, lat, az, dist)
    return lat2, lon2


def _flight(manifest: dict) -> tuple[list[tuple], dict[int, tuple[str | None, str | None, bool]], int]:
    """(events: time, lat, lon, alt AMSL, rel_alt; the extras by event number: (run before, run
    after, on the ground); the event number of a photo off its line's stations within a run)."""
    st = manifest["stations"]
    runs = list(dict.fromkeys(s["line"] for s in st))
    heading = {ln["id"]: ln["heading_deg"] for ln in manifest["lines"]}
    home = manifest["home"]
    ground = home["ground_amsl_m"]
    alt = st[0]["alt_rel_m"]
    places: list[tuple[float, float, float, tuple[str | None, str | None, bool] | None]] = []
    for _ in range(2):  # test shots on the ground at home
        places.append((home["lat"], home["lon"], 0.3, (None, runs[0], True)))
    inside = -1
    for k, run in enumerate(runs):
        mine = [s for s in st if s["line"] == run]
        for j, s in enumerate(mine):
            places.append((s["lat"], s["lon"], alt, None))
            if k == 1 and j == 5:  # a photo 25 m beside the line between two stations: still the run's
                lat, lon = _fwd((s["lat"] + mine[j + 1]["lat"]) / 2, (s["lon"] + mine[j + 1]["lon"]) / 2, heading[run] + 90, 25)
                places.append((lat, lon, alt, None))
                inside = len(places)
        last, az = mine[-1], heading[run]
        after = runs[k + 1] if k + 1 < len(runs) else None
        places.append((*_fwd(last["lat"], last["lon"], az, 30.0), alt, (run, after, False)))  # past the line's end
        if after is not None:  # halfway across to the next line, 40 m past the end: in the turn
            first = next(s for s in st if s["line"] == after)
            places.append((*_fwd((last["lat"] + first["lat"]) / 2, (last["lon"] + first["lon"]) / 2, az, 40.0), alt,
                           (run, after, False)))
    events = [(100.0 + 2.5 * i, lat, lon, ground + h, h) for i, (lat, lon, h, _) in enumerate(places)]
    extras = {i + 1: what for i, (_, _, _, what) in enumerate(places) if what is not None}
    return events, extras, inside


def _counts(folder: Path) -> np.ndarray:
    with rasterio.open(folder / "coverage.tif") as ds:
        return ds.read(1).astype(int)


def test_extras_are_counted_and_placed_and_never_a_run(copter, tmp_path):
    plan, manifest = copter
    events, extras, inside = _flight(manifest)
    log = tmp_path / "flight.bin"
    log.write_bytes(camera_log(events))
    folder = tmp_path / "log"
    code, out = _run("log", "ingest", log, "--plan", plan, "-o", folder)
    assert code == 0, out
    rep = json.loads((folder / "log_report.json").read_text())
    n_runs = len(manifest["lines"])
    assert len(extras) == 2 + n_runs + (n_runs - 1)
    ex = rep["extras"]
    assert ex["count"] == len(extras) and ex["on_ground"] == 2
    assert [p["event"] for p in ex["photos"]] == sorted(extras)
    for p in ex["photos"]:
        before, after, on_ground = extras[p["event"]]
        _, lat, lon, _, rel = events[p["event"] - 1]
        assert (p["after_run"], p["before_run"], p["on_ground"]) == (before, after, on_ground)
        # the CAM message holds 1e-7 degrees
        assert (p["lat"], p["lon"], p["rel_alt_m"]) == (pytest.approx(lat, abs=6e-8), pytest.approx(lon, abs=6e-8), rel)
    # every station has its photo; the extras and the photo beside its line are matched to none
    assert rep["matched"] == len(manifest["stations"]) and rep["missed_stations"] == []
    assert sorted(i + 1 for i in rep["extra_triggers"]) == sorted([*extras, inside])
    with open(folder / "events.csv", newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    assert {int(r["event"]) for r in rows if not r["station"]} == {*extras, inside}
    assert f"{len(extras)} extra photo(s) on no planned line (2 on the ground)" in out
    # no extra is a run: the flown runs are the planned lines, the photo beside a line is its run's
    flight = open_flight(folder)
    runs = flight.flown.run_ids
    assert {r for r in runs if r is not None} == {ln["id"] for ln in manifest["lines"]}
    assert [i + 1 for i, r in enumerate(runs) if r is None] == sorted(extras)
    assert runs[inside - 1] == manifest["lines"][1]["id"]
    # side overlaps between neighbouring lines only, each pair once, as planned (0.60: spacing over footprint width)
    pairs = side_overlaps(flight.flown, footprints(flight.flown))
    want = 1 - manifest["derived"]["line_spacing_m"] / manifest["derived"]["footprint_across_m"]
    ids = [ln["id"] for ln in manifest["lines"]]
    assert [(a, b) for a, b, _ in pairs] == list(zip(ids, ids[1:]))
    for a, b, v in pairs:  # the photo 25 m beside line 2 moves that line's mean place across by 25 m / its photos
        assert v == pytest.approx(want, abs=0.02 if ids[1] in (a, b) else 0.002)
    # the extras keep their footprints in the flown coverage: the same flight without them counts less
    bare = tmp_path / "bare.bin"
    bare.write_bytes(camera_log([e for i, e in enumerate(events) if i + 1 not in extras]))
    assert _run("log", "ingest", bare, "--plan", plan, "-o", tmp_path / "bare")[0] == 0
    with_extras, without = _counts(folder), _counts(tmp_path / "bare")
    assert (with_extras >= without).all() and with_extras.sum() > without.sum()
    assert json.loads((tmp_path / "bare" / "log_report.json").read_text())["extras"] == {"count": 0, "on_ground": 0, "photos": []}


def test_the_kubad_log_against_todays_plan_pairs_no_extra_with_a_line(tmp_path):
    """Its 19 photos past the line ends of today's plan (which has fewer stations a line) were runs
    of their own, paired with arbitrary lines (flown side overlap -252.3 %): now extras, in no pair."""
    plan = tmp_path / "plan"
    assert _run("plan", REPO / "missions" / "kubad-abad-fixed-wing.toml", "-o", plan)[0] == 0
    folder = tmp_path / "log"
    assert _run("log", "ingest", DATA / "sitl_plane_kubad.bin", "--plan", plan, "-o", folder)[0] == 1  # another mission
    rep = json.loads((folder / "log_report.json").read_text())
    assert rep["extras"]["count"] == len(rep["extra_triggers"]) == 19 and rep["extras"]["on_ground"] == 0
    assert rep["realized"]["side_overlap_min"] > 0.55
    flight = open_flight(folder)
    pairs = side_overlaps(flight.flown, footprints(flight.flown))
    lines = [ln["id"] for ln in json.loads((plan / "manifest.json").read_text())["lines"]]
    assert [(a, b) for a, b, _ in pairs] == list(zip(lines, lines[1:])) and min(v for _, _, v in pairs) > 0.55


def test_the_kubad_log_against_its_own_plan_lists_each_pair_of_lines_once(tmp_path):
    folder = tmp_path / "log"
    assert _run("log", "ingest", DATA / "sitl_plane_kubad.bin", "--plan", DATA / "sitl_plane_kubad_plan", "-o", folder)[0] == 0
    rep = json.loads((folder / "log_report.json").read_text())
    assert rep["extras"]["count"] == 0 and rep["realized"]["side_overlap_min"] > 0.59
    flight = open_flight(folder)
    pairs = side_overlaps(flight.flown, footprints(flight.flown))
    lines = [f"P1-L{k:03d}-R1" for k in range(1, 14)]
    assert [(a, b) for a, b, _ in pairs] == list(zip(lines, lines[1:]))
    code, text = _run("check", folder, "--profile", "cz-land-consolidation", "--json")
    side = next(r for r in json.loads(text)["results"] if r["rule"] == "cz-side-overlap")
    listed = [frozenset(e.split(":")[0].split(" / ")) for e in side["evidence"]]
    assert listed and len(set(listed)) == len(listed)  # the pairs below 60 %, each once
