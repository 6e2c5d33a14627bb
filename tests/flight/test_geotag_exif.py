"""EXIF GPS tags written into copies of the survey images; read back with Pillow, not with our writer."""

from __future__ import annotations

import datetime as dt
import hashlib
import io
import json
import struct
from pathlib import Path

import pytest
from click.testing import CliRunner
from dfwriter import camera_log
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import ExifTags, Image

from aerosurvey.cli import main
from aerosurvey.flight.events import read_events
from aerosurvey.flight.geotag_exif import GeotagError, GpsFix, dms_rationals, geotag_jpeg

T0 = dt.datetime(2026, 5, 4, 9, 30, tzinfo=dt.UTC).timestamp()
GPS = 0x8825


def _exif(t: float | None = None, endian: str = "<") -> Image.Exif:
    exif = Image.Exif()
    exif.endian = endian
    exif[271], exif[272] = "Sony", "ILCE-6000"  # Make, Model
    if t is not None:
        stamp = dt.datetime.fromtimestamp(t, dt.UTC)
        sub = exif.get_ifd(0x8769)
        sub[36867] = stamp.strftime("%Y:%m:%d %H:%M:%S")  # DateTimeOriginal
        sub[37521] = f"{stamp.microsecond // 10000:02d}"
        sub[0x927C] = b"MAKERNOTE\x00\x01\x02\x03 private bytes"
    return exif


def _jpeg_bytes(exif: Image.Exif | None = None, seed: int = 0) -> bytes:
    im = Image.effect_noise((64, 48), 40 + seed).convert("RGB")
    buf = io.BytesIO()
    im.save(buf, "JPEG", quality=90, **({"exif": exif} if exif is not None else {}))
    return buf.getvalue()


def _markers(data: bytes) -> tuple[list[tuple[int, bytes]], int]:
    """(marker, whole segment) before the first SOS, and the SOS offset: an independent walk of the headers."""
    pos, out = 2, []
    while data[pos + 1] != 0xDA:
        length = int.from_bytes(data[pos + 2:pos + 4], "big")
        out.append((data[pos + 1], data[pos:pos + 2 + length]))
        pos += 2 + length
    return out, pos


def _not_exif(data: bytes) -> list[bytes]:
    """Every header segment except the APP1 Exif one."""
    return [seg for m, seg in _markers(data)[0] if not (m == 0xE1 and seg[4:10] == b"Exif\x00\x00")]


def _gps(data: bytes) -> tuple[float, float, float | None, dict]:
    with Image.open(io.BytesIO(data)) as im:
        g = im.getexif().get_ifd(GPS)
    lat = sum(float(v) / k for v, k in zip(g[2], (1, 60, 3600))) * (1 if g[1] == "N" else -1)
    lon = sum(float(v) / k for v, k in zip(g[4], (1, 60, 3600))) * (1 if g[3] == "E" else -1)
    alt = float(g[6]) * (-1 if g.get(5) in (b"\x01", 1) else 1) if 6 in g else None
    return lat, lon, alt, g


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def _flight(tmp: Path, n: int = 6) -> tuple[Path, list[tuple]]:
    """A DataFlash log of n nadir camera events, 2 s apart, west of Greenwich and south of the equator."""
    events = [(100.0 + 2 * k, -33.8568 - 1e-4 * k, -70.2153 + 2e-4 * k, 512.37 + k, 100.0) for k in range(n)]
    log = tmp / "flight.bin"
    log.write_bytes(camera_log(events))
    return log, events


def _images(folder: Path, times: list[float], names: list[str] | None = None) -> list[Path]:
    folder.mkdir(exist_ok=True)
    out = []
    for k, t in enumerate(times):
        p = folder / (names[k] if names else f"DSC{k + 1:05d}.JPG")
        p.write_bytes(_jpeg_bytes(_exif(t), seed=k))
        out.append(p)
    return out


def _ingest(*args: str) -> CliRunner:
    return CliRunner().invoke(main, ["log", "ingest", *args])


