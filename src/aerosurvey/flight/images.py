"""Match image files to camera events by EXIF capture time, and write geotag files.

The camera's clock is not the autopilot's: the offset is estimated by voting over all
image/event time differences (the offset that pairs the most images with an event
within `tolerance_s` wins), so a few missing images or extra events do not disturb it.
Without usable times, images are matched to events by order, and the report says so.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.flight.events import Events

IMAGE_SUFFIXES = {".jpg", ".jpeg", ".tif", ".tiff", ".dng"}
JPEG_SUFFIXES = {".jpg", ".jpeg"}


def capture_time(path: Path) -> float | None:
    """EXIF DateTimeOriginal (+ SubSecTimeOriginal) as seconds, or None."""
    from PIL import Image

    try:
        with Image.open(path) as im:
            exif = im.getexif()
            sub = exif.get_ifd(0x8769)
    except OSError:
        return None
    text = sub.get(36867) or exif.get(306)  # DateTimeOriginal, else DateTime
    if not text:
        return None
    try:
        t = dt.datetime.strptime(str(text).strip(), "%Y:%m:%d %H:%M:%S").replace(tzinfo=dt.UTC).timestamp()
    except ValueError:
        return None
    frac = str(sub.get(37521, "") or "").strip()  # SubSecTimeOriginal
    return t + (float("0." + frac) if frac.isdigit() else 0.0)


@dataclass(frozen=True)
class ImageMatch:
    files: list[Path]
    event_of: list[int | None]  # event index of each file
    method: str
    offset_s: float | None
    unmatched_files: list[str]
    unmatched_events: list[int]


def match_images(files: list[Path], ev: Events, tolerance_s: float = 0.5) -> ImageMatch:
    times = [capture_time(f) for f in files]
    have = [i for i, t in enumerate(times) if t is not None]
    ev_t = ev.utc_s if ev.utc_s is not None else ev.time_s
    best: tuple[int, float | None] = (0, None)
    if len(have) >= 2 and len(ev_t) >= 2:
        it = np.array([times[i] for i in have])
        diffs = (it[:, None] - ev_t[None, :]).ravel()
        # vote: the offset bin holding the most image-event differences
        edges = np.arange(diffs.min() - tolerance_s, diffs.max() + 2 * tolerance_s, tolerance_s)
        hist, edges = np.histogram(diffs, edges)
        pair = hist[:-1] + hist[1:]
        k = int(np.argmax(pair))
        d = float(np.median(diffs[(diffs >= edges[k]) & (diffs < edges[k + 2])]))
        n = int(np.sum(np.min(np.abs(it[:, None] - (ev_t[None, :] + d)), axis=1) <= tolerance_s))
        best = (n, d)
    event_of: list[int | None] = [None] * len(files)
    voted, offset = best
    if offset is not None and voted >= 0.5 * min(len(have), len(ev_t)):
        d = offset
        # refine the offset as the median difference of the voted pairs, then pair greedily
        it = np.array([times[i] for i in have])
        near = np.argmin(np.abs(it[:, None] - (ev_t[None, :] + d)), axis=1)
        ok = np.abs(it - (ev_t[near] + d)) <= tolerance_s
        d = float(np.median(it[ok] - ev_t[near[ok]]))
        used = set()
        for i, ti in zip(have, it.tolist()):
            j = int(np.argmin(np.abs(ev_t + d - ti)))
            if abs(ev_t[j] + d - ti) <= tolerance_s and j not in used:
                event_of[i] = j
                used.add(j)
        method, offset = "capture time", d
    else:
        for i in range(min(len(files), len(ev_t))):
            event_of[i] = i
        method, offset = "order (capture times unusable)", None
    matched = {j for j in event_of if j is not None}
    return ImageMatch(files, event_of, method, offset, [f.name for f, j in zip(files, event_of) if j is None],
                      [j for j in range(len(ev_t)) if j not in matched])


def list_images(folder: Path) -> list[Path]:
    if not folder.is_dir():
        raise InputError(f"--images {folder}: not a folder")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise InputError(f"--images {folder}: no images ({', '.join(sorted(IMAGE_SUFFIXES))})")
    return files


def geotag_images(m: ImageMatch, ev: Events, dest: Path) -> dict[str, Any]:
    """Write each matched JPEG into `dest` with EXIF GPS tags from its camera event.

    Each file is written atomically (a temporary file and a rename), so `dest` may be the
    images' own folder (in place). Only the EXIF segment changes (see geotag_exif). Files
    that cannot be tagged (TIFF/DNG, damaged JPEGs) are skipped with the reason; unmatched
    images are not copied. Returns the report's `geotag` section.
    """
    from aerosurvey.fileio import atomic_write_bytes
    from aerosurvey.flight.geotag_exif import GeotagError, GpsFix, ends_with_eoi, geotag_jpeg

    written, skipped, notes = [], [], []
    for f, j in zip(m.files, m.event_of):
        if j is None:
            continue
        if f.suffix.lower() not in JPEG_SUFFIXES:
            skipped.append({"file": f.name, "reason": f"not a JPEG ({f.suffix}): EXIF GPS tags are written into JPEGs only"})
            continue
        data = f.read_bytes()
        fix = GpsFix(float(ev.lat[j]), float(ev.lon[j]), float(ev.alt_m[j]), float(ev.yaw[j]))
        try:
            out = geotag_jpeg(data, fix)
        except GeotagError as exc:
            skipped.append({"file": f.name, "reason": str(exc)})
            continue
        if not ends_with_eoi(data):
            notes.append({"file": f.name, "note": "no end-of-image marker: the image data may be cut off (tagged as it is)"})
        atomic_write_bytes(dest / f.name, out)
        written.append(f.name)
    return {"folder": str(dest), "written": len(written), "files": written, "skipped": skipped, "notes": notes,
            "unmatched_not_copied": list(m.unmatched_files)}
