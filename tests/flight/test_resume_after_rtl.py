"""`aerosurvey resume --log` after a return to launch that kept triggering along the line.

ArduPilot keeps its distance trigger running out of AUTO (CAM_AUTO_ONLY = 0, the default): a
flight switched to RTL mid-line whose way home runs on along the line takes photos near the
next stations, drifting off them. `log ingest` matches those photos to the stations (within
three tolerances); they are not the mission's photos. The logs here are built with the
flight's modes (DataFlash MODE messages, ArduCopter's numbers AUTO 3, RTL 6), the truth is
what the test put in, and the resumed missions' photos are replayed from the exported
.waypoints (tests/independent_coverage.py: ArduPilot's trigger), not taken from the planner.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from csvrows import event_rows
from dfwriter import camera_log, survey_log

import independent_coverage as ic
from aerosurvey.cli import main
from conftest import make_spec

AUTO, RTL, GCS_COMMAND, BATTERY_FAILSAFE = 3, 6, 2, 4
#: the RTL's photos lie this far east of their stations (m): its way home drifts off the line
DRIFT_M = (1.0, 4.0, 8.0, 12.0, 15.0)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """The default 17 ha area flown north-south, one mission: (spec, plan folder, manifest)."""
    tmp = tmp_path_factory.mktemp("plan")
    spec = make_spec(tmp, {"flight": {"heading": 0.0}})
    out = tmp / "plan"
    res = CliRunner().invoke(main, ["plan", str(spec), "-o", str(out)])
    assert res.exit_code == 0, res.output
    return spec, out, json.loads((out / "manifest.json").read_text())


def _east(lat: float, lon: float, metres: float) -> tuple[float, float]:
    return lat, lon + metres / (111_320.0 * math.cos(math.radians(lat)))


def _cut(manifest: dict) -> int:
    """A station in the middle of the third line, with room for the RTL's photos after it on the line."""
    lines = [s["line"] for s in manifest["stations"]]
    third = sorted(set(lines), key=lines.index)[2]
    on = [i for i, line in enumerate(lines) if line == third]
    assert len(on) > 2 * len(DRIFT_M)
    return on[len(on) // 2]


def _flight(manifest: dict, k: int, off: dict[int, float] | None = None) -> list[tuple[float, float, float, float, float]]:
    """Photos at stations 0..k-1 (those in `off` that many metres east), then the RTL's along the line."""
    st = manifest["stations"]
    events = []
    for i in range(k + len(DRIFT_M)):
        metres = (off or {}).get(i, 0.0) if i < k else DRIFT_M[i - k]
        lat, lon = _east(st[i]["lat"], st[i]["lon"], metres)
        events.append((100.0 + 2.0 * i, lat, lon, 400.0, st[i]["alt_rel_m"]))
    return events


def _modes(k: int) -> list[tuple[float, int, int]]:
    return [(90.0, AUTO, GCS_COMMAND), (100.0 + 2.0 * k - 1.0, RTL, BATTERY_FAILSAFE)]


def _ingest_and_resume(tmp: Path, spec: Path, plan: Path, log_bytes: bytes, extra: tuple[str, ...] = ()):
    log = tmp / "flight.bin"
    log.write_bytes(log_bytes)
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), *extra, "-o", str(tmp / "flight")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["resume", str(plan), "--spec", str(spec), "--log", str(tmp / "flight"), "-o", str(tmp / "r")])
    assert res.exit_code == 0, res.output
    return res.output, json.loads((tmp / "r" / "resume.json").read_text())


def _local(manifest: dict):
    st = manifest["stations"]
    to_xy = ic.local_projection(float(np.mean([s["lon"] for s in st])), float(np.mean([s["lat"] for s in st])))
    x, y = to_xy.transform([s["lon"] for s in st], [s["lat"] for s in st])
    return to_xy, np.column_stack([x, y])


def _resumed_photos(folder: Path, to_xy) -> np.ndarray:
    parts = []
    for f in sorted(folder.glob("resume-*.waypoints")):
        home, rows = ic.read_wpl(f)
        p = ic.replay_triggers(rows, to_xy, None, home[2])
        parts.append(np.column_stack([p.x, p.y]))
    return np.concatenate(parts)


def _uncovered(manifest: dict, flown: list[tuple[float, float, float, float, float]], counted: list[bool],
               resumed: Path) -> list[str]:
    """Stations with no photo within the tolerance (a quarter base) among the log's counted photos
    and the resumed missions' photos."""
    to_xy, xy = _local(manifest)
    tol = manifest["derived"]["photo_base_m"] / 4
    fx, fy = to_xy.transform([e[2] for e, c in zip(flown, counted) if c], [e[1] for e, c in zip(flown, counted) if c])
    photos = np.concatenate([np.column_stack([fx, fy]), _resumed_photos(resumed, to_xy)])
    d = np.hypot(xy[:, None, 0] - photos[None, :, 0], xy[:, None, 1] - photos[None, :, 1]).min(axis=1)
    return [s["id"] for s, di in zip(manifest["stations"], d) if di > tol]


