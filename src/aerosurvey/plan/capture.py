"""What a photo sees: one model of the camera, its attitude and the ground, for every consumer.

A frame camera is a pinhole: a ray leaves the projection centre through each point of the
sensor's imaging area (the smaller of the pixel grid and the published sensor size, as
`photogrammetry.footprint_m` has it) and meets the ground. The camera's attitude is its own,
not the vehicle's, in the gimbal convention MAVLink and DJI use:

- `yaw_deg`: compass bearing of the image's top edge direction (the direction of flight for
  a camera that looks ahead of the vehicle), clockwise from grid north;
- `pitch_deg`: the optical axis' elevation, -90 straight down (nadir), -45 an oblique looking
  towards the image's top, 0 the horizon;
- `roll_deg`: a turn of the camera about the horizontal line of its yaw, positive tilting the
  optical axis to the right of the image's top.

The rotations are applied pitch (about the level east axis of a camera looking north), then
roll (about the level north axis), then yaw. The mount (landscape, portrait) says
which side of the sensor spans the image's width. The ground is flat at a height per photo,
or a `Ground` (a DEM) whose heights the rays are intersected with by a fixed number of
refinements. Lengths are metres on the ground; `grid_scale` turns them into planning-grid
metres. Lens distortion and the principal point's offset are not modelled.

At pitch -90 over flat ground, a footprint is the nadir rectangle of `footprint_m`, turned to
the yaw, and the GSD is H · p / f everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt
import shapely

from aerosurvey.camera import Camera
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.spec import MOUNTS

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: A ray must point at least this far below the horizon (degrees) to meet the ground: a
#: footprint edge closer to the horizon is unbounded for mapping. A photo with an image corner
#: closer to it (a level or upward-looking camera) has no ground footprint (`bounded_footprints`).
MIN_DEPRESSION_DEG = 5.0

#: Refinements of a ray's meeting with a DEM (each moves it to the ground height found at the
#: previous meeting point).
DEM_REFINEMENTS = 6



class Ground(Protocol):
    """Ground heights (metres, the same datum as the cameras' heights) at planning-CRS points."""

    def height(self, x: FloatArray, y: FloatArray) -> FloatArray: ...


@dataclass(frozen=True)
class Optics:
    """The imaging area and focal length of a camera in its mount: what the rays are made of."""

    width_mm: float  # the imaging area across the image (its width as the image is shown)
    height_mm: float  # the imaging area along the image (top to bottom)
    focal_mm: float
    pixel_mm: float
    width_px: int  # the image's pixels across and along, as it is shown
    height_px: int

    @classmethod
    def of(cls, camera: Camera, mount: str) -> Optics:
        """The camera in its mount; the imaging area is the footprint `photogrammetry.footprint_m`
        gives at a height equal to the focal length (its sides in mm)."""
        if mount not in MOUNTS:
            raise ValueError(f"mount must be one of {', '.join(MOUNTS)}, not {mount!r}")
        across, along = pg.footprint(camera.focal_mm, camera, mount)
        px = (camera.image_width_px, camera.image_height_px)
        width_px, height_px = px if mount == "landscape" else px[::-1]
        return cls(float(across), float(along), camera.focal_mm, camera.pixel_pitch_mm, width_px, height_px)


@dataclass(frozen=True)
class Attitudes:
    """The camera attitude of each of n photos (degrees, see the module docstring)."""

    yaw_deg: FloatArray
    pitch_deg: FloatArray
    roll_deg: FloatArray

    @classmethod
    def nadir(cls, yaw_deg: FloatArray) -> Attitudes:
        yaw = np.asarray(yaw_deg, float)
        return cls(yaw, np.full(yaw.shape, -90.0), np.zeros(yaw.shape))

    @classmethod
    def of_body(cls, yaw_deg: FloatArray, pitch_deg: FloatArray, roll_deg: FloatArray) -> Attitudes:
        """The attitude of a camera fixed to a body, looking down with the image's top towards
        the nose, from the body's yaw, pitch (nose up positive) and roll (right side down
        positive), rotated in that order (the aircraft convention MAVLink's ATTITUDE uses).
        These are also the yaw, pitch, roll of a camera in Pix4D's, Metashape's and
        OpenDroneMap's convention (0, 0, 0: looking down, the image's top to the north); a
        camera on a nadir gimbal is (yaw, 0, 0), which gives `nadir(yaw)`.

        Exact: the camera's right and optical axis (the body's right and down) are found and
        the module's pitch, roll, yaw read off them (the inverse of `ray_directions`)."""
        y, p, r = (np.radians(np.asarray(a, float)) for a in (yaw_deg, pitch_deg, roll_deg))
        cy, sy, cp, sp, cr, sr = np.cos(y), np.sin(y), np.cos(p), np.sin(p), np.cos(r), np.sin(r)
        # the body's right and down axes in north, east, down (columns 2 and 3 of Rz(y)·Ry(p)·Rx(r)),
        # turned to east, north, up
        right_e, right_n, right_u = sy * sp * sr + cy * cr, cy * sp * sr - sy * cr, -(cp * sr)
        down_e, down_n, down_u = sy * sp * cr - cy * sr, cy * sp * cr + sy * sr, -(cp * cr)
        roll = np.arcsin(np.clip(right_u, -1.0, 1.0))
        yaw = np.arctan2(-right_n, right_e)
        along = down_e * np.sin(yaw) + down_n * np.cos(yaw)  # the axis with the yaw undone
        across = down_e * np.cos(yaw) - down_n * np.sin(yaw)
        up = -across * np.sin(roll) + down_u * np.cos(roll)  # and the roll
        return cls(np.degrees(yaw) % 360.0, np.degrees(np.arctan2(up, along)), np.degrees(roll))


@dataclass(frozen=True)
class Photos:
    """n photos: projection centres in the planning CRS (x, y) and height z on the ground's datum."""

    x: FloatArray
    y: FloatArray
    z: FloatArray
    attitude: Attitudes

    @classmethod
    def nadir(cls, x: FloatArray, y: FloatArray, agl_m: FloatArray, yaw_deg: FloatArray) -> Photos:
        """Photos looking straight down from `agl_m` above flat ground at height 0, the image's top towards `yaw_deg`."""
        return cls(np.asarray(x, float), np.asarray(y, float), np.asarray(agl_m, float), Attitudes.nadir(yaw_deg))

    @classmethod
    def looking(cls, x: FloatArray, y: FloatArray, agl_m: FloatArray, yaw_deg: FloatArray, pitch_deg: FloatArray) -> Photos:
        """Photos from `agl_m` above flat ground at height 0, the camera looking towards `yaw_deg`
        at `pitch_deg` (−90 straight down, the image's top towards `yaw_deg`), level (no roll)."""
        yaw = np.asarray(yaw_deg, float)
        att = Attitudes(yaw, np.broadcast_to(np.asarray(pitch_deg, float), yaw.shape).copy(), np.zeros(yaw.shape))
        return cls(np.asarray(x, float), np.asarray(y, float), np.asarray(agl_m, float), att)

    def take(self, which: IntArray | BoolArray) -> Photos:
        """The photos `which` selects (indices or a mask)."""
        a = self.attitude
        return Photos(self.x[which], self.y[which], self.z[which],
                      Attitudes(a.yaw_deg[which], a.pitch_deg[which], a.roll_deg[which]))


#: Image points (u, v) in units of the imaging area's half sides: the four corners, in the
#: order top-right, top-left, bottom-left, bottom-right (top = the image's top edge): on the
#: ground of a camera looking down, a counter-clockwise ring, as GeoJSON wants its outer rings.
CORNERS = np.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]])


