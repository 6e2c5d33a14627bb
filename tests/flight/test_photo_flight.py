"""Flights recorded by their photos: `log ingest FOLDER` with DJI photos (and another maker's).

The photos are written by the test's own writer (photowriter.py: EXIF by struct, DJI's drone-dji
XMP as DJI's manuals list it). The plans lie in S-JTSK / Krovak (EPSG:5514), where grid north is
7.4° off true north, and DJI writes the gimbal's yaw as a true bearing. Every expectation here is
computed independently of aerosurvey: true bearings and footprints from geodesics and a local
azimuthal projection (pyproj), overlaps from the camera's sensor and the stations' spacing, the
re-fly's waylines read from the .kmz with lxml.
"""

from __future__ import annotations

import csv
import datetime as dt
import json
import math
import re
import zipfile
from pathlib import Path

import numpy as np
import pyproj
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from lxml import etree
from tests.conftest import make_spec
from tests.flight import photowriter as pw

from aerosurvey.cli import main
from aerosurvey.errors import InputError

GEOD = pyproj.Geod(ellps="WGS84")
CENTRE = (15.05, 49.45)  # Obrataň, where S-JTSK's grid north lies 7.4° west of true north
T0 = dt.datetime(2026, 5, 14, 7, 0, 0, tzinfo=dt.UTC)
#: the Mavic 3E's wide camera (DJI's specifications: 17.3 mm across 5280 px, 3956 px high, f 12.29 mm): its
#: imaging area with square pixels, 3956 rows × 17.3 / 5280 mm high
M3E = {"sensor_mm": (17.3, 3956 * 17.3 / 5280), "focal_mm": 12.29}


def _run(*args: object) -> tuple[int, str]:
    res = CliRunner().invoke(main, [str(a) for a in args])
    return res.exit_code, res.output


def _aeqd(lon: float, lat: float) -> pyproj.Transformer:
    """WGS84 to metres east and north of (lon, lat): an azimuthal equidistant plane."""
    return pyproj.Transformer.from_crs("EPSG:4326", f"+proj=aeqd +lat_0={lat} +lon_0={lon} +datum=WGS84 +units=m",
                                       always_xy=True)


def _square(half_m: float = 200.0) -> list[list[float]]:
    """A square of 2·half_m around CENTRE, its sides east-west and north-south, in lon/lat."""
    back = _aeqd(*CENTRE)
    corners = [(-half_m, -half_m), (half_m, -half_m), (half_m, half_m), (-half_m, half_m), (-half_m, -half_m)]
    return [list(back.transform(x, y, direction="INVERSE")) for x, y in corners]


