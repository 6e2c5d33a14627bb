"""The camera model and the camera database (data/cameras.toml)."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

from aerosurvey.errors import InputError, bad_value

#: Pixel pitches from the sensor width and from the sensor height may differ by this
#: much on real cameras (rounded published sensor sizes) before we call a record suspect.
PITCH_MISMATCH_TOLERANCE = 0.03

#: Pixel pitches outside this range (um) mean a unit slip (sensor in cm or inches, image
#: size in thousands); real frame cameras, thermal ones included, sit well inside it.
PITCH_RANGE_UM = (0.5, 30.0)

#: Shutter kinds: rolling shutters skew images taken in motion, so the planner and QA
#: need to know which one a camera has.
SHUTTERS = ("global", "mechanical", "rolling", "unknown")

#: Database ids: lower-case words joined by '-', easy to type in a spec and on the command line.
_ID_PATTERN = re.compile(r"^[a-z0-9]+(?:-[a-z0-9]+)*$")


@dataclass(frozen=True)
class Camera:
    """A nadir frame camera. Sizes in mm, image in pixels, times in seconds.

    `width` is the sensor's long side. `min_cycle_s` is the shortest time between two
    pictures the camera sustains; `exposure_s` the exposure time used for the motion
    blur limit (the spec can override both).
    """

    id: str
    name: str
    sensor_width_mm: float
    sensor_height_mm: float
    image_width_px: int
    image_height_px: int
    focal_mm: float
    min_cycle_s: float = 2.0
    exposure_s: float = 1.0 / 1000.0
    shutter: str = "unknown"  # one of SHUTTERS
    source: str = ""
    notes: str = ""

    @property
    def pixel_pitch_mm(self) -> float:
        """Pixel pitch from the long side (docs/planning.md)."""
        return self.sensor_width_mm / self.image_width_px

    @property
    def pixel_pitch_um(self) -> float:
        """Pixel pitch in micrometres, the unit camera data sheets use."""
        return self.pixel_pitch_mm * 1000.0

    @property
    def pixel_pitch_height_um(self) -> float:
        """Pixel pitch from the short side, to compare with the long-side pitch."""
        return self.sensor_height_mm / self.image_height_px * 1000.0

    @property
    def pitch_mismatch(self) -> float:
        """Relative difference of the pitch from the width and from the height."""
        p_w = self.sensor_width_mm / self.image_width_px
        p_h = self.sensor_height_mm / self.image_height_px
        return abs(p_w - p_h) / p_w


_REQUIRED = ("name", "sensor_width_mm", "sensor_height_mm", "image_width_px", "image_height_px", "focal_mm")
_POSITIVE_FLOATS = ("sensor_width_mm", "sensor_height_mm", "focal_mm", "min_cycle_s", "exposure_s")
_TEXT = ("source", "notes")
_ALLOWED = _REQUIRED + ("min_cycle_s", "exposure_s", "shutter") + _TEXT


def _positive_number(where: str, key: str, value: Any) -> float:
    """A finite positive number (TOML int or float, not bool), or an error naming key and value."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise bad_value(f"{where}.{key}", value, "a positive number")
    return float(value)


def _pixels(where: str, key: str, value: Any) -> int:
    """A positive whole pixel count; 6000.0 is refused so a typo in the unit shows."""
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise bad_value(f"{where}.{key}", value, "a positive whole number of pixels")
    return value


def _text(where: str, key: str, value: Any, required: bool) -> str:
    """A string; `name` must also be non-blank because listings and reports show it."""
    if not isinstance(value, str) or (required and not value.strip()):
        raise bad_value(f"{where}.{key}", value, "a non-empty string" if required else "a string")
    return value