def ray_directions(optics: Optics, attitude: Attitudes, uv: FloatArray) -> FloatArray:
    """(n, k, 3) unit directions (east, north, up) of the rays through image points `uv` (k, 2),
    in units of the half sides (u to the image's right, v to its top), for each of n photos;
    or through each photo's own k points, `uv` (n, k, 2)."""
    u = uv[..., 0] * optics.width_mm / 2.0
    v = uv[..., 1] * optics.height_mm / 2.0
    # the camera at yaw 0, pitch 0, roll 0 looks north at the horizon: axis (0, 1, 0), image right
    # (1, 0, 0), image top (0, 0, 1); a ray is f·axis + u·right + v·top
    cam = np.stack([u, np.full_like(u, optics.focal_mm), v], axis=-1)  # (k, 3) or (n, k, 3)
    cam /= np.linalg.norm(cam, axis=-1, keepdims=True)
    cam = cam if cam.ndim == 3 else cam[None]
    # each angle's cosine and sine once a photo
    (cr, sr), (cp, sp), (cy, sy) = ((np.cos(a), np.sin(a)) for a in (np.radians(b)[:, None] for b in (
        attitude.roll_deg, attitude.pitch_deg, attitude.yaw_deg)))
    x0, y0, z0 = cam[..., 0], cam[..., 1], cam[..., 2]
    # pitch: about the east axis, positive raising the axis above the horizon
    y1, z1 = y0 * cp - z0 * sp, y0 * sp + z0 * cp
    x1 = np.broadcast_to(x0, y1.shape)
    # roll: about the (level) north axis, positive turning the axis' lower end to the right (east)
    x2, z2 = x1 * cr - z1 * sr, x1 * sr + z1 * cr
    # yaw: clockwise from north
    e = x2 * cy + y1 * sy
    n = -x2 * sy + y1 * cy
    return np.stack([e, n, z2], axis=-1)