@pytest.fixture(scope="module")
def dji_plan(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(spec, plan folder with its control points) of a DJI Mavic 3E survey in S-JTSK."""
    tmp = tmp_path_factory.mktemp("dji")
    spec = make_spec(tmp, {"mission": {"name": "dji-photos", "crs": "EPSG:5514"},
                           "camera": {"model": "dji-mavic-3-enterprise"},
                           "targets": {"images_beyond_boundary": 8}, "flight": {"heading": 30.0},
                           "rules": {"profiles": ["cz-land-consolidation"]}}, area=_square())
    plan = tmp / "plan"
    code, text = _run("plan", spec, "-o", plan)
    assert code in (0, 1), text
    code, text = _run("gcp", plan)
    assert code in (0, 1), text
    assert (plan / "mission.kmz").is_file()
    return spec, plan


def _stations(plan: Path) -> dict:
    m = json.loads((plan / "manifest.json").read_text())
    s = m["stations"]
    return {"lon": np.array([r["lon"] for r in s]), "lat": np.array([r["lat"] for r in s]),
            "rel": np.array([r["alt_rel_m"] for r in s]), "line": [r["line"] for r in s],
            "home": float(m["home"]["ground_amsl_m"])}


def _true_courses(s: dict) -> np.ndarray:
    """Each station's direction of flight as a true bearing (0..360): the geodesic azimuth to the
    next station of its line, or from the previous one for a line's last."""
    n = len(s["lon"])
    out = np.zeros(n)
    for i in range(n):
        a, b = (i, i + 1) if i + 1 < n and s["line"][i + 1] == s["line"][i] else (i - 1, i)
        out[i] = GEOD.inv(s["lon"][a], s["lat"][a], s["lon"][b], s["lat"][b])[0] % 360.0
    return out


def _dji_shots(plan: Path, turn_deg: float = 0.0, **fields: object) -> list[pw.Shot]:
    """A perfect DJI flight of the plan: each photo at its station, 2 s apart, the gimbal level
    and looking straight down, its yaw the true course (+ turn_deg) as DJI writes it (−180..180)."""
    s = _stations(plan)
    course = _true_courses(s)
    return [pw.Shot(float(la), float(lo), s["home"] + float(h), float(h), T0 + dt.timedelta(seconds=2 * i),
                    gimbal_yaw=(c + turn_deg + 180.0) % 360.0 - 180.0, flight_yaw=(c + 180.0) % 360.0 - 180.0, **fields)
            for i, (lo, la, h, c) in enumerate(zip(s["lon"], s["lat"], s["rel"], course))]


def _write(folder: Path, shots: list[pw.Shot], maker: str = "dji") -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for i, s in enumerate(shots):
        p = folder / f"DJI_{i + 1:04d}.JPG"
        p.write_bytes(pw.dji_jpeg(s) if maker == "dji" else pw.plain_jpeg(s, direction=s.gimbal_yaw % 360.0))
        out.append(p)
    return out


def _measured(r: dict) -> float:
    return float(re.match(r"\s*(-?[\d.]+)", r["measured"]).group(1))


#: the flown figure of these rules against the planned one: percentage points, centimetres of GSD
AS_PLANNED = {"cz-forward-overlap": 0.5, "cz-side-overlap": 0.5, "cz-gsd": 0.1}


def _check_as_planned(flight: Path) -> None:
    """`check FLIGHT --json`: every rule's verdict flown as planned, the overlaps and GSD within AS_PLANNED,
    and the exit code that of the rules the plan already fails."""
    code, text = _run("check", flight, "--json")
    doc = json.loads(text)
    by_rule = {r["rule"]: r for r in doc["results"]}
    assert set(AS_PLANNED) <= set(by_rule)
    changed = {rule: (r["planned"]["measured"], r["measured"]) for rule, r in by_rule.items() if r["status"] != r["planned"]["status"]}
    assert changed == {}
    for rule, tolerance in AS_PLANNED.items():
        assert _measured(by_rule[rule]) == pytest.approx(_measured(by_rule[rule]["planned"]), abs=tolerance), by_rule[rule]
    failing = sorted(rule for rule, r in by_rule.items() if r["severity"] == "error" and r["status"] == "fail")
    assert (sorted(doc["failed"]), code) == (failing, 1 if failing else 0)


def _coverage_agreement(tif: Path, shots: list[pw.Shot], crs: str) -> tuple[int, int]:
    """(cells of coverage.tif whose count equals an independent count, cells some photo sees): each
    photo a rectangle in a local azimuthal plane, the image's top towards its gimbal's true yaw."""
    import rasterio

    with rasterio.open(tif) as ds:
        counts = ds.read(1)
        rows, cols = np.indices(counts.shape)
        cx, cy = rasterio.transform.xy(ds.transform, rows.ravel(), cols.ravel())
    lon, lat = pyproj.Transformer.from_crs(crs, "EPSG:4326", always_xy=True).transform(np.asarray(cx), np.asarray(cy))
    to_m = _aeqd(*CENTRE)
    ex, ny = to_m.transform(lon, lat)
    mine = np.zeros(len(ex), int)
    sw, sh = M3E["sensor_mm"]
    for s in shots:
        px, py = to_m.transform(s.lon, s.lat)
        across, along = sw * s.rel_alt / M3E["focal_mm"], sh * s.rel_alt / M3E["focal_mm"]
        a = math.radians(s.gimbal_yaw)
        dx, dy = ex - px, ny - py
        right, ahead = dx * math.cos(a) - dy * math.sin(a), dx * math.sin(a) + dy * math.cos(a)
        mine += (np.abs(right) <= across / 2) & (np.abs(ahead) <= along / 2)
    theirs = counts.ravel().astype(int)
    seen = (mine > 0) | (theirs > 0)
    return int(np.sum((mine == theirs) & seen)), int(np.sum(seen))


def test_a_perfect_dji_photo_flight_flies_every_rule_as_planned(tmp_path, dji_plan):
    _, plan = dji_plan
    shots = _dji_shots(plan)
    _write(tmp_path / "DCIM", shots)
    flight = tmp_path / "flown"
    code, text = _run("log", "ingest", tmp_path / "DCIM", "--plan", plan, "-o", flight)
    assert code == 0, text
    assert f"{len(shots)} of {len(shots)} photos are camera events (DJI M3E;" in text
    assert f"RTK: {len(shots)} fixed of {len(shots)} photos recording it (100.0 %)" in text
    rep = json.loads((flight / "log_report.json").read_text())
    assert rep["matched"] == rep["planned"] == len(shots) and rep["max_distance_m"] < 0.01
    assert rep["photos"]["rtk"]["fixed_share"] == 1.0 and rep["photos"]["rtk"]["not_fixed"] == []
    assert rep["photos"]["attitude"]["yaw"] == {"gimbal": len(shots)}
    assert rep["photos"]["event_files"] == [f"DJI_{i + 1:04d}.JPG" for i in range(len(shots))]
    _check_as_planned(flight)
    agree, cells = _coverage_agreement(flight / "coverage.tif", shots, "EPSG:5514")
    assert agree >= 0.98 * cells, (agree, cells)
    # the photos are the events: every camera pose file names them, no geotagging, no matching
    geo = (flight / "geo.txt").read_text().splitlines()
    assert geo[0] == "EPSG:4326" and [ln.split()[0] for ln in geo[1:]] == rep["photos"]["event_files"]
    for ln, s in zip(geo[1:], shots):
        cells_ = ln.split()
        # EXIF holds the seconds of arc to 1e-4 (2.8e-8°), geo.txt 8 decimals
        assert float(cells_[1]) == pytest.approx(s.lon, abs=4e-8) and float(cells_[2]) == pytest.approx(s.lat, abs=4e-8)
        assert float(cells_[3]) == pytest.approx(s.abs_alt, abs=1e-3)
        assert float(cells_[4]) == pytest.approx(s.gimbal_yaw % 360.0, abs=0.01)  # ODM's yaw: the camera's, true north
        assert float(cells_[5]) == pytest.approx(0.0, abs=0.01)  # ODM's pitch: 90 + the gimbal's (−90: straight down)


def test_the_camera_is_where_the_gimbal_looked_not_where_the_plan_aimed(tmp_path, dji_plan):
    """Every photo at its station, but the gimbal turned 90° from the course (DJI writes the gimbal's
    true yaw): the flown coverage is that of the turned images, counted independently, and not
    that of images along the course the plan aimed them."""
    _, plan = dji_plan
    shots = _dji_shots(plan, turn_deg=90.0)
    _write(tmp_path / "DCIM", shots)
    code, text = _run("log", "ingest", tmp_path / "DCIM", "--plan", plan, "-o", tmp_path / "flown")
    assert code in (0, 1), text
    agree, cells = _coverage_agreement(tmp_path / "flown" / "coverage.tif", shots, "EPSG:5514")
    assert agree >= 0.98 * cells, (agree, cells)
    along_course = [pw.Shot(**{**vars(s), "gimbal_yaw": s.flight_yaw}) for s in shots]
    agree, cells = _coverage_agreement(tmp_path / "flown" / "coverage.tif", along_course, "EPSG:5514")
    assert agree < 0.8 * cells, (agree, cells)
    # check FOLDER reads the recorded attitude back from events.csv: the GCPs are seen as the turned images see them
    code, text = _run("check", tmp_path / "flown", "--json")
    results = {r["rule"]: r for r in json.loads(text)["results"]}
    ingested = {r["rule"]: r for r in json.loads((tmp_path / "flown" / "log_report.json").read_text())["rules_on_flown_data"]}
    assert results["cz-gcp-visibility"]["measured"] == ingested["cz-gcp-visibility"]["measured"]
    assert _measured(results["cz-gcp-visibility"]) < _measured(results["cz-gcp-visibility"]["planned"])


def _rtk_shots(plan: Path) -> list[pw.Shot]:
    shots = _dji_shots(plan)
    for i, s in enumerate(shots):
        s.rtk_std = (0.01 + 0.001 * (i % 7), 0.012 + 0.001 * (i % 5), 0.02 + 0.002 * (i % 3))
        if i % 10 == 3:
            s.rtk_flag, s.rtk_std = 16, (1.2 + 0.01 * i, 0.9, 2.5)
        elif i % 10 == 7:
            s.rtk_flag, s.rtk_std = 34, (0.21, 0.35 + 0.001 * i, 0.6)
        elif i % 25 == 11:
            s.rtk_std = None  # no accuracy recorded: the defaults
    return shots


def test_photos_without_a_fixed_solution_are_flagged_and_carry_their_own_accuracy(tmp_path, dji_plan):
    _, plan = dji_plan
    shots = _rtk_shots(plan)
    _write(tmp_path / "DCIM", shots)
    code, text = _run("log", "ingest", tmp_path / "DCIM", "--plan", plan, "--accuracy-xy", 0.5, "--accuracy-z", 0.8,
                      "-o", tmp_path / "flown")
    assert code in (0, 1), text
    single = [i for i, s in enumerate(shots) if s.rtk_flag == 16]
    floating = [i for i, s in enumerate(shots) if s.rtk_flag == 34]
    fixed = len(shots) - len(single) - len(floating)
    rtk = json.loads((tmp_path / "flown" / "log_report.json").read_text())["photos"]["rtk"]
    assert (rtk["fixed"], rtk["single"], rtk["float"], rtk["none"], rtk["not recorded"]) == (fixed, len(single), len(floating), 0, 0)
    assert rtk["fixed_share"] == pytest.approx(fixed / len(shots), abs=1e-6)
    flagged = {(f["file"], f["event"], f["flag"], f["solution"]) for f in rtk["not_fixed"]}
    assert flagged == {(f"DJI_{i + 1:04d}.JPG", i + 1, 16, "single") for i in single} | \
                      {(f"DJI_{i + 1:04d}.JPG", i + 1, 34, "float") for i in floating}
    assert f"RTK: {fixed} fixed of {len(shots)} photos recording it ({100 * fixed / len(shots):.1f} %); not fixed: " \
           f"DJI_{single[0] + 1:04d}.JPG (single 16)" in text
    # each photo's accuracy: DJI's standard deviations, the larger horizontal one for ODM and Pix4D,
    # east and north apart for Metashape; the defaults where the photo recorded none
    geo = {ln.split()[0]: ln.split()[1:] for ln in (tmp_path / "flown" / "geo.txt").read_text().splitlines()[1:]}
    pix4d = {r[0]: r[1:] for r in csv.reader((tmp_path / "flown" / "pix4d_geolocation.csv").read_text().splitlines()[1:])}
    meta = {r[0]: r[1:] for r in csv.reader((tmp_path / "flown" / "metashape_reference.csv").read_text().splitlines()[1:])}
    for i, s in enumerate(shots):
        name = f"DJI_{i + 1:04d}.JPG"
        e, n, u = s.rtk_std if s.rtk_std is not None else (0.5, 0.5, 0.8)
        assert [float(v) for v in geo[name][6:8]] == pytest.approx([max(e, n), u], rel=1e-5), name
        assert [float(v) for v in pix4d[name][6:8]] == pytest.approx([max(e, n), u], rel=1e-5), name
        assert [float(v) for v in meta[name][6:9]] == pytest.approx([e, n, u], rel=1e-5), name


# ---- damaged photos -------------------------------------------------------------------------------

def _line_shots(n: int = 24, maker: str = "DJI") -> list[pw.Shot]:
    """A straight line flown north-east at 10 m/s, a photo each 2 s (no plan needed)."""
    out = []
    for i in range(n):
        lon, lat, _ = GEOD.fwd(CENTRE[0], CENTRE[1], 45.0, 20.0 * i)
        out.append(pw.Shot(lat, lon, 480.0 + 0.1 * i, 100.0 + 0.1 * i, T0 + dt.timedelta(seconds=2 * i), gimbal_yaw=45.0,
                           gimbal_pitch=-89.5, gimbal_roll=0.3, make=maker))
    return out


def _xmp_swap(data: bytes, field: str, value: str) -> bytes:
    return re.sub(rf'drone-dji:{field}="[^"]*"'.encode(), f'drone-dji:{field}="{value}"'.encode(), data, count=1)


def _without_segment(data: bytes, prefix: bytes) -> bytes:
    """The JPEG without its APP1 segment whose payload starts with `prefix`."""
    at = data.index(b"\xff\xe1" + data[data.index(prefix) - 2:data.index(prefix)] + prefix)
    length = int.from_bytes(data[at + 2:at + 4], "big")
    return data[:at] + data[at + 2 + length:]


def _damaged_folder(folder: Path) -> tuple[list[pw.Shot], dict[str, str]]:
    """A line of 24 good photos and, among them, one damaged file of each kind: name -> reason category."""
    shots = _line_shots()
    _write(folder, shots)
    good = (folder / "DJI_0005.JPG").read_bytes()
    s = pw.Shot(**{**vars(shots[4])})
    damaged: dict[str, tuple[bytes, str]] = {
        "cut_in_image.JPG": (good[:-3], "cut off"),
        "cut_in_exif.JPG": (good[:60], "unreadable"),
        "not_a_photo.JPG": (b"this is a note, not a photo\n", "unreadable"),
        "empty.JPG": (b"", "unreadable"),
        "no_gps.JPG": (pw.jpeg(pw.tiff(*pw.exif_fields(s)[:2], None), pw.xmp_packet(
            {k: v for k, v in pw.dji_fields(s).items() if not k.startswith("Gps")})), "no position"),
        "zero_position.JPG": (pw.dji_jpeg(pw.Shot(**{**vars(s), "lat": 0.0, "lon": 0.0})), "no position"),
        "xmp_not_xml.JPG": (good.replace(b"</rdf:RDF>", b"</rdf:RDX>"), "bad field"),
        "yaw_nan.JPG": (_xmp_swap(good, "GimbalYawDegree", "nan"), "bad field"),
        "yaw_606.JPG": (_xmp_swap(good, "GimbalYawDegree", "+606.00"), "bad field"),
        "alt_3838km.JPG": (_xmp_swap(good, "AbsoluteAltitude", "+3838000.0"), "bad field"),
        "rtk_77.JPG": (_xmp_swap(good, "RtkFlag", "77"), "bad field"),
        "std_negative.JPG": (_xmp_swap(good, "RtkStdHgt", "-0.02"), "bad field"),
        "exif_xmp_apart.JPG": (pw.dji_jpeg(pw.Shot(**{**vars(s), "xmp_position": True,
                                                       "extra_fields": {"GpsLatitude": f"{s.lat + 0.0005:+.10f}"}})),
                               "EXIF and XMP disagree"),
        "no_time.JPG": (pw.jpeg(pw.tiff(pw.exif_fields(s)[0], [], pw.exif_fields(s, gps_time=False)[2]),
                                pw.xmp_packet(pw.dji_fields(s))), "no capture time"),
        "xmp_lost.JPG": (_without_segment(good, b"http://ns.adobe.com/xap/1.0/\0"), "DJI XMP missing"),
        "copy_of_0005.JPG": (good, "repeat"),
        "far_away.JPG": (pw.dji_jpeg(pw.Shot(**{**vars(shots[10]), "lat": s.lat + 0.05,
                                              "when": shots[10].when + dt.timedelta(seconds=1)})), "off the flight"),
        # photo 5's place with a time 32.5 s later: where the line had flown on 325 m at 10 m/s
        "time_off.JPG": (pw.dji_jpeg(pw.Shot(**{**vars(s), "when": shots[20].when + dt.timedelta(seconds=0.5)})),
                         "off the flight"),
        "alt_300m_off.JPG": (pw.dji_jpeg(pw.Shot(**{**vars(shots[12]), "abs_alt": shots[12].abs_alt + 300.0,
                                                  "when": shots[12].when + dt.timedelta(seconds=1)})), "off the flight"),
        "home_off.JPG": (pw.dji_jpeg(pw.Shot(**{**vars(shots[16]), "rel_alt": shots[16].rel_alt - 35.0,
                                              "when": shots[16].when + dt.timedelta(seconds=1)})), "off the take-off height"),
    }
    for name, (data, _) in damaged.items():
        (folder / name).write_bytes(data)
    (folder / "DJI_0001.MRK").write_text("1\t0.000\n")  # a DJI timestamp file: not a photo, not read
    return shots, {name: why for name, (_, why) in damaged.items()}


def test_damaged_photos_are_skipped_each_with_its_reason(tmp_path):
    shots, expected = _damaged_folder(tmp_path / "DCIM")
    code, text = _run("log", "ingest", tmp_path / "DCIM", "-o", tmp_path / "out")
    # most of the files are damaged: the outputs are written, and the command fails with the counts
    assert code == 1, text
    assert "camera events dropped as implausible" in text.splitlines()[-1]
    rep = json.loads((tmp_path / "out" / "log_report.json").read_text())
    p = rep["photos"]
    assert (p["files"], p["other_files"], p["used"]) == (len(shots) + len(expected), 1, len(shots))
    counts: dict[str, int] = {}
    for why in expected.values():
        counts[why] = counts.get(why, 0) + 1
    assert p["skipped"] == counts
    reasons = {s["reason"].split(":", 1)[0]: s for s in rep["read"]["skipped"]}
    assert set(reasons) == set(expected)
    assert rep["read"]["skipped_places"] == rep["read"]["dropped_events"] == len(expected)
    assert all(reasons[n]["kind"] == {"cut off": "damage", "unreadable": "damage", "repeat": "repeat"}.get(w, "event")
               for n, w in expected.items())
    # every photo kept is a good one, every field as written
    from aerosurvey.flight.records import read_events_csv

    ev = read_events_csv(tmp_path / "out" / "events.csv")
    assert p["event_files"] == [f"DJI_{i + 1:04d}.JPG" for i in range(len(shots))]
    for i, s in enumerate(shots):
        assert (ev.lat[i], ev.lon[i]) == (pytest.approx(s.lat, abs=4e-8), pytest.approx(s.lon, abs=4e-8))  # EXIF: 1e-4"
        assert (ev.alt_m[i], ev.rel_alt_m[i]) == (pytest.approx(s.abs_alt, abs=0.005), pytest.approx(s.rel_alt, abs=0.005))
        assert (ev.yaw[i], ev.pitch[i], ev.roll[i]) == (pytest.approx(45.0), pytest.approx(-89.5), pytest.approx(0.3))
        assert np.isnan(ev.time_s[i])  # a photo has no autopilot boot time


def test_a_folder_without_a_usable_photo_is_one_line(tmp_path):
    (tmp_path / "none").mkdir()
    (tmp_path / "none" / "README.txt").write_text("flight notes")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "DJI_0001.JPG").write_bytes(b"not a photo")
    (tmp_path / "bad" / "DJI_0002.JPG").write_bytes(pw.dji_jpeg(_line_shots(1)[0])[:-2])
    for folder, expected in [(tmp_path / "none", "no photos in it (.jpg, .jpeg, .tif, .tiff), 1 other file(s)"),
                             (tmp_path / "bad", "none of its 2 photos is usable (1 unreadable, e.g. DJI_0001.JPG: not a "
                                                "readable image (UnidentifiedImageError: cannot identify image file 'DJI_0001.JPG'))"),
                             (tmp_path / "missing", "does not exist")]:
        code, text = _run("log", "ingest", folder, "-o", tmp_path / "out")
        assert code == 2, text
        assert len(text.strip().splitlines()) == 1 and expected in text, text


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_random_damage_never_raises_nor_returns_an_impossible_photo(tmp_path_factory, data):
    """Photos cut off anywhere or with random bytes over their metadata: the reader raises nothing
    but a one-line InputError, every intact photo comes back exactly, and every photo it returns
    lies on the flight (within reach of the line at 10 m/s) with its fields within their bounds."""
    from aerosurvey.flight.photos import read_photo_flight

    folder = tmp_path_factory.mktemp("damage")
    shots = _line_shots(16)
    paths = _write(folder, shots)
    hurt = set()
    for _ in range(data.draw(st.integers(1, 6))):
        k = data.draw(st.integers(0, len(paths) - 1))
        raw = bytearray(paths[k].read_bytes())
        if not raw:
            continue  # cut to nothing by an earlier draw
        meta_end = len(raw) - len(pw.TINY_IMAGE)
        if data.draw(st.booleans()) or meta_end < 4:
            raw = raw[:data.draw(st.integers(0, len(raw) - 1))]
        else:
            at = data.draw(st.integers(2, meta_end - 1))
            junk = data.draw(st.binary(min_size=1, max_size=48))
            raw[at:at + len(junk)] = junk
        paths[k].write_bytes(bytes(raw))
        hurt.add(k)
    try:
        flight = read_photo_flight(folder)
    except InputError as exc:
        assert "\n" not in str(exc)
        return
    names = [f.name for f in flight.files]
    ev = flight.events
    for i in set(range(len(shots))) - hurt:
        j = names.index(paths[i].name)
        assert (ev.lat[j], ev.lon[j], ev.alt_m[j]) == (pytest.approx(shots[i].lat, abs=3e-8),  # EXIF: 1e-4"
                                                       pytest.approx(shots[i].lon, abs=3e-8), pytest.approx(shots[i].abs_alt))
    to_m = _aeqd(*CENTRE)
    x, y = to_m.transform(ev.lon, ev.lat)
    along = (np.asarray(x) + np.asarray(y)) / math.sqrt(2)
    across = (np.asarray(x) - np.asarray(y)) / math.sqrt(2)
    assert np.all(np.abs(across) < 1000) and np.all((along > -1000) & (along < 20 * len(shots) + 1000))
    assert np.all((ev.alt_m > 480 - 500) & (ev.alt_m < 482 + 500))
    assert np.all((ev.yaw >= 0) & (ev.yaw < 360)) and np.all(np.abs(ev.pitch) <= 180) and np.all(np.abs(ev.roll) <= 180)
    flags = flight.rtk_flag[np.isfinite(flight.rtk_flag)]
    assert np.all((flags >= 0) & (flags <= 50) & (flags == np.round(flags)))
    for a in (flight.std_lon_m, flight.std_lat_m, flight.std_hgt_m):
        assert np.all(a[np.isfinite(a)] >= 0)


