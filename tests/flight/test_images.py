"""Images matched to the SITL log's camera events by EXIF time with an unknown camera clock."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from click.testing import CliRunner
from PIL import Image

from aerosurvey.cli import main
from aerosurvey.flight.events import read_events
from aerosurvey.flight.images import match_images

LOG = Path(__file__).resolve().parents[1] / "data" / "sitl_copter_survey.bin"


def _images(folder: Path, times: list[float]) -> list[Path]:
    folder.mkdir()
    out = []
    for k, t in enumerate(times):
        stamp = dt.datetime.fromtimestamp(t, dt.UTC)
        exif = Image.Exif()
        sub = exif.get_ifd(0x8769)
        sub[36867] = stamp.strftime("%Y:%m:%d %H:%M:%S")
        sub[37521] = f"{stamp.microsecond // 10000:02d}"
        p = folder / f"DSC{k + 1:05d}.JPG"
        Image.new("RGB", (8, 8)).save(p, exif=exif)
        out.append(p)
    return out


def test_clock_offset_and_missing_images(tmp_path):
    ev, _ = read_events(LOG)
    assert ev.utc_s is not None
    keep = [j for j in range(len(ev)) if j not in (10, 80)]  # two pictures never written to the card
    files = _images(tmp_path / "img", [float(ev.utc_s[j]) + 3.3 for j in keep])
    m = match_images(files, ev)
    assert m.method == "capture time" and abs(m.offset_s - 3.3) < 0.02
    assert m.event_of == keep and m.unmatched_events == [10, 80] and m.unmatched_files == []


def test_ingest_writes_geotags(tmp_path):
    ev, _ = read_events(LOG)
    _images(tmp_path / "img", [float(t) - 7.0 for t in ev.utc_s])
    res = CliRunner().invoke(main, ["log", "ingest", str(LOG), "--images", str(tmp_path / "img"), "-o", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    geo = (tmp_path / "o" / "geo.txt").read_text().splitlines()
    assert geo[0] == "EPSG:4326" and len(geo) == 1 + len(ev)
    name, lon, lat, alt = geo[1].split()[:4]
    assert name == "DSC00001.JPG" and abs(float(lat) - ev.lat[0]) < 1e-8 and abs(float(lon) - ev.lon[0]) < 1e-8
    for name in ("pix4d_geolocation.csv", "metashape_reference.csv"):
        ref = (tmp_path / "o" / name).read_text().splitlines()
        assert ref[0].startswith("#") and len(ref) == 1 + len(ev)


def test_unusable_times_fall_back_to_order(tmp_path):
    ev, _ = read_events(LOG)
    (tmp_path / "img").mkdir()
    files = []
    for k in range(5):
        p = tmp_path / "img" / f"IMG_{k}.JPG"
        Image.new("RGB", (8, 8)).save(p)  # no EXIF time
        files.append(p)
    m = match_images(files, ev)
    assert m.method.startswith("order") and m.event_of == [0, 1, 2, 3, 4]