def test_a_return_to_launch_along_the_line_is_flown_again(tmp_path, planned):
    spec, plan, manifest = planned
    ids = [s["id"] for s in manifest["stations"]]
    k = _cut(manifest)
    flown = _flight(manifest, k)
    output, doc = _ingest_and_resume(tmp_path, spec, plan, survey_log(flown, _modes(k)))
    rows = event_rows(tmp_path / "flight" / "events.csv")
    # the RTL's photos are matched to the next stations (the trap): that alone would resume after ids[k + 4]
    assert [r["station"] for r in rows[k:]] == ids[k:k + len(DRIFT_M)]
    assert [r["mode"] for r in rows] == ["AUTO"] * k + ["RTL"] * len(DRIFT_M)
    assert doc["from_station"] == ids[k] and doc["stations_done"] == k
    assert doc["stations_left"] == len(ids) - k and doc["sorties"][0]["first_station"] == ids[k]
    assert f"counted as done: {k} photo(s) taken in AUTO within" in output
    assert f"not counted, their stations are flown again: {len(DRIFT_M)} taken in RTL" in output
    assert doc["counted"] == output.splitlines()[:len(doc["counted"])]
    # the union of the flight's AUTO photos and the resumed missions' photos takes every station
    assert _uncovered(manifest, flown, [i < k for i in range(len(flown))], tmp_path / "r") == []


def test_the_last_matched_photo_would_have_skipped_stations(tmp_path, planned):
    """The check above can fail: resumed after the last matched photo (the RTL's), stations are missed."""
    spec, plan, manifest = planned
    ids = [s["id"] for s in manifest["stations"]]
    k = _cut(manifest)
    flown = _flight(manifest, k)
    res = CliRunner().invoke(main, ["resume", str(plan), "--spec", str(spec), "--after", ids[k + len(DRIFT_M) - 1],
                                    "-o", str(tmp_path / "r")])
    assert res.exit_code == 0, res.output
    missed = _uncovered(manifest, flown, [i < k for i in range(len(flown))], tmp_path / "r")
    assert missed == ids[k:k + len(DRIFT_M)]


def test_a_photo_in_auto_too_far_from_its_station_resumes_there(tmp_path, planned):
    """A gust puts one AUTO photo 9 m off its station (tolerance 6.2 m): the flight resumes at
    that station, and the stations photographed after it are flown again."""
    spec, plan, manifest = planned
    ids = [s["id"] for s in manifest["stations"]]
    k = _cut(manifest)
    gust = k - 7
    flown = _flight(manifest, k, {gust: 9.0})
    output, doc = _ingest_and_resume(tmp_path, spec, plan, survey_log(flown, _modes(k)))
    tol = manifest["derived"]["photo_base_m"] / 4
    assert doc["from_station"] == ids[gust] and doc["stations_done"] == k - 1
    assert f"1 farther than {tol:.2f} m from their station (up to 9.0 m)" in output
    assert "6 station(s) after it that were photographed are flown again" in output
    assert _uncovered(manifest, flown, [i < k and i != gust for i in range(len(flown))], tmp_path / "r") == []


def test_a_log_without_modes_counts_photos_by_their_distance_and_says_so(tmp_path, planned):
    """No MODE messages: the RTL's first two photos (1 m and 4 m off, within 6.2 m) cannot be told
    from the mission's and count; the text says why."""
    spec, plan, manifest = planned
    ids = [s["id"] for s in manifest["stations"]]
    k = _cut(manifest)
    flown = _flight(manifest, k)
    output, doc = _ingest_and_resume(tmp_path, spec, plan, camera_log(flown))
    assert {r["mode"] for r in event_rows(tmp_path / "flight" / "events.csv")} == {""}
    assert doc["from_station"] == ids[k + 2]
    assert "the log records no flight modes, so a photo taken out of the mission (in a return to launch) cannot be told" \
        in output
    assert "3 farther than" in output


def test_a_sortie_log_takes_the_sorties_before_it_as_flown(tmp_path):
    spec = make_spec(tmp_path, {"flight": {"heading": 0.0}, "battery": {"usable_min": 6.0}})
    plan = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(spec), "-o", str(plan)]).exit_code == 0
    manifest = json.loads((plan / "manifest.json").read_text())
    ids = [s["id"] for s in manifest["stations"]]
    s02 = manifest["sorties"][1]
    first, last = ids.index(s02["first_station"]), ids.index(s02["last_station"])
    assert last - first >= 15  # the log photographs its first 15 stations: some of S02 is left
    st = manifest["stations"]
    flown = [(100.0 + 2.0 * j, st[i]["lat"], st[i]["lon"], 400.0, st[i]["alt_rel_m"]) for j, i in enumerate(range(first, first + 15))]
    output, doc = _ingest_and_resume(tmp_path, spec, plan, survey_log(flown, [(90.0, AUTO, GCS_COMMAND)]),
                                     ("--sortie", "S02"))
    assert doc["from_station"] == ids[first + 15] and doc["stations_done"] == first + 15
    assert f"the log is of sortie S02: the {first} stations before it are taken as flown" in output


def test_nothing_left_when_every_station_was_photographed_in_auto(tmp_path, planned):
    spec, plan, manifest = planned
    st = manifest["stations"]
    log = tmp_path / "all.bin"
    log.write_bytes(survey_log([(100.0 + i, s["lat"], s["lon"], 400.0, s["alt_rel_m"]) for i, s in enumerate(st)],
                               [(90.0, AUTO, GCS_COMMAND)]))
    res = CliRunner().invoke(main, ["log", "ingest", str(log), "--plan", str(plan), "-o", str(tmp_path / "flight")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["resume", str(plan), "--spec", str(spec), "--log", str(tmp_path / "flight"), "-o",
                                    str(tmp_path / "r")])
    assert res.exit_code == 2 and "nothing is left to fly" in res.output and not (tmp_path / "r").exists()
