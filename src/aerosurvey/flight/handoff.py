"""Files for photogrammetry software from a flight's matched images: camera poses, GCP marks.

Every file names images by their file names (never by station ids), and gives each camera's
orientation, not the vehicle's: yaw, pitch, roll in the convention Pix4D, Metashape and
OpenDroneMap share (0, 0, 0 is a camera looking straight down with the image's top to the
north; pitch 90 looks ahead; see `capture.Attitudes.of_body`), the yaw a true bearing as the
autopilot logs it (each program turns it into its projection's grid itself). A camera on a
gimbal is (vehicle yaw + the gimbal's planned yaw against the nose, 90 + the gimbal's planned
pitch, 0): (vehicle yaw, 0, 0) looking straight down, (yaw, 45, 0) for an oblique pitched to
−45°; a camera fixed to the body (`--fixed-camera`) has the vehicle's yaw, pitch and roll.
The mount (landscape, portrait) changes neither: in the capture
model the image's top is towards the nose in both. A flight recorded by its photos
(flight/photos.py) recorded each camera's own attitude: (gimbal yaw, 90 + gimbal pitch, 0).

The accuracies are --accuracy-xy/-z for every image, or each image's own where the flight
recorded them (a photo flight's RTK standard deviations, `accuracies`).

- geo.txt (OpenDroneMap): the CRS line, then `image lon lat alt yaw pitch roll horizontal
  vertical` (opendm/geo.py GeoFile: columns 5-7 are read as the angles, 8-9 as accuracies).
- pix4d_geolocation.csv: `imagename,latitude,longitude,altitude,yaw,pitch,roll,accuracy
  horizontal,accuracy vertical`, no header but one '#' comment line, as Pix4D's "image
  geolocation and orientation import format" (geographic coordinates, Yaw/Pitch/Roll and
  accuracy values) gives it.
- metashape_reference.csv: a '#' header line, then `label,longitude,latitude,altitude,yaw,
  pitch,roll,accuracy x,accuracy y,accuracy z`: Metashape's Import Reference columns
  ``nxyzabcXYZ`` (n label, x/y/z coordinates, a/b/c angles, X/Y/Z accuracies).
- gcp_predictions.csv: for each GCP, the images that see it and where (pixel column, row),
  from the flown camera poses and the ground (a DEM or flat) through `capture.image_points`:
  what a marking tool needs to find the targets.
- gcp_list.txt (OpenDroneMap): only from image measurements, a marking tool's CSV of gcp id,
  image, pixel x, pixel y, with the GCPs' surveyed coordinates (opendm/gcp.py GCPFile: the CRS
  line, then `x y z pixel_x pixel_y image [name]`; make_filtered_copy keeps the lines whose
  image is in the images folder and drops the file below 3 of them).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.flight.coverage import Aim
from aerosurvey.flight.events import Events
from aerosurvey.flight.images import ImageMatch
from aerosurvey.plan import capture

#: ODM drops a gcp_list.txt with fewer image marks than this (GCPFile.make_filtered_copy's min_images).
ODM_MIN_MARKS = 3


@dataclass(frozen=True)
class CameraPoses:
    """Matched images: file name, WGS84 position, altitude above mean sea level, and camera
    orientation (degrees, see the module docstring); `std_m`, where known, each image's own
    position accuracy (rows of east, north, up standard deviations in metres, NaN where not
    known: the files take the --accuracy-xy/-z defaults there)."""

    images: tuple[str, ...]
    lon: np.ndarray
    lat: np.ndarray
    alt_m: np.ndarray
    yaw: np.ndarray
    pitch: np.ndarray
    roll: np.ndarray
    std_m: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.images)


def camera_poses(m: ImageMatch, ev: Events, fixed_camera: bool, aim: Aim | None = None,
                 std_m: np.ndarray | None = None) -> CameraPoses:
    """The matched images' camera poses; images without a position are left out. `aim`: each
    event's planned gimbal aim (without one, a gimbal camera looks straight down along the nose);
    `std_m`: each event's position accuracy (rows of east, north, up standard deviations, NaN
    where not known), as a photo flight's RTK solution records it."""
    pairs = [(f.name, j) for f, j in zip(m.files, m.event_of)
             if j is not None and math.isfinite(ev.lon[j]) and math.isfinite(ev.lat[j]) and math.isfinite(ev.alt_m[j])]
    k = np.array([j for _, j in pairs], int)
    yaw = np.nan_to_num(np.asarray(ev.yaw, float)[k]) % 360.0
    if fixed_camera:
        pitch, roll = (np.nan_to_num(np.asarray(a, float)[k]) for a in (ev.pitch, ev.roll))
    elif aim is not None:
        yaw = (yaw + aim.yaw_deg[k]) % 360.0
        pitch, roll = 90.0 + aim.pitch_deg[k], np.zeros(len(k))
    else:
        pitch, roll = np.zeros(len(k)), np.zeros(len(k))
    return CameraPoses(tuple(n for n, _ in pairs), np.asarray(ev.lon, float)[k], np.asarray(ev.lat, float)[k],
                       np.asarray(ev.alt_m, float)[k], yaw, pitch, roll,
                       np.asarray(std_m, float).reshape(-1, 3)[k] if std_m is not None else None)