# ---- the reader on each layout --------------------------------------------------------------------

def test_the_xmp_forms_and_fields_dji_writes(tmp_path):
    """Attributes or elements give the same; XMP GpsLatitude/GpsLongtitude (full precision, DJI's
    spelling on some firmware) win over EXIF's rationals within a metre; a photo without
    DateTimeOriginal takes its GPS time on the camera clock; OffsetTimeOriginal moves to UTC."""
    from aerosurvey.flight.photos import read_photo_flight

    shots = _line_shots(6)
    a, b = tmp_path / "attributes", tmp_path / "elements"
    _write(a, shots)
    b.mkdir()
    for i, s in enumerate(shots):
        (b / f"DJI_{i + 1:04d}.JPG").write_bytes(pw.dji_jpeg(s, elements=True))
    fa, fb = read_photo_flight(a), read_photo_flight(b)
    for name in ("lat", "lon", "alt_m", "rel_alt_m", "roll", "pitch", "yaw"):
        assert np.array_equal(getattr(fa.events, name), getattr(fb.events, name)), name
    assert np.array_equal(fa.rtk_flag, fb.rtk_flag) and np.array_equal(fa.std_hgt_m, fb.std_hgt_m)
    # XMP position: 1e-10° where EXIF holds 1e-4"; one photo spells the longitude DJI's other way
    c = tmp_path / "xmp-position"
    c.mkdir()
    for i, s in enumerate(shots):
        fine = pw.Shot(**{**vars(s), "lat": s.lat + 1.23e-9, "lon": s.lon - 2.5e-9, "xmp_position": i != 2})
        if i == 2:
            fine.extra_fields = {"GpsLatitude": f"{fine.lat:+.10f}", "GpsLongtitude": f"{fine.lon:+.10f}"}
        (c / f"DJI_{i + 1:04d}.JPG").write_bytes(pw.dji_jpeg(fine))
    fc = read_photo_flight(c)
    assert np.allclose(fc.events.lat, [s.lat + 1.23e-9 for s in shots], atol=6e-11, rtol=0)  # XMP: 10 decimals
    assert np.allclose(fc.events.lon, [s.lon - 2.5e-9 for s in shots], atol=6e-11, rtol=0)
    # clocks: photo 3 has no DateTimeOriginal (its GPS time, the camera 2 h ahead of UTC), all write OffsetTimeOriginal
    d = tmp_path / "clocks"
    d.mkdir()
    for i, s in enumerate(shots):
        ifd0, exif, gps = pw.exif_fields(s)
        local = s.when + dt.timedelta(hours=2)
        exif = [] if i == 3 else [(0x9003, pw.ASCII, local.strftime("%Y:%m:%d %H:%M:%S")),
                                  (0x9291, pw.ASCII, f"{local.microsecond // 1000:03d}"), (0x9011, pw.ASCII, "+02:00")]
        (d / f"IMG_{i + 1:04d}.JPG").write_bytes(pw.jpeg(pw.tiff(ifd0, exif, gps), pw.xmp_packet(pw.dji_fields(s))))
    fd = read_photo_flight(d)
    assert np.allclose(fd.capture_s, [s.when.timestamp() for s in shots], atol=1e-3)
    assert [f.name for f in fd.files] == [f"IMG_{i + 1:04d}.JPG" for i in range(6)]


