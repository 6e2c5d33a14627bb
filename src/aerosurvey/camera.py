"""The camera model and the camera database (data/cameras.toml)."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any, Mapping

from aerosurvey.errors import InputError, bad_value

#: Pixel pitches from the sensor width and from the sensor height may differ by this
#: much on real cameras (rounded published sensor sizes) before we call a record suspect.
PITCH_MISMATCH_TOLERANCE = 0.03


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
    shutter: str = "unknown"  # "global", "mechanical", "rolling", "unknown"
    source: str = ""
    notes: str = ""

    @property
    def pixel_pitch_mm(self) -> float:
        """Pixel pitch from the long side (domain.md section 1)."""
        return self.sensor_width_mm / self.image_width_px

    @property
    def pixel_pitch_um(self) -> float:
        return self.pixel_pitch_mm * 1000.0

    @property
    def pitch_mismatch(self) -> float:
        """Relative difference of the pitch from the width and from the height."""
        p_w = self.sensor_width_mm / self.image_width_px
        p_h = self.sensor_height_mm / self.image_height_px
        return abs(p_w - p_h) / p_w


_REQUIRED = ("name", "sensor_width_mm", "sensor_height_mm", "image_width_px", "image_height_px", "focal_mm")
_OPTIONAL_FLOATS = ("min_cycle_s", "exposure_s")


def camera_from_mapping(cam_id: str, data: Mapping[str, Any], where: str) -> Camera:
    """Build a validated Camera from a TOML table; `where` names it in errors."""
    unknown = set(data) - set(_REQUIRED) - set(_OPTIONAL_FLOATS) - {"shutter", "source", "notes"}
    if unknown:
        raise InputError(f"{where}: unknown key(s) {sorted(unknown)}; allowed: {sorted(_REQUIRED + _OPTIONAL_FLOATS + ('shutter', 'source', 'notes'))}")
    for key in _REQUIRED:
        if key not in data:
            raise InputError(f"{where}: missing key '{key}'")
    values: dict[str, Any] = {}
    for key in ("sensor_width_mm", "sensor_height_mm", "focal_mm") + _OPTIONAL_FLOATS:
        if key not in data:
            continue
        v = data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            raise bad_value(f"{where}.{key}", v, "a positive number")
        values[key] = float(v)
    for key in ("image_width_px", "image_height_px"):
        v = data[key]
        if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
            raise bad_value(f"{where}.{key}", v, "a positive whole number of pixels")
        values[key] = v
    if values["image_width_px"] < values["image_height_px"] or values["sensor_width_mm"] < values["sensor_height_mm"]:
        raise InputError(
            f"{where}: give the long side as width (sensor {values['sensor_width_mm']} x "
            f"{values['sensor_height_mm']} mm, image {values['image_width_px']} x {values['image_height_px']} px)"
        )
    shutter = data.get("shutter", "unknown")
    if shutter not in ("global", "mechanical", "rolling", "unknown"):
        raise bad_value(f"{where}.shutter", shutter, "one of global, mechanical, rolling, unknown")
    cam = Camera(
        id=cam_id,
        name=str(data["name"]),
        shutter=shutter,
        source=str(data.get("source", "")),
        notes=str(data.get("notes", "")),
        **values,
    )
    if cam.pitch_mismatch > PITCH_MISMATCH_TOLERANCE:
        raise InputError(
            f"{where}: pixel pitch from the width ({cam.sensor_width_mm / cam.image_width_px * 1000:.3f} um) and "
            f"from the height ({cam.sensor_height_mm / cam.image_height_px * 1000:.3f} um) differ by "
            f"{cam.pitch_mismatch:.1%}; check the sensor size and image size"
        )
    return cam


@lru_cache(maxsize=1)
def database() -> dict[str, Camera]:
    """All cameras shipped in data/cameras.toml, by id."""
    text = resources.files("aerosurvey").joinpath("data/cameras.toml").read_text(encoding="utf-8")
    raw = tomllib.loads(text)
    return {cid: camera_from_mapping(cid, table, f"cameras.toml [{cid}]") for cid, table in sorted(raw.items())}


def get_camera(cam_id: str) -> Camera:
    """A database camera by id, or an error listing the close names."""
    db = database()
    if cam_id in db:
        return db[cam_id]
    close = [c for c in db if cam_id.lower().replace(" ", "-") in c or c in cam_id.lower()]
    hint = f"; did you mean {', '.join(close[:5])}?" if close else "; `aerosurvey cameras` lists them"
    raise InputError(f"camera = {cam_id!r} is not in the camera database{hint}")