def test_copies_carry_the_event_position_and_keep_the_rest(tmp_path):
    log, _ = _flight(tmp_path)
    ev, _ = read_events(log)
    # the camera clock runs 4.2 s off; the fourth event has no picture, and one picture has no event
    files = _images(tmp_path / "img", [T0 + ev.time_s[j] + 4.2 for j in (0, 1, 2, 4, 5)] + [T0 + 500.0])
    before = {p.name: _sha(p) for p in files}
    res = _ingest(str(log), "--images", str(tmp_path / "img"), "--geotag-copies", str(tmp_path / "tagged"),
                  "-o", str(tmp_path / "out"))
    assert res.exit_code == 0, res.output
    assert {p.name: _sha(p) for p in files} == before, "the originals must not change"
    rep = json.loads((tmp_path / "out" / "log_report.json").read_text())
    g = rep["geotag"]
    assert g["written"] == 5 and g["skipped"] == [] and g["unmatched_not_copied"] == ["DSC00006.JPG"]
    assert "DSC00006.JPG" in res.output and "5 JPEG(s) written" in res.output
    assert sorted(p.name for p in (tmp_path / "tagged").iterdir()) == [f"DSC{k:05d}.JPG" for k in range(1, 6)]
    for f, j in zip(files, (0, 1, 2, 4, 5)):
        orig, copy = f.read_bytes(), (tmp_path / "tagged" / f.name).read_bytes()
        lat, lon, alt, gps = _gps(copy)
        assert lat == pytest.approx(ev.lat[j], abs=1e-6) and lon == pytest.approx(ev.lon[j], abs=1e-6)
        assert lat < 0 and lon < 0 and gps[1] == "S" and gps[3] == "W"
        assert alt == pytest.approx(float(ev.alt_m[j]), abs=0.01)
        assert gps[0] == b"\x02\x03\x00\x00" and gps[18] == "WGS-84" and gps[16] == "T" and float(gps[17]) == 0.0
        with Image.open(io.BytesIO(copy)) as im, Image.open(f) as im0:
            e, e0 = im.getexif(), im0.getexif()
            assert (e[271], e[272]) == ("Sony", "ILCE-6000")
            assert e.get_ifd(0x8769) == e0.get_ifd(0x8769)  # DateTimeOriginal, SubSec, maker note
            assert im.size == im0.size
        # the compressed image and every other header segment are the original's bytes
        assert copy[_markers(copy)[1]:] == orig[_markers(orig)[1]:]
        assert _not_exif(copy) == _not_exif(orig)


def test_the_originals_folder_is_refused(tmp_path):
    log, _ = _flight(tmp_path)
    ev, _ = read_events(log)
    _images(tmp_path / "img", [T0 + t for t in ev.time_s])
    for spelling in (str(tmp_path / "img"), str(tmp_path / "img" / "."), str(tmp_path / "img") + "/"):
        res = _ingest(str(log), "--images", str(tmp_path / "img"), "--geotag-copies", spelling, "-o", str(tmp_path / "o"))
        assert res.exit_code == 2, res.output
        assert "--geotag-copies" in res.output and "is the --images folder" in res.output
        assert "--geotag-in-place" in res.output and repr(str(Path(spelling))) in res.output
    assert not (tmp_path / "o").exists()
    res = _ingest(str(log), "--geotag-copies", str(tmp_path / "t"), "-o", str(tmp_path / "o"))
    assert res.exit_code == 2 and "give --images too" in res.output


def test_in_place_replaces_each_original_atomically(tmp_path):
    log, _ = _flight(tmp_path)
    ev, _ = read_events(log)
    files = _images(tmp_path / "img", [T0 + t for t in ev.time_s])
    scans = {p.name: p.read_bytes()[_markers(p.read_bytes())[1]:] for p in files}
    res = _ingest(str(log), "--images", str(tmp_path / "img"), "--geotag-in-place", "-o", str(tmp_path / "o"))
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (tmp_path / "img").iterdir()) == sorted(scans), "no temporary files left behind"
    for j, p in enumerate(files):
        data = p.read_bytes()
        assert _gps(data)[0] == pytest.approx(ev.lat[j], abs=1e-6)
        assert data[_markers(data)[1]:] == scans[p.name]
    # tagging again (the GPS IFD now exists) sets the pointer in place and stays readable
    res = _ingest(str(log), "--images", str(tmp_path / "img"), "--geotag-copies", str(tmp_path / "img"),
                  "--geotag-in-place", "-o", str(tmp_path / "o"))
    assert res.exit_code == 0, res.output
    assert _gps(files[2].read_bytes())[1] == pytest.approx(ev.lon[2], abs=1e-6)