def test_another_makers_photos_southern_and_western_below_sea_level(tmp_path):
    """Big-endian EXIF, S and W references, an altitude below sea level (GPSAltitudeRef 1), no XMP:
    the yaw from GPSImgDirection (true north) where written, else the direction of flight; the
    pitch straight down; no height above take-off."""
    from aerosurvey.flight.photos import read_photo_flight

    shots = []
    for i in range(8):
        lon, lat, _ = GEOD.fwd(-70.6, -33.4, 120.0, 25.0 * i)
        shots.append(pw.Shot(lat, lon, -12.5 + 0.01 * i, 0.0, T0 + dt.timedelta(seconds=3 * i), gimbal_yaw=118.5,
                             make="NIKON CORPORATION", model="NIKON Z 7"))
    folder = tmp_path / "nikon"
    folder.mkdir()
    for i, s in enumerate(shots):
        (folder / f"DSC_{i + 1:04d}.JPG").write_bytes(pw.plain_jpeg(s, direction=None if i >= 4 else 118.5))
    f = read_photo_flight(folder)
    assert np.allclose(f.events.lat, [s.lat for s in shots], atol=3e-8) and np.all(f.events.lat < 0)  # EXIF: 1e-4"
    assert np.allclose(f.events.lon, [s.lon for s in shots], atol=3e-8) and np.all(f.events.lon < 0)
    assert np.allclose(f.events.alt_m, [s.abs_alt for s in shots], atol=1e-6)
    assert np.all(np.isnan(f.events.rel_alt_m)) and np.all(f.events.pitch == -90.0)
    assert np.allclose(f.events.yaw[:4], 118.5)
    course = GEOD.inv(shots[4].lon, shots[4].lat, shots[5].lon, shots[5].lat)[0] % 360.0
    assert np.allclose(f.events.yaw[4:], course, atol=0.01)
    assert f.report["attitude"] == {"yaw": {"exif direction": 4, "track": 4},
                                    "pitch": {"gimbal": 0, "straight down assumed": 8}}
    assert f.report["cameras"] == ["NIKON CORPORATION NIKON Z 7"] and f.report["rtk"]["fixed_share"] is None


