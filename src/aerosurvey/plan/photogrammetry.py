"""Nadir frame-camera geometry: the one source of truth for GSD, footprint, spacing and speeds.

Formulas are those of docs/planning.md. Heights are above ground, lengths in
metres, times in seconds. Every function is pure and works on floats or numpy arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from aerosurvey.camera import Camera

#: Numerical slack when turning an overlap into a whole number of images.
_EPS = 1e-9

#: Spacing and photo base are shortened by this fraction so that rounding in the mission
#: files (1 cm heights, 1e-8° positions) can never take the overlap below the target.
SAFETY = 1e-3

#: A float, or an array of them (one value per station).
FloatOrArray = TypeVar("FloatOrArray", float, npt.NDArray[np.float64])


def gsd_from_height(height_m: FloatOrArray, camera: Camera) -> FloatOrArray:
    """GSD = H · p / f (metres per pixel)."""
    return gsd_m(height_m, camera.pixel_pitch_mm, camera.focal_mm)


def gsd_at_centre_m(height_m: FloatOrArray, pitch_deg: FloatOrArray, pixel_pitch_mm: float,
                    focal_mm: float) -> np.ndarray:
    """GSD (metres per pixel) at the image centre on level ground, of a camera `height_m` above it pitched
    `pitch_deg` (gimbal convention: −90 straight down), in its coarser direction, along the tilt: the slant
    range H / sin|pitch| times p / f, stretched by 1 / sin|pitch| where the ray meets the ground obliquely,
    so H·p/f / sin²|pitch| (`gsd_m` straight down; twice it at −45°). NaN where the centre ray does not
    meet the ground (pitch 0 or above: a level camera photographs a wall, not the ground)."""
    s = np.sin(np.radians(-np.asarray(pitch_deg, float)))
    nadir = np.asarray(gsd_m(np.asarray(height_m, float), pixel_pitch_mm, focal_mm), float)
    with np.errstate(divide="ignore", invalid="ignore"):
        out: np.ndarray = np.where(s > 0.0, nadir / (s * s), np.nan)
    return out


def height_from_gsd(gsd_m: float, camera: Camera) -> float:
    """H = GSD · f / p."""
    return gsd_m * camera.focal_mm / camera.pixel_pitch_mm


def footprint(height_m: FloatOrArray, camera: Camera, mount: str = "landscape") -> tuple[FloatOrArray, FloatOrArray]:
    """Ground footprint (across track, along track) in metres.

    Landscape puts the sensor's long side across the flight line (wider strips, shorter
    photo base); portrait puts it along the line. Each side is the smaller of N · GSD and
    the published sensor size · H / f: the two differ when a maker rounds the sensor size
    (Sony a6000: 4000 px × 3.917 µm = 15.67 mm, sensor 15.6 mm), and the smaller one
    keeps the overlap at or above the target.
    """
    return footprint_m(height_m, camera.sensor_width_mm, camera.sensor_height_mm, camera.image_width_px,
                       camera.image_height_px, camera.focal_mm, mount)


def turned_footprint(across_m: float, along_m: float, turn_deg: float) -> tuple[float, float]:
    """(across, along) of the largest rectangle square to the flight line inside a footprint
    turned by `turn_deg` against it (a camera whose image top faces a fixed yaw, not the track).

    The footprint is `across_m` × `along_m` square to the nose; turned, the ground it surely
    photographs along a line is this rectangle, so spacing and base laid from it keep the
    overlaps. 0° (or 180°) gives the footprint, 90° its sides swapped.
    """
    t = abs(turn_deg) % 180.0
    t = 180.0 - t if t > 90.0 else t
    w, h = (across_m, along_m) if t <= 45.0 else (along_m, across_m)  # w × h turned by 90° − t is the same ground
    a = math.radians(t if t <= 45.0 else 90.0 - t)
    sin_a, cos_a = math.sin(a), math.cos(a)
    long_side, short_side = max(w, h), min(w, h)
    if short_side <= 2.0 * sin_a * cos_a * long_side or abs(sin_a - cos_a) < 1e-12:
        # the short side touches both long edges: the rectangle's corners lie on them
        half = 0.5 * short_side
        return (half / sin_a, half / cos_a) if w >= h else (half / cos_a, half / sin_a)
    cos_2a = cos_a * cos_a - sin_a * sin_a
    return (w * cos_a - h * sin_a) / cos_2a, (h * cos_a - w * sin_a) / cos_2a


def line_spacing(across_m: float, side_overlap: float) -> float:
    """Distance between neighbouring flight lines: Wg · (1 − side overlap), less SAFETY."""
    return across_m * (1.0 - side_overlap) * (1.0 - SAFETY)


def trigger_distance(along_m: float, forward_overlap: float) -> float:
    """Photo base along the line: Lg · (1 − forward overlap), less SAFETY."""
    return along_m * (1.0 - forward_overlap) * (1.0 - SAFETY)


def max_speed_for_cycle(trigger_distance_m: float, min_cycle_s: float) -> float:
    """The camera must be ready again before the next photo: v ≤ B / t_min."""
    return trigger_distance_m / min_cycle_s


def max_speed_for_blur(gsd_m: float, exposure_s: float, max_blur_px: float) -> float:
    """Motion blur during the exposure stays under k pixels: v ≤ k · GSD / t_exp."""
    return max_blur_px * gsd_m / exposure_s


def trigger_interval(trigger_distance_m: float, ground_speed_ms: float) -> float:
    """Time between photos for a time-triggered camera flying at `ground_speed_ms`."""
    return trigger_distance_m / ground_speed_ms


def images_per_point(overlap: float) -> int:
    """Fewest images that see an interior point for this overlap: ⌊1 / (1 − overlap)⌋.

    With 60 % side overlap every point lies in at least 2 strips, with 75 % forward
    overlap in at least 4 photos of a strip. Coverage checks and edge extensions use it.
    """
    return max(1, math.floor(1.0 / (1.0 - overlap) + _EPS))


@dataclass(frozen=True)
class SpeedLimit:
    """The ground speed to fly and the reason it is what it is."""

    speed_ms: float
    reason: str
    cruise_ms: float
    cycle_limit_ms: float
    blur_limit_ms: float


def survey_speed(
    cruise_ms: float,
    trigger_distance_m: float,
    gsd_m: float,
    camera: Camera,
    max_blur_px: float,
    min_cycle_s: float | None = None,
    exposure_s: float | None = None,
) -> SpeedLimit:
    """The fastest ground speed allowed by the vehicle, the camera cycle and motion blur."""
    cycle = max_speed_for_cycle(trigger_distance_m, min_cycle_s or camera.min_cycle_s)
    blur = max_speed_for_blur(gsd_m, exposure_s or camera.exposure_s, max_blur_px)
    limits = [(cruise_ms, "vehicle cruise speed"), (cycle, "camera cycle time"), (blur, "motion blur")]
    speed, reason = min(limits, key=lambda item: item[0])
    return SpeedLimit(speed, reason, cruise_ms, cycle, blur)


#: ArduPilot checks its distance trigger at 50 Hz (AP_Camera::update in Copter.cpp and
#: Plane.cpp) and takes the picture at the first check past the distance.
TRIGGER_CHECK_HZ = 50.0


#: ArduPilot's flat earth (AP_Common/Location.cpp, Location::get_distance): metres per degree
#: of latitude on its sphere of 6,378,100 m (LOCATION_SCALING_FACTOR is the metres of 1e-7°)
ARDUPILOT_M_PER_DEG = 0.011131884502145034 * 1e7


def ardupilot_distance_m(lon1: FloatOrArray, lat1: FloatOrArray, lon2: FloatOrArray, lat2: FloatOrArray) -> FloatOrArray:
    """The distance ArduPilot measures between two places (Location::get_distance): flat earth,
    the longitude difference scaled by the cosine of the mean latitude (at least 0.01).

    The autopilot's distance trigger counts these metres, and its navigation flies its speed in
    them (positions become metres north and east of its origin the same way). They differ from
    the ground's: along a meridian the sphere's metre is longer than the ellipsoid's, along a
    parallel shorter (ArduPilot measures 0.09 % more north-south and 0.19 % less east-west
    at 49° N, 0.67 % more north-south at the equator, 0.34 % less near the poles), so stations
    are laid in these metres
    (`Site.autopilot_scale`), where the autopilot will fire."""
    dlon = (lon2 - lon1 + 180.0) % 360.0 - 180.0
    scale = np.maximum(np.cos(np.radians((lat1 + lat2) / 2.0)), 0.01)
    d: FloatOrArray = np.hypot(lat2 - lat1, dlon * scale) * ARDUPILOT_M_PER_DEG
    return d


def distance_trigger(base_m: float, speed_ms: float) -> tuple[float, float]:
    """(distance to command, spacing the autopilot then flies), in the autopilot's metres
    (`ardupilot_distance_m`: it measures the distance and flies the speed in them).

    At a steady speed v the checks fall every v/f metres and each picture is taken on the
    first check past the distance, so pictures land a whole number of check steps apart:
    spacing = ceil(command / step) · step. We fly the largest whole number of steps within
    the photo base B (the overlap never drops below target) and command half a step less
    than that, so small speed changes do not change the count of steps; stations are laid
    at that spacing and the photos do not drift from them along a line.
    """
    step = speed_ms / TRIGGER_CHECK_HZ
    steps = math.floor(base_m / step + 1e-9)
    if steps < 2:
        raise ValueError(f"photo base {base_m:.2f} m is under two trigger checks ({step:.2f} m each) at {speed_ms:.1f} m/s")
    spacing = steps * step
    return round(spacing - step / 2.0, 2), spacing


def turn_radius(speed_ms: float, bank_deg: float, g: float = 9.80665) -> float:
    """Coordinated-turn radius of a plane: R = v² / (g · tan φ)."""
    return speed_ms**2 / (g * math.tan(math.radians(bank_deg)))


def plane_lead_in(speed_ms: float, nav_period_s: float, damping: float = 0.75) -> float:
    """Straight approach a plane needs to settle on a line after a turn: three L1 distances.

    ArduPlane's L1 controller looks ζ·P·v/π ahead (NAVL1_DAMPING ζ = 0.75, NAVL1_PERIOD P);
    in SITL a 16 m/s plane's first photos lay 17-20 m off the line with a 45-90 m lead-in
    and 5-6 m off (then within a quarter base) with 150-220 m, i.e. from about three L1
    distances on.
    """
    return 3.0 * l1_distance(speed_ms, nav_period_s, damping)


def l1_distance(speed_ms: float, nav_period_s: float, damping: float = 0.75) -> float:
    """How far ahead ArduPlane's L1 controller looks: ζ·P·v/π (NAVL1_DAMPING ζ, NAVL1_PERIOD P); it turns for the
    next waypoint about this far short of the one it flies to (`Kinematics.reach_m`)."""
    return damping * nav_period_s * speed_ms / math.pi


def stop_distance(speed_ms: float, accel_ms2: float) -> float:
    """Distance a copter needs to reach (or leave) `speed_ms`: v² / (2a)."""
    return speed_ms**2 / (2.0 * accel_ms2)


def distance_from_rest(speed_ms: float, accel_ms2: float, seconds: float) -> float:
    """The most a copter covers in `seconds` from rest, accelerating at `accel_ms2` up to `speed_ms` (the
    jerk limit only slows it): a lead-in this long lasts at least that time."""
    t = speed_ms / accel_ms2
    if seconds <= t:
        return 0.5 * accel_ms2 * seconds**2
    return stop_distance(speed_ms, accel_ms2) + speed_ms * (seconds - t)


# --- The same formulas on plain numbers -------------------------------------------------
# For code that has a camera's numbers but no Camera: the rules read them from a plan's
# manifest (camera.sensor_mm, image_px, focal_mm). The Camera-taking functions above give
# bit-identical results (tests/rules/test_footprint_rule.py); they may delegate here.



def pixel_pitch_mm(sensor_width_mm: float, image_width_px: int) -> float:
    """Pixel pitch from the sensor's long side, p = W / N (docs/planning.md), as Camera.pixel_pitch_mm."""
    return sensor_width_mm / image_width_px