def test_non_jpeg_and_damaged_files_are_skipped_with_a_note(tmp_path):
    log, _ = _flight(tmp_path, 5)
    (tmp_path / "img").mkdir()
    good = _jpeg_bytes()  # no EXIF times anywhere: images are matched by order
    (tmp_path / "img" / "A1.JPG").write_bytes(good)
    (tmp_path / "img" / "A2.jpg").write_bytes(b"this is no jpeg at all" * 20)
    (tmp_path / "img" / "A3.jpg").write_bytes(good[:40])  # cut off inside the headers
    (tmp_path / "img" / "A4.jpg").write_bytes(good[: len(good) - 200])  # cut off in the image data
    Image.new("RGB", (8, 8)).save(tmp_path / "img" / "A5.tif")
    res = _ingest(str(log), "--images", str(tmp_path / "img"), "--geotag-copies", str(tmp_path / "t"), "-o", str(tmp_path / "o"))
    assert res.exit_code == 0, res.output
    g = json.loads((tmp_path / "o" / "log_report.json").read_text())["geotag"]
    assert g["files"] == ["A1.JPG", "A4.jpg"]
    reasons = {s["file"]: s["reason"] for s in g["skipped"]}
    assert set(reasons) == {"A2.jpg", "A3.jpg", "A5.tif"}
    assert "not a JPEG file" in reasons["A2.jpg"] and "cut off" in reasons["A3.jpg"] and "not a JPEG" in reasons["A5.tif"]
    assert g["notes"][0]["file"] == "A4.jpg" and "cut off" in g["notes"][0]["note"]
    for name in ("A2.jpg", "A3.jpg", "A5.tif"):
        assert f"skipped {name}" in res.output
    assert sorted(p.name for p in (tmp_path / "t").iterdir()) == ["A1.JPG", "A4.jpg"]


@settings(max_examples=150, deadline=None)
@given(st.floats(-90, 90), st.floats(-180, 180), st.floats(-430, 9000), st.floats(-720, 720))
def test_hemispheres_and_values_read_back(lat, lon, alt, yaw):
    src = _jpeg_bytes(_exif(T0))
    out = geotag_jpeg(src, GpsFix(lat, lon, alt, yaw))
    rlat, rlon, ralt, g = _gps(out)
    assert g[1] == ("N" if lat >= 0 else "S") and g[3] == ("E" if lon >= 0 else "W")
    assert rlat == pytest.approx(lat, abs=1e-6) and rlon == pytest.approx(lon, abs=1e-6)
    assert abs(ralt - alt) <= 0.001 and g[5] == (b"\x00" if alt >= 0 else b"\x01")
    assert 0 <= float(g[17]) < 360 and abs((float(g[17]) - yaw + 180) % 360 - 180) <= 0.006
    for k in (2, 4):
        d, m, s = (float(v) for v in g[k])
        assert d == int(d) and 0 <= m < 60 and 0 <= s < 60
    assert out[_markers(out)[1]:] == src[_markers(src)[1]:]


def test_dms_rounding_carries_instead_of_sixty_seconds():
    (d, _), (m, _), (s, den) = dms_rationals(10.99999999999999)
    assert (d, m, s) == (11, 0, 0)
    (d, _), (m, _), (s, den) = dms_rationals(-0.5)
    assert (d, m, s / den) == (0, 30, 0.0)


def test_big_endian_exif_and_a_jpeg_without_exif():
    src = _jpeg_bytes(_exif(T0, endian=">"))
    out = geotag_jpeg(src, GpsFix(12.5, -3.25, 10.0))
    assert next(seg for m, seg in _markers(out)[0] if m == 0xE1)[10:12] == b"MM", "the camera's byte order is kept"
    lat, lon, alt, g = _gps(out)
    assert (lat, lon, alt) == (pytest.approx(12.5), pytest.approx(-3.25), pytest.approx(10.0))
    assert 16 not in g, "no direction without a yaw"
    with Image.open(io.BytesIO(out)) as im:
        assert im.getexif()[271] == "Sony"
    bare = _jpeg_bytes()
    out = geotag_jpeg(bare, GpsFix(1.0, 2.0))
    markers = [m for m, _ in _markers(out)[0]]
    assert markers[:2] == [0xE0, 0xE1], "JFIF APP0 first, then the new APP1 Exif"
    assert _gps(out)[:3] == (pytest.approx(1.0), pytest.approx(2.0), None)
    assert _not_exif(out) == _not_exif(bare) and out[_markers(out)[1]:] == bare[_markers(bare)[1]:]