def test_another_makers_flight_needs_the_ground_and_then_flies_as_planned(tmp_path):
    """A camera that records its altitude but no height above take-off, on a plan in S-JTSK: without
    --dem one line names it; with a flat DEM its heights above ground are its altitude minus the
    ground, and every rule is flown as planned."""
    import rasterio
    from rasterio.transform import from_origin

    spec = make_spec(tmp_path, {"mission": {"name": "sony", "crs": "EPSG:5514"}, "targets": {"images_beyond_boundary": 8},
                                "flight": {"heading": 30.0}, "rules": {"profiles": ["cz-land-consolidation"]}},
                     area=_square(150.0))
    plan = tmp_path / "plan"
    assert _run("plan", spec, "-o", plan)[0] in (0, 1)
    assert _run("gcp", plan)[0] in (0, 1)
    ground = 512.0
    dem = tmp_path / "flat.tif"
    with rasterio.open(dem, "w", driver="GTiff", width=40, height=40, count=1, dtype="float32", crs="EPSG:4326",
                       transform=from_origin(CENTRE[0] - 0.02, CENTRE[1] + 0.02, 0.001, 0.001)) as ds:
        ds.write(np.full((1, 40, 40), ground, "float32"))
    s = _stations(plan)
    course = _true_courses(s)
    shots = [pw.Shot(float(la), float(lo), ground + float(h), 0.0, T0 + dt.timedelta(seconds=2 * i), gimbal_yaw=float(c),
                     make="SONY", model="ILCE-6000")
             for i, (lo, la, h, c) in enumerate(zip(s["lon"], s["lat"], s["rel"], course))]
    _write(tmp_path / "DCIM", shots, maker="sony")
    code, text = _run("log", "ingest", tmp_path / "DCIM", "--plan", plan, "-o", tmp_path / "flown")
    assert code == 2 and f"{len(shots)} of the {len(shots)} photos" in text and "give --dem" in text, text
    code, text = _run("log", "ingest", tmp_path / "DCIM", "--plan", plan, "--dem", dem, "-o", tmp_path / "flown")
    assert code == 0, text
    rep = json.loads((tmp_path / "flown" / "log_report.json").read_text())
    assert rep["photos"]["rel_alt_from_dem_at_home"] == len(shots)
    _check_as_planned(tmp_path / "flown")