def _below_horizon(d: FloatArray) -> BoolArray:
    """Whether each unit ray `d` points at least MIN_DEPRESSION_DEG below the horizon."""
    below: BoolArray = d[..., 2] <= -np.sin(np.radians(MIN_DEPRESSION_DEG))
    return below


def bounded_footprints(photos: Photos, optics: Optics) -> BoolArray:
    """Which photos have a bounded ground footprint: the one place that says so. A photo has one
    when the ray through every corner of its image points at least MIN_DEPRESSION_DEG below the
    horizon (the corners decide for the whole image: a ray's up component plus sin(margin) times
    its length is convex over the image plane, so it is greatest at a corner). The others (a
    level or upward-looking camera: a facade photographed square) see the horizon or near it:
    they have no ground footprint (`footprint_corners` refuses them), plan.geojson writes their
    point with the reason, and the coverage step and the rules' footprints count them for no
    ground point."""
    return _bounded(ray_directions(optics, photos.attitude, CORNERS))


def _bounded(corner_rays: FloatArray) -> BoolArray:
    """Which photos have a bounded ground footprint (`bounded_footprints`), from their corners' (n, 4, 3) rays."""
    bounded: BoolArray = np.all(_below_horizon(corner_rays), axis=1)
    return bounded


def _check_below_horizon(d: FloatArray) -> None:
    if not _below_horizon(d).all():
        worst = float(np.degrees(np.arcsin(np.clip(d[..., 2].max(), -1, 1))))
        raise ValueError(f"a ray of the image points {worst:+.1f}° from the horizon; the camera must look at least "
                         f"{MIN_DEPRESSION_DEG:g}° below it at every edge of the image (lower the pitch)")


def ground_points(photos: Photos, optics: Optics, uv: FloatArray, ground: float | FloatArray | Ground,
                  grid_scale: float = 1.0) -> FloatArray:
    """(n, k, 3) points (x, y in the planning CRS, z) where the rays through image points `uv`
    meet the ground: flat at a height (one, or one per photo), or a `Ground`. ValueError when
    a ray does not point far enough below the horizon, or a camera is not above the ground."""
    return _meet_ground(photos, ray_directions(optics, photos.attitude, uv), ground, grid_scale)


def _meet_ground(photos: Photos, d: FloatArray, ground: float | FloatArray | Ground, grid_scale: float) -> FloatArray:
    """`ground_points` of the photos' (n, k, 3) unit rays `d`."""
    _check_below_horizon(d)
    cx, cy, cz = (np.asarray(a, float)[:, None] for a in (photos.x, photos.y, photos.z))
    if isinstance(ground, int | float | np.ndarray):
        g = np.broadcast_to(np.asarray(ground, float), np.shape(photos.x))[:, None] * np.ones(d.shape[:2])
        refinements = 0
    else:
        g = ground.height(np.asarray(photos.x, float), np.asarray(photos.y, float))[:, None] * np.ones(d.shape[:2])
        refinements = DEM_REFINEMENTS
    if (cz <= g[:, :1]).any():
        raise ValueError("a camera is not above the ground under it")
    for i in range(refinements + 1):
        t = (cz - g) / -d[..., 2]  # range along the ray to the height g
        px, py = cx + d[..., 0] * t * grid_scale, cy + d[..., 1] * t * grid_scale
        if i < refinements:
            assert not isinstance(ground, int | float | np.ndarray)
            g = np.minimum(ground.height(px.ravel(), py.ravel()).reshape(px.shape), cz - 0.1)
    return np.stack([px, py, g], axis=-1)


def footprint_corners(photos: Photos, optics: Optics, ground: float | FloatArray | Ground,
                      grid_scale: float = 1.0) -> FloatArray:
    """(n, 4, 2) corners of each photo's footprint in the planning CRS (see `CORNERS` for their
    order): a rectangle at nadir over flat ground, a trapezoid when tilted. Only for photos that
    have one (`bounded_footprints`; ValueError for the others)."""
    return ground_points(photos, optics, CORNERS, ground, grid_scale)[..., :2]


def bounded_footprint_corners(photos: Photos, optics: Optics, ground: float | FloatArray | Ground,
                              grid_scale: float = 1.0) -> tuple[FloatArray, BoolArray]:
    """`footprint_corners` of the photos that have a footprint, and which photos those are
    (`bounded_footprints`), the corners' rays made once for both (51,316 photos: ~15 ms a time)."""
    d = ray_directions(optics, photos.attitude, CORNERS)
    bounded = _bounded(d)
    return _meet_ground(photos.take(bounded), d[bounded], ground, grid_scale)[..., :2], bounded