def _check_accuracy(accuracy_xy: float, accuracy_z: float) -> None:
    for name, v in (("--accuracy-xy", accuracy_xy), ("--accuracy-z", accuracy_z)):
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"{name} = {v!r} is not allowed: a standard deviation in metres, more than 0")


def accuracies(p: CameraPoses, accuracy_xy: float, accuracy_z: float) -> np.ndarray:
    """Each image's (east, north, horizontal, up) standard deviation in metres: its own where
    known and more than 0, else the defaults. The horizontal one is the larger of east and north,
    as OpenDroneMap takes DJI's RtkStdLon and RtkStdLat."""
    _check_accuracy(accuracy_xy, accuracy_z)
    own = p.std_m if p.std_m is not None else np.full((len(p), 3), np.nan)
    known = np.isfinite(own) & (own > 0)
    east = np.where(known[:, 0], own[:, 0], accuracy_xy)
    north = np.where(known[:, 1], own[:, 1], accuracy_xy)
    horizontal = np.where(known[:, 0] & known[:, 1], np.maximum(east, north), accuracy_xy)
    return np.column_stack([east, north, horizontal, np.where(known[:, 2], own[:, 2], accuracy_z)])


def _pose_lines(p: CameraPoses, accuracy_xy: float, accuracy_z: float, first: str, columns: Sequence[str], sep: str) -> str:
    """`first`, then a line per image of the `columns` (names below) joined by `sep`."""
    acc = accuracies(p, accuracy_xy, accuracy_z)
    lines = [first]
    for i, name in enumerate(p.images):
        cells = {"image": name, "lon": f"{p.lon[i]:.8f}", "lat": f"{p.lat[i]:.8f}", "alt": f"{p.alt_m[i]:.3f}",
                 "yaw": f"{p.yaw[i]:.2f}", "pitch": f"{p.pitch[i]:.2f}", "roll": f"{p.roll[i]:.2f}",
                 "acc_x": f"{acc[i, 0]:g}", "acc_y": f"{acc[i, 1]:g}", "acc_xy": f"{acc[i, 2]:g}", "acc_z": f"{acc[i, 3]:g}"}
        lines.append(sep.join(cells[c] for c in columns))
    return "\n".join(lines) + "\n"


def geo_txt(p: CameraPoses, accuracy_xy: float, accuracy_z: float) -> str:
    """OpenDroneMap's geo.txt (see the module docstring)."""
    return _pose_lines(p, accuracy_xy, accuracy_z, "EPSG:4326",
                       ("image", "lon", "lat", "alt", "yaw", "pitch", "roll", "acc_xy", "acc_z"), " ")


def pix4d_csv(p: CameraPoses, accuracy_xy: float, accuracy_z: float) -> str:
    """Pix4D's image geolocation and orientation file (see the module docstring)."""
    return _pose_lines(p, accuracy_xy, accuracy_z,
                       "#imagename,latitude,longitude,altitude,yaw,pitch,roll,accuracy horizontal,accuracy vertical",
                       ("image", "lat", "lon", "alt", "yaw", "pitch", "roll", "acc_xy", "acc_z"), ",")