def test_options_that_do_not_apply_to_a_photo_flight_are_refused(tmp_path):
    _write(tmp_path / "DCIM", _line_shots(3))
    for extra, key in [(["--images", tmp_path / "DCIM"], "--images"), (["--fixed-camera"], "--fixed-camera"),
                       (["--geotag-copies", tmp_path / "tagged"], "--geotag-copies")]:
        code, text = _run("log", "ingest", tmp_path / "DCIM", *extra, "-o", tmp_path / "out")
        assert code == 2 and key in text and len(text.strip().splitlines()) == 1, text


# ---- a re-fly for the DJI aircraft ----------------------------------------------------------------

def test_a_refly_of_a_dji_photo_flight_is_dji_waylines_over_the_gap(tmp_path, dji_plan):
    """The photos of one line lost: the re-fly from the photo flight's folder is a .kmz for the
    M3E (WPML: droneEnumValue 77, payloadEnumValue 66, as DJI's reference lists them) whose
    waylines pass over every lost station."""
    spec, plan = dji_plan
    shots = _dji_shots(plan)
    s = _stations(plan)
    lost_line = list(dict.fromkeys(s["line"]))[3]
    kept = [sh for sh, ln in zip(shots, s["line"]) if ln != lost_line]
    _write(tmp_path / "DCIM", kept)
    code, text = _run("log", "ingest", tmp_path / "DCIM", "--plan", plan, "-o", tmp_path / "flown")
    assert code in (0, 1), text
    code, text = _run("refly", tmp_path / "flown", "--plan", plan, "--spec", spec, "-o", tmp_path / "refly")
    assert code == 0, text
    assert "mission.kmz" in text
    with zipfile.ZipFile(tmp_path / "refly" / "mission.kmz") as z:
        wpml = etree.fromstring(z.read("wpmz/waylines.wpml"))
    ns = {"k": "http://www.opengis.net/kml/2.2", "w": wpml.nsmap["wpml"]}
    assert wpml.findtext(".//w:droneEnumValue", namespaces=ns) == "77"
    assert wpml.findtext(".//w:payloadEnumValue", namespaces=ns) == "66"
    pts = [tuple(float(v) for v in pm.findtext(".//k:coordinates", namespaces=ns).split(",")[:2])
           for pm in wpml.findall(".//k:Placemark", ns)]
    assert len(pts) >= 2
    # each lost station lies within half a line spacing of the re-fly's wayline (a local plane)
    to_m = _aeqd(*CENTRE)
    wx, wy = (np.asarray(v) for v in to_m.transform([p[0] for p in pts], [p[1] for p in pts]))
    lost = [i for i, ln in enumerate(s["line"]) if ln == lost_line]
    lx, ly = to_m.transform(s["lon"][lost], s["lat"][lost])
    import shapely

    route = shapely.LineString(np.column_stack([wx, wy]))
    half_width = 0.5 * M3E["sensor_mm"][0] * float(np.median(s["rel"])) / M3E["focal_mm"]  # the image's ground half width
    for x, y in zip(lx, ly):
        assert route.distance(shapely.Point(x, y)) < half_width