def footprint_polygons(photos: Photos, optics: Optics, ground: float | FloatArray | Ground,
                       grid_scale: float = 1.0) -> npt.NDArray[np.object_]:
    """Each photo's footprint as a shapely polygon (planning CRS)."""
    polygons: npt.NDArray[np.object_] = shapely.polygons(footprint_corners(photos, optics, ground, grid_scale))
    return polygons


@dataclass(frozen=True)
class EdgeGsd:
    """Ground sample distance (metres a pixel, the larger of its two sides on the ground) at the
    middle of the image's bottom (near, for a camera pitched forward) and top (far) edges, and
    the largest at any corner."""

    near_m: FloatArray
    far_m: FloatArray
    worst_m: FloatArray


def edge_gsd(photos: Photos, optics: Optics, ground: float | FloatArray | Ground) -> EdgeGsd:
    """GSD at the image's edges, from where a pixel's neighbours meet the ground (so exact for
    the pinhole over flat ground, whatever the tilt). Lengths are true metres, not grid metres:
    give `photos` in a frame where they are (a DEM's planning grid differs by its scale, ~1e-4)."""
    du = optics.pixel_mm / (optics.width_mm / 2.0)
    dv = optics.pixel_mm / (optics.height_mm / 2.0)
    at = np.array([[0.0, -1.0], [0.0, 1.0], *CORNERS.tolist()])
    shifted = np.concatenate([at, at + [du, 0.0], at + [0.0, dv]])
    pts = ground_points(photos, optics, shifted, ground, 1.0)
    k = len(at)
    base, right, up = pts[:, :k], pts[:, k:2 * k], pts[:, 2 * k:]
    size = np.maximum(np.linalg.norm(right - base, axis=-1), np.linalg.norm(up - base, axis=-1))
    return EdgeGsd(size[:, 0], size[:, 1], size[:, 2:].max(axis=1))


@dataclass(frozen=True)
class ImagePoints:
    """Where ground points appear in each photo: (n photos, m points) pixel column (from the
    image's left edge) and row (from its top), and whether the point is in the image."""

    col: FloatArray
    row: FloatArray
    seen: npt.NDArray[np.bool_]


def image_points(photos: Photos, optics: Optics, gx: FloatArray, gy: FloatArray, gz: float | FloatArray,
                 grid_scale: float = 1.0) -> ImagePoints:
    """Project ground points (planning CRS x, y; height gz) into every photo: the inverse of
    `ray_directions` (yaw, then roll, then pitch undone), then the pinhole. Occlusion by the
    ground itself is not modelled."""
    gx, gy = np.asarray(gx, float)[None, :], np.asarray(gy, float)[None, :]
    e = (gx - np.asarray(photos.x, float)[:, None]) / grid_scale
    n = (gy - np.asarray(photos.y, float)[:, None]) / grid_scale
    z2 = np.broadcast_to(np.asarray(gz, float), gx.shape[1:])[None, :] - np.asarray(photos.z, float)[:, None]
    r, p, y = (np.radians(np.asarray(a, float))[:, None] for a in (photos.attitude.roll_deg, photos.attitude.pitch_deg,
                                                                      photos.attitude.yaw_deg))
    x2, y1 = e * np.cos(y) - n * np.sin(y), e * np.sin(y) + n * np.cos(y)
    x1, z1 = x2 * np.cos(r) + z2 * np.sin(r), -x2 * np.sin(r) + z2 * np.cos(r)
    y0, z0 = y1 * np.cos(p) + z1 * np.sin(p), -y1 * np.sin(p) + z1 * np.cos(p)
    ahead = y0 > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        u_mm, v_mm = optics.focal_mm * x1 / y0, optics.focal_mm * z0 / y0
    seen = ahead & (np.abs(u_mm) <= optics.width_mm / 2) & (np.abs(v_mm) <= optics.height_mm / 2)
    return ImagePoints(optics.width_px / 2 + u_mm / optics.pixel_mm, optics.height_px / 2 - v_mm / optics.pixel_mm, seen)


def images_seeing(px: FloatArray, py: FloatArray, footprints: shapely.STRtree) -> IntArray:
    """How many footprints (an STRtree of their polygons, built once for many questions) contain
    each ground point, their edges included."""
    pairs = footprints.query(shapely.points(np.asarray(px, float), np.asarray(py, float)), predicate="intersects")
    counts: IntArray = np.bincount(pairs[0], minlength=len(px)).astype(np.intp)
    return counts