def metashape_csv(p: CameraPoses, accuracy_xy: float, accuracy_z: float) -> str:
    """Metashape's camera reference file, columns nxyzabcXYZ (see the module docstring)."""
    return _pose_lines(p, accuracy_xy, accuracy_z,
                       "#label,longitude,latitude,altitude,yaw,pitch,roll,accuracy x,accuracy y,accuracy z",
                       ("image", "lon", "lat", "alt", "yaw", "pitch", "roll", "acc_x", "acc_y", "acc_z"), ",")


def read_geo_txt(text: str, where: str) -> CameraPoses:
    """The camera poses of a geo.txt `log ingest` wrote (EPSG:4326, nine columns a line)."""
    lines = [ln.strip() for ln in text.strip().splitlines()]
    if not lines or lines[0] != "EPSG:4326":
        raise InputError(f"{where}: the first line is {lines[0] if lines else ''!r}, not 'EPSG:4326': not a geo.txt of "
                         "`aerosurvey log ingest --images`")
    names, values = [], []
    for k, ln in enumerate(lines[1:], start=2):
        if not ln or ln.startswith("#"):
            continue
        parts = ln.split()
        if len(parts) < 7:
            raise InputError(f"{where} line {k}: {len(parts)} columns; image, longitude, latitude, altitude, yaw, pitch, "
                             "roll are needed")
        try:
            values.append([float(v) for v in parts[1:7]])
        except ValueError:
            raise InputError(f"{where} line {k}: {ln!r} has a value that is not a number") from None
        names.append(parts[0])
    if not names:
        raise InputError(f"{where}: no images")
    a = np.array(values, float)
    return CameraPoses(tuple(names), a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4], a[:, 5])


@dataclass(frozen=True)
class GroundPoint:
    """A control point: id, planning-CRS x and y, and its ground height above mean sea level."""

    id: str
    x: float
    y: float
    z: float


@dataclass(frozen=True)
class Mark:
    """Where a GCP is (or is predicted to be) in an image: pixel column and row from the image's top-left corner."""

    gcp: str
    image: str
    col: float
    row: float


def predict_marks(poses: CameraPoses, points: Sequence[GroundPoint], optics: capture.Optics, crs: str,
                  grid_scale: float = 1.0) -> list[Mark]:
    """Each GCP in every image that sees it, with the pixel where it should appear (the capture
    model's projection from the flown camera pose; lens distortion is not modelled). Per GCP,
    the images in flight order."""
    from aerosurvey.reproject import planar

    if not points or not len(poses):
        return []
    grid = planar(crs)
    x, y = grid.xy(poses.lon, poses.lat)
    # the poses' yaw is a true bearing; the capture model turns cameras in the grid
    attitudes = capture.Attitudes.of_body(grid.grid_bearing(poses.yaw, x, y), poses.pitch, poses.roll)
    photos = capture.Photos(np.asarray(x, float), np.asarray(y, float), poses.alt_m, attitudes)
    ip = capture.image_points(photos, optics, np.array([p.x for p in points]), np.array([p.y for p in points]),
                              np.array([p.z for p in points]), grid_scale)
    out = []
    for j, p in enumerate(points):
        for i in np.flatnonzero(ip.seen[:, j]):
            out.append(Mark(p.id, poses.images[i], round(float(ip.col[i, j]), 1), round(float(ip.row[i, j]), 1)))
    return out


def predictions_csv(marks: Sequence[Mark]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["gcp", "image", "col", "row"])
    for m in marks:
        w.writerow([m.gcp, m.image, f"{m.col:.1f}", f"{m.row:.1f}"])
    return buf.getvalue()