def test_camera_gps_replaced_thumbnail_ifd_kept():
    # an EXIF block written by hand: IFD0 (Make) -> IFD1 (thumbnail pointers) -> a thumbnail, and a GPS IFD of the camera's
    thumb = _jpeg_bytes(seed=3)[:300]
    make = b"TestCam\x00"
    ifd0_at, gps_at, ifd1_at = 8, 8 + 2 + 2 * 12 + 4, 0
    gps = (struct.pack("<H", 2) + struct.pack("<HHI4s", 1, 2, 2, b"N\x00\x00\x00")
           + struct.pack("<HHI4s", 8, 2, 3, b"07\x00\x00") + b"\x00" * 4)
    make_at = gps_at + len(gps)
    ifd1_at = make_at + len(make)
    thumb_at = ifd1_at + 2 + 2 * 12 + 4
    ifd0 = (struct.pack("<H", 2) + struct.pack("<HHII", 271, 2, len(make), make_at)
            + struct.pack("<HHII", GPS, 4, 1, gps_at) + struct.pack("<I", ifd1_at))
    ifd1 = (struct.pack("<H", 2) + struct.pack("<HHII", 0x201, 4, 1, thumb_at) + struct.pack("<HHII", 0x202, 4, 1, len(thumb))
            + struct.pack("<I", 0))
    tiff = b"II" + struct.pack("<HI", 42, ifd0_at) + ifd0 + gps + make + ifd1 + thumb
    bare = _jpeg_bytes()
    app1 = b"Exif\x00\x00" + tiff
    src = bare[:2] + b"\xff\xe1" + struct.pack(">H", len(app1) + 2) + app1 + bare[2:]
    with Image.open(io.BytesIO(src)) as im:
        ifd1_before = dict(im.getexif().get_ifd(ExifTags.IFD.IFD1))
    assert ifd1_before == {0x201: thumb_at, 0x202: len(thumb)}
    out = geotag_jpeg(src, GpsFix(-1.5, 100.25, 20.0))
    with Image.open(io.BytesIO(out)) as im:
        e = im.getexif()
        assert e[271] == "TestCam" and dict(e.get_ifd(ExifTags.IFD.IFD1)) == ifd1_before
        assert 8 not in e.get_ifd(GPS), "the camera's own GPS tags are not mixed with the event's position"
    exif_seg = next(seg for m, seg in _markers(out)[0] if m == 0xE1)
    new_tiff = exif_seg[10:]
    assert new_tiff[thumb_at:thumb_at + len(thumb)] == thumb
    assert _gps(out)[:3] == (pytest.approx(-1.5), pytest.approx(100.25), pytest.approx(20.0))


@pytest.mark.parametrize("data", [b"", b"\xff\xd8", b"\xff\xd8\xff\xe1\x00\x10Exif", b"\xff\xd8\xff\xd9", b"\x89PNG\r\n"])
def test_damaged_input_raises_geotag_error(data):
    with pytest.raises(GeotagError):
        geotag_jpeg(data, GpsFix(1.0, 1.0))


def test_a_broken_exif_block_is_refused_not_rewritten():
    bare = _jpeg_bytes()
    app1 = b"Exif\x00\x00" + b"II" + struct.pack("<HI", 42, 5000)
    src = bare[:2] + b"\xff\xe1" + struct.pack(">H", len(app1) + 2) + app1 + bare[2:]
    with pytest.raises(GeotagError, match="outside"):
        geotag_jpeg(src, GpsFix(1.0, 1.0))
    with pytest.raises(GeotagError, match="not a WGS84 position"):
        geotag_jpeg(bare, GpsFix(float("nan"), 1.0))
