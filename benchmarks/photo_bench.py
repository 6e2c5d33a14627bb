"""Photo metadata readers, like for like: which library reads a flight's photos (EXIF GPS and DJI's XMP)?

    python benchmarks/photo_bench.py                   # 2,000 photos, 8 MB each (sparse), every candidate
    python benchmarks/photo_bench.py --photos 500 --pixel-mb 0
    python benchmarks/photo_bench.py --candidates pillow-lxml --no-correctness

The photos are written by the tests' own writer (tests/flight/photowriter.py: EXIF packed with
struct, DJI's drone-dji XMP packet): three in four in DJI's layout (little-endian EXIF, the XMP
fields as attributes), one in eight with the XMP fields as elements, one in eight another maker's
(big-endian EXIF, GPSImgDirection, no XMP). Each file is padded to --pixel-mb with a sparse run of
image data, as a real 20 MP photo is 8-12 MB: a reader that reads the whole file pays for it.

Candidates (each in its own process per run, so its peak memory is its own; the libraries that
aerosurvey does not depend on are installed by hand for the comparison, `pip install exifread pyexiv2
piexif defusedxml`, and a candidate whose library is missing is reported as failed):

  pillow-lxml     Pillow's Image.open (reads the markers up to the image data) + getexif() and its GPS
                  and Exif IFDs; the XMP packet Pillow keeps (info["xmp"]) parsed with lxml
  pillow-getxmp   the same EXIF; XMP through Pillow's own getxmp() (defusedxml; namespaces dropped)
  exifread        exifread.process_file(details=False) for EXIF; XMP by exifread's own search for
                  <x:xmpmeta> (exifread.core.xmp.find_xmp_data, which it runs only in debug mode)
                  parsed with lxml
  pyexiv2         pyexiv2.Image(path).read_exif() and read_xmp() (exiv2 in C++)
  piexif          piexif.load(path) for EXIF (no XMP reader: the packet found in the file's first
                  64 KB, parsed with lxml); piexif's last release is of 2019
  aerosurvey      aerosurvey.flight.photos.read_photo_flight: the project's reader (the chosen
                  library plus its checks, ordering and the flight record), as `log ingest` runs it

Correctness: each candidate's position, altitudes, capture time, gimbal angles and RTK fields
against the truth the photos were written from, on the three layouts, and the count of
exceptions it raises on damaged copies (cut off at random places, random bytes overwritten).
Figures are printed, never asserted.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import random
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "flight"))

import photowriter as pw  # noqa: E402

DJI = "{http://www.dji.com/drone-dji/1.0/}"
FIELDS = ("lat", "lon", "alt", "rel_alt", "time", "yaw", "pitch", "roll", "rtk_flag", "std_lon", "std_lat", "std_hgt")


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


# ---- the photos ------------------------------------------------------------------------------

def shot(i: int) -> tuple[pw.Shot, str]:
    """The i-th photo of a synthetic flight and its layout."""
    rnd = random.Random(i)
    t0 = dt.datetime(2026, 5, 14, 7, 0, 0, tzinfo=dt.UTC)
    row = i % 50 if (i // 50) % 2 == 0 else 49 - i % 50  # lines of 50 photos flown back and forth
    s = pw.Shot(49.45 + 1e-4 * row + 1e-7 * rnd.random(), 15.05 + 2e-4 * (i // 50) + 1e-7 * rnd.random(),
                600.0 + rnd.uniform(-2, 2), 100.0 + rnd.uniform(-2, 2), t0 + dt.timedelta(seconds=2.3 * i),
                gimbal_yaw=rnd.uniform(-180, 180), gimbal_pitch=rnd.uniform(-90, -45), gimbal_roll=rnd.uniform(-1, 1),
                rtk_flag=rnd.choice([50, 50, 50, 34, 16]), rtk_std=(rnd.uniform(0.01, 2), rnd.uniform(0.01, 2), rnd.uniform(0.01, 3)),
                xmp_position=i % 3 == 0)
    layout = "plain" if i % 8 == 7 else "dji-elements" if i % 8 == 3 else "dji"
    if layout == "plain":
        s.make, s.model = "NIKON CORPORATION", "NIKON Z 7"
    return s, layout


def photo_bytes(s: pw.Shot, layout: str) -> bytes:
    if layout == "plain":
        return pw.plain_jpeg(s, direction=s.gimbal_yaw % 360.0)
    return pw.dji_jpeg(s, elements=layout == "dji-elements")


def write_photos(folder: Path, n: int, pixel_mb: float) -> None:
    pad = int(pixel_mb * 1e6)
    for i in range(n):
        s, layout = shot(i)
        data = photo_bytes(s, layout)
        with open(folder / f"DJI_{i + 1:04d}.JPG", "wb") as f:
            f.write(data[:-2])  # the image data runs on to the file's size (a hole: no disk used)
            if pad:
                f.seek(pad, os.SEEK_CUR)
            f.write(b"\xff\xd9")


def truth(i: int) -> dict[str, float | None]:
    s, layout = shot(i)
    plain = layout == "plain"
    return {"lat": s.lat, "lon": s.lon, "alt": s.abs_alt, "rel_alt": None if plain else s.rel_alt,
            "time": s.when.timestamp(), "yaw": s.gimbal_yaw % 360.0, "pitch": None if plain else s.gimbal_pitch,
            "roll": None if plain else s.gimbal_roll, "rtk_flag": None if plain else s.rtk_flag,
            "std_lon": None if plain else s.rtk_std[0], "std_lat": None if plain else s.rtk_std[1],
            "std_hgt": None if plain else s.rtk_std[2]}


# ---- shared by the candidates: the same decoding of what each library returns ---------------

def _num(v: Any) -> float:
    if isinstance(v, tuple) and len(v) == 2:
        return v[0] / v[1]
    if isinstance(v, str) and "/" in v:
        a, b = v.split("/")
        return float(a) / float(b)
    if hasattr(v, "num"):
        return v.num / v.den
    return float(v)


def _deg(parts: Any, ref: Any) -> float:
    d, m, s = (_num(p) for p in parts)
    r = ref.decode() if isinstance(ref, bytes) else str(ref)
    return (-1 if r.strip().upper() in ("S", "W") else 1) * (d + m / 60 + s / 3600)


def _time(dto: Any, sub: Any) -> float | None:
    if not dto:
        return None
    text = dto.decode() if isinstance(dto, bytes) else str(dto)
    t = dt.datetime.strptime(text.strip().rstrip("\0"), "%Y:%m:%d %H:%M:%S").replace(tzinfo=dt.UTC).timestamp()
    s = (sub.decode() if isinstance(sub, bytes) else str(sub or "")).strip().rstrip("\0")
    return t + (float("0." + s) if s.isdigit() else 0.0)


def _xmp_lxml(packet: bytes | None) -> dict[str, str]:
    """drone-dji fields of an XMP packet (attributes or elements), by local name."""
    if not packet:
        return {}
    from lxml import etree

    root = etree.fromstring(packet.strip(b"\0 \n"), etree.XMLParser(resolve_entities=False, no_network=True))
    out = {}
    for el in root.iter("{http://www.w3.org/1999/02/22-rdf-syntax-ns#}Description"):
        for k, v in el.attrib.items():
            if k.startswith(DJI):
                out[k[len(DJI):]] = v
        for child in el:
            if isinstance(child.tag, str) and child.tag.startswith(DJI):
                out[child.tag[len(DJI):]] = (child.text or "").strip()
    return out


def _record(gps: dict[str, Any], dto: Any, sub: Any, x: dict[str, str]) -> dict[str, float | None]:
    """The fields from EXIF (GPS IFD entries by name) and the drone-dji XMP fields."""
    def xf(k: str) -> float | None:
        return float(x[k]) if k in x else None

    lat = _deg(gps["lat"], gps["lat_ref"]) if "lat" in gps else None
    lon = _deg(gps["lon"], gps["lon_ref"]) if "lon" in gps else None
    alt = _num(gps["alt"]) * (-1 if int(_num(gps.get("alt_ref", 0) or 0)) == 1 else 1) if "alt" in gps else None
    yaw = xf("GimbalYawDegree")
    if yaw is None and "dir" in gps:
        yaw = _num(gps["dir"])
    return {"lat": xf("GpsLatitude") or lat, "lon": xf("GpsLongitude") or lon, "alt": xf("AbsoluteAltitude") or alt,
            "rel_alt": xf("RelativeAltitude"), "time": _time(dto, sub), "yaw": None if yaw is None else yaw % 360.0,
            "pitch": xf("GimbalPitchDegree"), "roll": xf("GimbalRollDegree"), "rtk_flag": xf("RtkFlag"),
            "std_lon": xf("RtkStdLon"), "std_lat": xf("RtkStdLat"), "std_hgt": xf("RtkStdHgt")}


# ---- the candidates ------------------------------------------------------------------------------

def _pillow_exif(im: Any) -> tuple[dict[str, Any], Any, Any]:
    exif = im.getexif()
    g = exif.get_ifd(0x8825)
    e = exif.get_ifd(0x8769)
    names = {1: "lat_ref", 2: "lat", 3: "lon_ref", 4: "lon", 5: "alt_ref", 6: "alt", 17: "dir"}
    gps = {names[k]: v for k, v in g.items() if k in names}
    if "alt_ref" in gps and isinstance(gps["alt_ref"], bytes):
        gps["alt_ref"] = gps["alt_ref"][0]
    return gps, e.get(0x9003), e.get(0x9291)


def read_pillow_lxml(path: Path) -> dict[str, float | None]:
    from PIL import Image

    with Image.open(path) as im:
        gps, dto, sub = _pillow_exif(im)
        return _record(gps, dto, sub, _xmp_lxml(im.info.get("xmp")))


def read_pillow_getxmp(path: Path) -> dict[str, float | None]:
    from PIL import Image

    with Image.open(path) as im:
        gps, dto, sub = _pillow_exif(im)
        d = im.getxmp().get("xmpmeta", {}).get("RDF", {}).get("Description", {})
        d = d[0] if isinstance(d, list) else d
        x = {k: (v if isinstance(v, str) else "") for k, v in d.items()} if isinstance(d, dict) else {}
        return _record(gps, dto, sub, {k: v for k, v in x.items() if v})


def read_exifread(path: Path) -> dict[str, float | None]:
    import exifread
    from exifread.core.xmp import find_xmp_data

    with open(path, "rb") as f:
        tags = exifread.process_file(f, details=False, extract_thumbnail=False)
        f.seek(0)
        packet = find_xmp_data(f)
    names = {"GPS GPSLatitudeRef": "lat_ref", "GPS GPSLatitude": "lat", "GPS GPSLongitudeRef": "lon_ref",
             "GPS GPSLongitude": "lon", "GPS GPSAltitudeRef": "alt_ref", "GPS GPSAltitude": "alt", "GPS GPSImgDirection": "dir"}
    gps: dict[str, Any] = {}
    for k, n in names.items():
        if k in tags:
            v = tags[k].values
            gps[n] = v if n in ("lat", "lon") else (v[0] if isinstance(v, list) else v)
    dto, sub = tags.get("EXIF DateTimeOriginal"), tags.get("EXIF SubSecTimeOriginal")
    return _record(gps, dto.values if dto else None, sub.values if sub else None, _xmp_lxml(packet))


def read_pyexiv2(path: Path) -> dict[str, float | None]:
    import pyexiv2

    im = pyexiv2.Image(str(path))
    try:
        e, x = im.read_exif(), im.read_xmp()
    finally:
        im.close()
    p = "Exif.GPSInfo.GPS"
    names = {"LatitudeRef": "lat_ref", "Latitude": "lat", "LongitudeRef": "lon_ref", "Longitude": "lon",
             "AltitudeRef": "alt_ref", "Altitude": "alt", "ImgDirection": "dir"}
    gps: dict[str, Any] = {n: e[p + k] for k, n in names.items() if p + k in e}
    for k in ("lat", "lon"):
        if k in gps:
            gps[k] = gps[k].split()
    dji = {k[len("Xmp.drone-dji."):]: v for k, v in x.items() if k.startswith("Xmp.drone-dji.")}
    return _record(gps, e.get("Exif.Photo.DateTimeOriginal"), e.get("Exif.Photo.SubSecTimeOriginal"), dji)


def read_piexif(path: Path) -> dict[str, float | None]:
    import piexif

    d = piexif.load(str(path))
    with open(path, "rb") as f:
        head = f.read(65536)
    a, b = head.find(b"<x:xmpmeta"), head.find(b"</x:xmpmeta>")
    packet = head[a:b + 12] if 0 <= a < b else None
    g = d.get("GPS", {})
    names = {1: "lat_ref", 2: "lat", 3: "lon_ref", 4: "lon", 5: "alt_ref", 6: "alt", 17: "dir"}
    gps = {names[k]: v for k, v in g.items() if k in names}
    e = d.get("Exif", {})
    return _record(gps, e.get(0x9003), e.get(0x9291), _xmp_lxml(packet))


CANDIDATES: dict[str, Callable[[Path], dict[str, float | None]]] = {
    "pillow-lxml": read_pillow_lxml, "pillow-getxmp": read_pillow_getxmp, "exifread": read_exifread,
    "pyexiv2": read_pyexiv2, "piexif": read_piexif,
}


# ---- one run in a child process -------------------------------------------------------------------

def child(candidate: str, folder: Path, correctness: bool) -> dict[str, Any]:
    files = sorted(folder.glob("*.JPG"))
    out: dict[str, Any] = {"candidate": candidate, "photos": len(files)}
    t = time.perf_counter()
    if candidate == "aerosurvey":
        from aerosurvey.flight.photos import read_photo_flight

        flight = read_photo_flight(folder)
        out["seconds"] = time.perf_counter() - t
        out["read"] = len(flight.events)
        out["peak_mb"] = _peak_mb()
        if correctness:
            out["wrong"] = _wrong_aerosurvey(flight)
        return out
    read = CANDIDATES[candidate]
    records = []
    errors = 0
    for f in files:
        try:
            records.append(read(f))
        except Exception:  # a candidate that raises on a photo: counted
            records.append(None)
            errors += 1
    out["seconds"] = time.perf_counter() - t
    out["peak_mb"] = _peak_mb()
    out["errors"] = errors
    if correctness:
        out["wrong"] = _wrong(records)
    return out


def _close(field: str, got: float | None, want: float | None) -> bool:
    if want is None:
        return got is None or field in ("yaw", "pitch", "roll") and got is not None
    if got is None or not math.isfinite(got):
        return False
    tol = {"lat": 1e-7, "lon": 1e-7, "time": 1e-3, "yaw": 0.006, "pitch": 0.006, "roll": 0.006}.get(field, 1e-3)
    d = abs(got - want)
    return (min(d, 360 - d) if field == "yaw" else d) <= tol


def _wrong(records: list[dict[str, float | None] | None]) -> dict[str, dict[str, int]]:
    """Per layout, per field: photos whose value is not the truth (a raised photo counts as wrong everywhere)."""
    out: dict[str, dict[str, int]] = {}
    for i, r in enumerate(records):
        _, layout = shot(i)
        w = truth(i)
        bad = out.setdefault(layout, dict.fromkeys(FIELDS, 0))
        for k in FIELDS:
            if r is None or not _close(k, r.get(k), w[k]):
                bad[k] += 1
    return out


def _wrong_aerosurvey(flight: Any, per_photo: bool = False) -> dict[str, Any]:
    """Per layout, per field: photos whose value is not the truth; `per_photo`: file → wrong fields."""
    out: dict[str, Any] = {}
    ev = flight.events
    for j, f in enumerate(flight.files):
        i = int(Path(f).stem.split("_")[1]) - 1
        _, layout = shot(i)
        w = truth(i)
        got = {"lat": ev.lat[j], "lon": ev.lon[j], "alt": ev.alt_m[j], "rel_alt": ev.rel_alt_m[j],
               "time": flight.capture_s[j], "yaw": ev.yaw[j], "pitch": ev.pitch[j], "roll": ev.roll[j],
               "rtk_flag": flight.rtk_flag[j], "std_lon": flight.std_lon_m[j], "std_lat": flight.std_lat_m[j],
               "std_hgt": flight.std_hgt_m[j]}
        bad = out.setdefault(Path(f).name if per_photo else layout, dict.fromkeys(FIELDS, 0))
        for k in FIELDS:
            v = got[k]
            v = None if v is None or (isinstance(v, float) and math.isnan(v)) else float(v)
            if layout == "plain" and k in ("pitch", "roll"):
                continue  # aerosurvey assumes a nadir camera where the photo records no attitude (documented)
            if not _close(k, v, w[k]):
                bad[k] += 1
        if per_photo and not any(bad.values()):
            out[Path(f).name] = {}
    return out if not per_photo else {k: {f: n for f, n in v.items() if n} for k, v in out.items()}


def damaged_outcomes(candidate: str, copies: int, seed: int) -> dict[str, int]:
    """Over damaged copies of the first photos (even ones cut off at a random place, odd ones with a
    run of 1-64 random bytes written over a random place of the metadata): how many the candidate
    raised on, returned with every field right (the damage missed what is read), or returned with a
    field altered (silently wrong). aerosurvey's reader: skipped (with the reason), right, altered."""
    rnd = random.Random(seed)
    out = {"raised": 0, "skipped": 0, "right": 0, "altered": 0}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(copies):
            s, layout = shot(k)
            data = bytearray(photo_bytes(s, layout))
            meta_end = len(data) - len(pw.TINY_IMAGE)
            if k % 2 == 0:
                data = data[:rnd.randrange(2, len(data))]
            else:
                at = rnd.randrange(2, meta_end)
                run = rnd.randrange(1, 65)
                data[at:at + run] = bytes(rnd.randrange(256) for _ in range(run))[:len(data[at:at + run])]
            (Path(tmp) / f"DJI_{k + 1:04d}.JPG").write_bytes(bytes(data))
        if candidate == "aerosurvey":
            from aerosurvey.errors import InputError
            from aerosurvey.flight.photos import read_photo_flight

            try:
                flight = read_photo_flight(Path(tmp))
            except InputError:
                out["skipped"] = copies
                return out
            wrong = _wrong_aerosurvey(flight, per_photo=True)
            out["skipped"] = copies - len(flight.files)
            out["altered"] = sum(1 for v in wrong.values() if v)
            out["right"] = len(flight.files) - out["altered"]
            return out
        for k in range(copies):
            try:
                r = CANDIDATES[candidate](Path(tmp) / f"DJI_{k + 1:04d}.JPG")
            except Exception:  # a candidate that raises on a damaged photo: counted
                out["raised"] += 1
                continue
            w = truth(k)
            out["right" if all(_close(f, r.get(f), w[f]) for f in FIELDS) else "altered"] += 1
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--photos", type=int, default=2000)
    ap.add_argument("--pixel-mb", type=float, default=8.0, help="each photo's size (sparse image data)")
    ap.add_argument("--candidates", default=",".join([*CANDIDATES, "aerosurvey"]))
    ap.add_argument("--no-correctness", action="store_true")
    ap.add_argument("--damaged", type=int, default=400, help="damaged copies per candidate (0: none)")
    ap.add_argument("--flat", action="store_true", help="aerosurvey's peak memory at a quarter and at all the photos")
    ap.add_argument("--child", nargs=2, metavar=("CANDIDATE", "FOLDER"), help=argparse.SUPPRESS)
    ap.add_argument("--damaged-child", metavar="CANDIDATE", help=argparse.SUPPRESS)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child[0], Path(args.child[1]), not args.no_correctness)))
        return
    if args.damaged_child:
        print(json.dumps(damaged_outcomes(args.damaged_child, args.damaged, args.seed)))
        return
    names = [c for c in args.candidates.split(",") if c]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "photos"
        folder.mkdir()
        t = time.perf_counter()
        write_photos(folder, args.photos, args.pixel_mb)
        print(f"{args.photos} photos of {args.pixel_mb:g} MB written in {time.perf_counter() - t:.1f} s ({folder})")
        rows = []
        for c in names:
            # the page cache is warm for every candidate alike: the folder was just written
            extra = ["--no-correctness"] if args.no_correctness else []
            p = subprocess.run([sys.executable, __file__, "--child", c, str(folder), *extra], capture_output=True, text=True)
            if p.returncode:
                print(f"{c}: failed: {p.stderr.strip().splitlines()[-1] if p.stderr.strip() else p.returncode}")
                continue
            r = json.loads(p.stdout.strip().splitlines()[-1])
            if args.damaged:
                q = subprocess.run([sys.executable, __file__, "--damaged-child", c, "--damaged", str(args.damaged),
                                    "--seed", str(args.seed)], capture_output=True, text=True)
                r["damaged"] = json.loads(q.stdout.strip().splitlines()[-1]) if q.returncode == 0 else None
            rows.append(r)
        base = next((r["seconds"] for r in rows if r["candidate"] == "pillow-lxml"), None)
        print(f"\n{'candidate':15} {'seconds':>8} {'ms/photo':>9} {'vs pillow-lxml':>15} {'peak MB':>8} {'raised':>7}")
        for r in rows:
            ratio = f"{r['seconds'] / base:.2f}" if base else "-"
            print(f"{r['candidate']:15} {r['seconds']:8.2f} {1000 * r['seconds'] / r['photos']:9.3f} {ratio:>15} "
                  f"{r['peak_mb']:8.1f} {r.get('errors', 0):7d}")
        if args.damaged:
            print(f"\n{args.damaged} damaged copies (half cut off, half with random bytes over the metadata):")
            for r in rows:
                d = r.get("damaged")
                if d:
                    print(f"  {r['candidate']:15} raised {d['raised']:4d}, skipped {d['skipped']:4d}, every field right "
                          f"{d['right']:4d}, a field altered {d['altered']:4d}")
        if not args.no_correctness:
            print("\nwrong values (photos per layout; a field the layout does not hold must come back empty):")
            for r in rows:
                for layout, bad in sorted(r["wrong"].items()):
                    wrong = {k: v for k, v in bad.items() if v}
                    print(f"  {r['candidate']:15} {layout:13} {wrong or 'none'}")
        if args.flat and "aerosurvey" in names:
            quarter = Path(tmp) / "quarter"
            quarter.mkdir()
            for f in sorted(folder.glob("*.JPG"))[: args.photos // 4]:
                os.link(f, quarter / f.name)
            for label, d in ((f"{args.photos // 4} photos", quarter), (f"{args.photos} photos", folder)):
                p = subprocess.run([sys.executable, __file__, "--child", "aerosurvey", str(d), "--no-correctness"],
                                   capture_output=True, text=True, check=True)
                r = json.loads(p.stdout.strip().splitlines()[-1])
                print(f"aerosurvey peak memory, {label}: {r['peak_mb']:.1f} MB ({r['seconds']:.2f} s)")


if __name__ == "__main__":
    main()
