"""The camera database: every record valid, the required cameras present, the numbers the
source papers print, helpful errors for bad records, and the `aerosurvey cameras` command."""

from __future__ import annotations

import csv
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner, Result

from aerosurvey.camera import (
    PITCH_MISMATCH_TOLERANCE,
    SHUTTERS,
    Camera,
    camera_from_mapping,
    cameras_from_toml,
    database,
    get_camera,
)
from aerosurvey.errors import InputError

REFERENCE_CSV = Path(__file__).resolve().parent / "data" / "reference" / "cameras_from_sources.csv"

#: Cameras the brief requires in the database, by id.
REQUIRED_IDS = (
    "ricoh-gr",
    "sony-nex-5n-16mm",
    "sony-nex-7-18mm",
    "sony-ilce-7rm2-15mm",
    "gopro-hero7",
    "dji-phantom-4-rtk",
    "dji-phantom-4-pro",
    "dji-mavic-3-enterprise",
    "dji-zenmuse-p1-24mm",
    "dji-zenmuse-p1-35mm",
    "dji-zenmuse-p1-50mm",
    "sony-rx1r-ii",
    "sony-a6000-16mm",
    "sony-a7r-iv-35mm",
    "micasense-rededge-mx",
    "panasonic-lumix-gx1-14mm",
    "trimble-ux5-hp-15mm",
    "sensefly-soda",
    "dji-mavic-2-pro",
    "dji-zenmuse-x5s-15mm",
    "parrot-sequoia-plus-rgb",
    "phase-one-ixm-100-80mm",
)

#: Rows of the reference CSV (camera names as the papers print them) and their database ids.
CSV_IDS = {
    "Ricoh GR": "ricoh-gr",
    "Sony NEX-5N": "sony-nex-5n-16mm",
    "Sony NEX-7": "sony-nex-7-18mm",
    "Sony ILCE-7RM2": "sony-ilce-7rm2-15mm",
    "GoPro Hero 7": "gopro-hero7",
}