def gsd_m(height_m: FloatOrArray, pitch_mm: float, focal_mm: float) -> FloatOrArray:
    """GSD = H · p / f in metres per pixel, the pitch in millimetres (as gsd_from_height)."""
    return height_m * pitch_mm / focal_mm


def footprint_m(
    height_m: FloatOrArray,
    sensor_width_mm: float,
    sensor_height_mm: float,
    image_width_px: int,
    image_height_px: int,
    focal_mm: float,
    mount: str = "landscape",
) -> tuple[FloatOrArray, FloatOrArray]:
    """Ground footprint (across track, along track) in metres, by the rule of `footprint`.

    Each side is the smaller of N · GSD and the published sensor size · H / f; landscape
    puts the long side across the flight line, portrait along it.
    """
    gsd = gsd_m(height_m, pixel_pitch_mm(sensor_width_mm, image_width_px), focal_mm)
    scale = height_m / focal_mm
    long_side: FloatOrArray = np.minimum(image_width_px * gsd, sensor_width_mm * scale)
    short_side: FloatOrArray = np.minimum(image_height_px * gsd, sensor_height_mm * scale)
    if mount == "landscape":
        return long_side, short_side
    if mount == "portrait":
        return short_side, long_side
    raise ValueError(f"mount must be 'landscape' or 'portrait', not {mount!r}")