def test_a_smart_oblique_look_not_photographed_is_the_look_missed(tmp_path):
    """A DJI smart oblique (five looks at each station: nadir, four at −45°) flown by its photos in S-JTSK, one
    look of one station not taken: that look is the station missed, and every other photo is matched to the look
    its gimbal recorded (not to the next look in flight order). The stations' true bearings are worked here from
    the manifest's grid bearings (a point a metre along each, taken to WGS84 by pyproj, its geodesic azimuth)."""
    spec = make_spec(tmp_path, {"mission": {"name": "smart", "crs": "EPSG:5514"}, "pattern": {"kind": "smart-oblique"},
                                "camera": {"model": "dji-mavic-3-enterprise", "trigger": "hover"}},
                     area=_square(60.0))
    plan = tmp_path / "plan"
    code, text = _run("plan", spec, "-o", plan)
    assert code in (0, 1), text
    m = json.loads((plan / "manifest.json").read_text())
    st = m["stations"]
    to_wgs = pyproj.Transformer.from_crs("EPSG:5514", "EPSG:4326", always_xy=True)
    shots, ids = [], []
    for i, s in enumerate(st):
        b = math.radians(s["camera_yaw_deg"])
        lon2, lat2 = to_wgs.transform(s["x"] + math.sin(b), s["y"] + math.cos(b))
        true = GEOD.inv(s["lon"], s["lat"], lon2, lat2)[0]
        shots.append(pw.Shot(s["lat"], s["lon"], m["home"]["ground_amsl_m"] + s["alt_rel_m"], s["alt_rel_m"],
                             T0 + dt.timedelta(seconds=3 * i), gimbal_yaw=(true + 180.0) % 360.0 - 180.0,
                             gimbal_pitch=s["pitch_deg"]))
        ids.append(s["id"])
    looks = sorted({s["pitch_deg"] for s in st[:5]}) + [len({(s["x"], s["y"]) for s in st[:5]})]
    assert looks == [-90.0, -45.0, 1], looks  # the first station: five looks at one place
    gone = 3 * 5 + 2  # the third look of the fourth station
    assert st[gone]["pitch_deg"] == -45.0 and st[gone + 1]["pitch_deg"] == -45.0
    del shots[gone]
    kept = ids[:gone] + ids[gone + 1:]
    _write(tmp_path / "DCIM", shots)
    flight = tmp_path / "flown"
    code, text = _run("log", "ingest", tmp_path / "DCIM", "--plan", plan, "-o", flight)
    assert code in (0, 1), text
    rep = json.loads((flight / "log_report.json").read_text())
    assert rep["missed_stations"] == [ids[gone]] and rep["matched"] == len(shots)
    rows = [ln for ln in (flight / "events.csv").read_text().splitlines() if not ln.startswith("#")]
    assert [r["station"] for r in csv.DictReader(rows)] == kept