def camera_from_mapping(cam_id: str, data: Mapping[str, Any], where: str) -> Camera:
    """Build a validated Camera from a TOML table; `where` names it in errors.

    Every error names the offending key and its value, so a user can find the line.
    """
    if not isinstance(data, Mapping):
        raise bad_value(where, data, "a table of camera keys")
    unknown = sorted(set(data) - set(_ALLOWED))
    if unknown:
        given = ", ".join(f"{k} = {data[k]!r}" for k in unknown)
        raise InputError(f"{where}: unknown key(s) {given}; allowed: {', '.join(_ALLOWED)}")
    for key in _REQUIRED:
        if key not in data:
            raise InputError(f"{where}: missing key '{key}' (required: {', '.join(_REQUIRED)})")
    values: dict[str, Any] = {}
    for key in _POSITIVE_FLOATS:
        if key in data:
            values[key] = _positive_number(where, key, data[key])
    for key in ("image_width_px", "image_height_px"):
        values[key] = _pixels(where, key, data[key])
    if values["image_width_px"] < values["image_height_px"]:
        raise InputError(
            f"{where}.image_width_px = {values['image_width_px']} is smaller than "
            f"image_height_px = {values['image_height_px']}: give the long side as width"
        )
    if values["sensor_width_mm"] < values["sensor_height_mm"]:
        raise InputError(
            f"{where}.sensor_width_mm = {data['sensor_width_mm']!r} is smaller than "
            f"sensor_height_mm = {data['sensor_height_mm']!r}: give the long side as width"
        )
    shutter = data.get("shutter", "unknown")
    if shutter not in SHUTTERS:
        raise bad_value(f"{where}.shutter", shutter, f"one of {', '.join(SHUTTERS)}")
    name = _text(where, "name", data["name"], required=True)
    texts = {key: _text(where, key, data[key], required=False) for key in _TEXT if key in data}
    cam = Camera(id=cam_id, name=name, shutter=shutter, **texts, **values)  # type: ignore[arg-type]  # keys checked above
    if cam.exposure_s >= cam.min_cycle_s:
        raise InputError(
            f"{where}.exposure_s = {cam.exposure_s:g} is not shorter than min_cycle_s = {cam.min_cycle_s:g}: "
            "a camera cannot expose longer than its cycle"
        )
    lo, hi = PITCH_RANGE_UM
    if not lo <= cam.pixel_pitch_um <= hi:
        raise InputError(
            f"{where}: pixel pitch sensor_width_mm / image_width_px = {cam.sensor_width_mm:g} / "
            f"{cam.image_width_px} = {cam.pixel_pitch_um:.3g} um is outside {lo:g}-{hi:g} um; check the units"
        )
    if cam.pitch_mismatch > PITCH_MISMATCH_TOLERANCE:
        raise InputError(
            f"{where}: pixel pitch from sensor_width_mm / image_width_px ({cam.pixel_pitch_um:.3f} um) and "
            f"from sensor_height_mm / image_height_px ({cam.pixel_pitch_height_um:.3f} um) differ by "
            f"{cam.pitch_mismatch:.1%} (more than {PITCH_MISMATCH_TOLERANCE:.0%}); check the sensor size and image size"
        )
    return cam


def cameras_from_toml(text: str, origin: str) -> dict[str, Camera]:
    """Parse and validate a whole camera database; `origin` names the file in errors."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{origin}: not valid TOML: {exc}") from exc
    cams: dict[str, Camera] = {}
    for cid, table in sorted(raw.items()):
        where = f"{origin} [{cid}]"
        if not _ID_PATTERN.match(cid):
            raise bad_value(where, cid, "an id of lower-case words joined by '-'")
        cams[cid] = camera_from_mapping(cid, table, where)
    return cams


@lru_cache(maxsize=1)
def database() -> dict[str, Camera]:
    """All cameras shipped in data/cameras.toml, by id."""
    text = resources.files("aerosurvey").joinpath("data/cameras.toml").read_text(encoding="utf-8")
    return cameras_from_toml(text, "cameras.toml")


def get_camera(cam_id: str) -> Camera:
    """A database camera by id, or an error naming the id and the closest ids."""
    db = database()
    if cam_id in db:
        return db[cam_id]
    key = str(cam_id).strip().lower().replace(" ", "-").replace("_", "-")
    if key in db:
        return db[key]
    import difflib  # only for this error: 1.3 ms of every `aerosurvey plan` otherwise

    close = [c for c in db if key and (key in c or c in key)]
    close += [c for c in difflib.get_close_matches(key, list(db), n=5, cutoff=0.6) if c not in close]
    hint = f"; did you mean {', '.join(close[:5])}?" if close else "; `aerosurvey cameras` lists them"
    raise InputError(f"camera = {cam_id!r} is not in the camera database{hint}", key="camera.model")