def read_marks(text: str, where: str) -> list[Mark]:
    """A marking tool's export: CSV of gcp id, image name, pixel x (column), pixel y (row), with or
    without a header line (one whose third cell is not a number)."""
    rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)]
    if rows and not _is_number(rows[0][2] if len(rows[0]) > 2 else ""):
        rows = rows[1:]
    marks = []
    for k, r in enumerate(rows, start=1):
        if len(r) < 4:
            raise InputError(f"{where} row {k}: {r!r} has {len(r)} cells; gcp id, image, pixel x, pixel y are needed")
        gcp, image, px, py = (c.strip() for c in r[:4])
        if not (_is_number(px) and _is_number(py)) or float(px) < 0 or float(py) < 0:
            raise InputError(f"{where} row {k}: pixel x {px!r}, y {py!r} are not allowed: pixel coordinates, 0 or more")
        if not gcp or not image or any(c.isspace() for c in gcp + image):
            raise InputError(f"{where} row {k}: gcp {gcp!r}, image {image!r} are not allowed: names without spaces "
                             "(gcp_list.txt separates its columns by spaces)")
        marks.append(Mark(gcp, image, float(px), float(py)))
    return marks


def _is_number(s: str) -> bool:
    try:
        return math.isfinite(float(s))
    except ValueError:
        return False


def odm_gcp_list(marks: Sequence[Mark], surveyed: dict[str, tuple[float, float, float]], crs: str, where: str,
                 images: Sequence[str] | None = None) -> str:
    """OpenDroneMap's gcp_list.txt from image marks and the GCPs' surveyed coordinates (x, y, z
    in `crs`). Every mark's GCP must be surveyed and, when `images` (the file names in the
    images folder) is given, its image must be one of them; fewer than 3 marks is refused
    (ODM would drop the file)."""
    missing = sorted({m.gcp for m in marks} - set(surveyed))
    if missing:
        raise InputError(f"{where}: GCP(s) {', '.join(missing[:5])} have marks but no surveyed coordinates; "
                         f"surveyed: {', '.join(sorted(surveyed)[:10]) or 'none'}")
    if images is not None:
        unknown = sorted({m.image for m in marks} - set(images))
        if unknown:
            raise InputError(f"{where}: image(s) {', '.join(unknown[:5])} are not in the images folder "
                             "(ODM keeps only marks of images it has)")
    if len(marks) < ODM_MIN_MARKS:
        raise InputError(f"{where}: {len(marks)} image mark(s); OpenDroneMap drops a gcp_list.txt with fewer than "
                         f"{ODM_MIN_MARKS}")
    lines = [crs]
    for m in marks:
        x, y, z = surveyed[m.gcp]
        lines.append(f"{x:.3f} {y:.3f} {z:.3f} {m.col:.1f} {m.row:.1f} {m.image} {m.gcp}")
    return "\n".join(lines) + "\n"


def read_surveyed(path: Path) -> tuple[str, dict[str, tuple[float, float, float]]]:
    """The GCPs' surveyed coordinates: a CSV with columns id, easting, northing, elevation and crs
    (control_points.csv of `aerosurvey gcp` with an elevation column filled in by the survey).
    Returns the CRS (one for every row) and id → (easting, northing, elevation)."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot be read: {getattr(exc, 'strerror', None) or exc}") from None
    reader = csv.DictReader(io.StringIO(text))
    need = ["id", "easting", "northing", "elevation", "crs"]
    if reader.fieldnames is None or any(c not in reader.fieldnames for c in need):
        raise InputError(f"{path.name}: columns {reader.fieldnames} are not allowed: {', '.join(need)} are needed "
                         "(control_points.csv with the surveyed elevation added)")
    out: dict[str, tuple[float, float, float]] = {}
    crss = set()
    for k, r in enumerate(reader, start=2):
        vals = [r[c] for c in need[1:4]]
        if not all(_is_number(v) for v in vals):
            raise InputError(f"{path.name} line {k}: easting, northing, elevation {vals} must be numbers (the surveyed "
                             "coordinates)")
        out[r["id"]] = (float(vals[0]), float(vals[1]), float(vals[2]))
        crss.add(r["crs"])
    if len(crss) != 1:
        raise InputError(f"{path.name}: CRS {sorted(crss)} is not allowed: one CRS for every point")
    return crss.pop(), out