def _raw_tables() -> dict[str, Any]:
    text = resources.files("aerosurvey").joinpath("data/cameras.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def _good() -> dict[str, Any]:
    """A valid record (the a6000 numbers) to break one key at a time."""
    return {
        "name": "Test camera",
        "sensor_width_mm": 23.5,
        "sensor_height_mm": 15.6,
        "image_width_px": 6000,
        "image_height_px": 4000,
        "focal_mm": 16.0,
        "min_cycle_s": 1.0,
        "exposure_s": 0.001,
        "shutter": "mechanical",
    }


# --- the shipped database -------------------------------------------------------------


def test_database_has_at_least_24_cameras_and_every_table_loads():
    raw = _raw_tables()
    db = database()
    assert len(db) >= 24
    assert set(db) == set(raw)


@pytest.mark.parametrize("cam_id", sorted(_raw_tables()))
def test_every_entry_validates_and_is_sensible(cam_id):
    table = _raw_tables()[cam_id]
    cam = camera_from_mapping(cam_id, table, f"cameras.toml [{cam_id}]")
    assert cam == database()[cam_id]
    assert cam.sensor_width_mm >= cam.sensor_height_mm, "width must be the long side"
    assert cam.image_width_px >= cam.image_height_px
    assert cam.shutter in ("global", "mechanical", "rolling", "unknown")
    assert cam.source.strip(), "every camera names its source"
    # the brief asks for explicit cycle, exposure and shutter on every record
    for key in ("min_cycle_s", "exposure_s", "shutter"):
        assert key in table, f"{cam_id} has no {key}"
    assert 0 < cam.exposure_s < cam.min_cycle_s
    assert 0.5 <= cam.pixel_pitch_um <= 30.0


@pytest.mark.parametrize("cam_id", REQUIRED_IDS)
def test_required_camera_present(cam_id):
    assert get_camera(cam_id).id == cam_id


def test_ricoh_gr_pitch_is_the_papers_4_78_um():
    assert get_camera("ricoh-gr").pixel_pitch_um == pytest.approx(4.78, abs=0.01)


@pytest.mark.parametrize("cam_id", sorted(_raw_tables()))
def test_pitch_from_width_and_height_agree(cam_id):
    cam = database()[cam_id]
    p_w = cam.sensor_width_mm / cam.image_width_px
    p_h = cam.sensor_height_mm / cam.image_height_px
    assert abs(p_w - p_h) / p_w <= PITCH_MISMATCH_TOLERANCE
    assert cam.pitch_mismatch == pytest.approx(abs(p_w - p_h) / p_w)


def test_database_matches_the_reference_csv():
    with REFERENCE_CSV.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    assert {r["name"] for r in rows} == set(CSV_IDS)
    for row in rows:
        cam = get_camera(CSV_IDS[row["name"]])
        assert cam.sensor_width_mm == pytest.approx(float(row["sensor_width_mm"]))
        assert cam.sensor_height_mm == pytest.approx(float(row["sensor_height_mm"]))
        assert cam.image_width_px == int(row["image_width_px"])
        assert cam.image_height_px == int(row["image_height_px"])
        assert cam.focal_mm == pytest.approx(float(row["focal_mm"]))
        if row["pixel_um"]:
            assert cam.pixel_pitch_um == pytest.approx(float(row["pixel_um"]), abs=0.01)


def test_gopro_keeps_the_printed_focal_length_and_flags_it():
    cam = get_camera("gopro-hero7")
    assert cam.focal_mm == 17.0
    assert "17 mm" in cam.notes and "3 mm" in cam.notes and "suspect" in cam.notes.lower()


def test_paper_exposure_times_are_used():
    # Table A1 of the forest paper: NEX-5N at 1/640 s, NEX-7 and a7R II at 1/1000 s
    assert get_camera("sony-nex-5n-16mm").exposure_s == pytest.approx(1 / 640)
    assert get_camera("sony-nex-7-18mm").exposure_s == pytest.approx(1 / 1000)
    assert get_camera("sony-ilce-7rm2-15mm").exposure_s == pytest.approx(1 / 1000)


def test_shutter_kinds_are_the_documented_ones():
    assert SHUTTERS == ("global", "mechanical", "rolling", "unknown")
    assert get_camera("micasense-rededge-mx").shutter == "global"
    assert get_camera("dji-mavic-2-pro").shutter == "rolling"
    assert get_camera("dji-zenmuse-p1-35mm").shutter == "mechanical"


# --- get_camera -------------------------------------------------------------------------


def test_unknown_id_error_names_the_id():
    with pytest.raises(InputError) as exc:
        get_camera("nikon-d1")
    assert "'nikon-d1'" in str(exc.value)
    assert "\n" not in str(exc.value)


def test_unknown_id_error_suggests_close_ids():
    with pytest.raises(InputError) as exc:
        get_camera("zenmuse-p1-35")
    assert "dji-zenmuse-p1-35mm" in str(exc.value)


def test_get_camera_accepts_case_and_spaces():
    assert get_camera("Sony A6000 16mm").id == "sony-a6000-16mm"


# --- malformed records ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("key", "value", "needles"),
    [
        ("focal_mm", -16.0, ["focal_mm", "-16.0"]),
        ("focal_mm", 0, ["focal_mm", "= 0"]),
        ("sensor_width_mm", "23.5", ["sensor_width_mm", "'23.5'"]),
        ("sensor_height_mm", float("nan"), ["sensor_height_mm", "nan"]),
        ("image_width_px", 6000.0, ["image_width_px", "6000.0"]),
        ("image_height_px", "4000", ["image_height_px", "'4000'"]),
        ("image_height_px", True, ["image_height_px", "True"]),
        ("min_cycle_s", -1, ["min_cycle_s", "-1"]),
        ("shutter", "leaf", ["shutter", "'leaf'"]),
        ("name", "  ", ["name", "'  '"]),
        ("source", 12, ["source", "12"]),
    ],
)
def test_bad_value_names_key_and_value(key, value, needles):
    rec = _good() | {key: value}
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", rec, "cameras.toml [x]")
    msg = str(exc.value)
    assert msg.startswith("cameras.toml [x]")
    for needle in needles:
        assert needle in msg


@pytest.mark.parametrize("key", ["name", "sensor_width_mm", "sensor_height_mm", "image_width_px",
                                 "image_height_px", "focal_mm"])
def test_missing_key_is_named(key):
    rec = _good()
    del rec[key]
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", rec, "cameras.toml [x]")
    assert f"missing key '{key}'" in str(exc.value)


def test_unknown_key_is_named_with_its_value():
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", _good() | {"focal_length": 16}, "cameras.toml [x]")
    msg = str(exc.value)
    assert "focal_length = 16" in msg and "unknown key" in msg and "focal_mm" in msg


def test_portrait_image_is_refused_naming_both_keys():
    rec = _good() | {"image_width_px": 4000, "image_height_px": 6000}
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", rec, "cameras.toml [x]")
    msg = str(exc.value)
    assert "image_width_px = 4000" in msg and "image_height_px = 6000" in msg and "long side" in msg


def test_portrait_sensor_is_refused_naming_both_keys():
    rec = _good() | {"sensor_width_mm": 15.6, "sensor_height_mm": 23.5}
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", rec, "cameras.toml [x]")
    msg = str(exc.value)
    assert "sensor_width_mm = 15.6" in msg and "sensor_height_mm = 23.5" in msg


def test_pitch_mismatch_over_3_percent_is_refused():
    rec = _good() | {"sensor_height_mm": 17.0}  # 4.25 um vs 3.92 um: 8.5 %
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", rec, "cameras.toml [x]")
    msg = str(exc.value)
    assert "3.917 um" in msg and "4.250 um" in msg and "8.5%" in msg


def test_pitch_mismatch_under_3_percent_is_accepted():
    cam = camera_from_mapping("x", _good() | {"sensor_height_mm": 16.0}, "here")  # 2.1 %
    assert cam.pitch_mismatch == pytest.approx(0.0213, abs=1e-3)


def test_unit_slip_in_sensor_size_is_refused():
    rec = _good() | {"sensor_width_mm": 2.35, "sensor_height_mm": 1.56}  # cm typed as mm: 0.39 um
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", rec, "cameras.toml [x]")
    assert "sensor_width_mm / image_width_px" in str(exc.value) and "units" in str(exc.value)


def test_exposure_longer_than_cycle_is_refused():
    rec = _good() | {"exposure_s": 2.0, "min_cycle_s": 1.0}
    with pytest.raises(InputError) as exc:
        camera_from_mapping("x", rec, "cameras.toml [x]")
    assert "exposure_s = 2" in str(exc.value) and "min_cycle_s = 1" in str(exc.value)


def test_defaults_fill_optional_keys():
    rec = {k: v for k, v in _good().items() if k not in ("min_cycle_s", "exposure_s", "shutter")}
    cam = camera_from_mapping("x", rec, "here")
    assert cam == Camera("x", "Test camera", 23.5, 15.6, 6000, 4000, 16.0)


def test_bad_database_id_and_bad_toml_are_named():
    good = "\n".join(f"{k} = {v!r}".replace("'", '"') for k, v in _good().items())
    with pytest.raises(InputError) as exc:
        cameras_from_toml(f"[Sony_A6000]\n{good}\n", "cameras.toml")
    assert "'Sony_A6000'" in str(exc.value)
    with pytest.raises(InputError) as exc:
        cameras_from_toml("[a]\nname = \n", "cameras.toml")
    assert "cameras.toml: not valid TOML" in str(exc.value)
    assert set(cameras_from_toml(f"[sony-test]\n{good}\n", "t")) == {"sony-test"}


# --- the command ------------------------------------------------------------------------


def _run(*args: str) -> Result:
    """Run `aerosurvey ARGS` in-process; imported here so a broken unrelated command module
    fails only these tests, not the database tests above."""
    from aerosurvey.cli import main

    return CliRunner().invoke(main, list(args))


def test_cli_lists_every_id_in_aligned_columns():
    res = _run("cameras")
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    header, rows = lines[0], lines[1:]
    assert [r.split()[0] for r in rows] == sorted(database())
    # right-aligned numeric columns end at the same position as their header
    for title in ("sensor mm", "image px", "f mm", "pitch um", "cycle s"):
        end = header.index(title) + len(title)
        for row in rows:
            assert row[end - 1].isdigit() and row[end] == " ", (title, row)
    # left-aligned text columns start where their header starts
    for title in ("shutter", "name"):
        start = header.index(title)
        for row in rows:
            assert row[start - 1] == " " and row[start] != " ", (title, row)


def test_cli_show_prints_the_pitch():
    res = _run("cameras", "show", "sony-a6000-16mm")
    assert res.exit_code == 0, res.output
    assert "3.917 um" in res.output  # 23.5 mm / 6000 px
    assert "Sony a6000" in res.output and "source:" in res.output


def test_cli_show_unknown_id_exits_2_with_one_line():
    res = _run("cameras", "show", "nikon-d1")
    assert res.exit_code == 2
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith("Error:") and "'nikon-d1'" in err
