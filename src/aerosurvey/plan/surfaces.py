"""What photos see of a structure: its walls and roof, met by the photos' rays as the ground is
(plan/capture.py: the same camera, attitude and pinhole).

A structure (`Structure`) is a prism: a footprint polygon in the planning CRS standing from
`base_m` to `top_m`, heights on the photos' datum (`Photos.z`: above the ground the structure
stands on, its `foot`: over a DEM the lowest ground under its footprint or toe line, else the
launch point's). Its faces are sampled at points
(`face_points`): each wall (an edge of the footprint's rings, its outward normal level) at the
middle of cells about `spacing_m` wide and high, the roof (normal up) at a point of each cell of
a square grid inside the footprint; each point stands for its cell's area, so the sampled area
is the faces' area exactly.

A photo sees a face point (`seen`) when the point projects into its image
(`capture.image_points`), its face is turned towards the camera, and nothing of the structure
lies between: the segment from the camera to the point crosses no wall between the base and
the top (with both ends outside the prism and above its base, the only way through it). Exact
for the prism; the ground occludes nothing (the cameras and the faces are above it).

On a face point a photo's GSD (`face_gsd`) is the larger side of its pixel there, on the face's
plane: the rays through the pixel's neighbours met with the plane, exact for the pinhole as
`capture.edge_gsd` is on the ground. `FaceCoverage` holds what `check` proves the faces'
coverage from: the photos seeing each point, the finest GSD among them, and the faces' area.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from aerosurvey.errors import InputError
from aerosurvey.plan.capture import Attitudes, FloatArray, Optics, Photos, image_points, ray_directions

#: how far off its face a point is moved towards the camera before the segment to it is tested
#: (metres): the point's own face never hides it
FACE_OFFSET_M = 1e-3
#: photo–point pairs tested at once (bounds the arrays of the occlusion test: pairs × walls)
PAIRS_PER_BATCH = 200_000


@dataclass(frozen=True)
class Structure:
    """A prism: `footprint` (planning CRS) from `base_m` up to `top_m` (metres, the photos' datum)."""

    footprint: Polygon
    base_m: float
    top_m: float

    def __post_init__(self) -> None:
        if not (isinstance(self.footprint, Polygon) and self.footprint.is_valid and self.footprint.area > 0):
            raise ValueError(f"a structure's footprint is a valid polygon with an area: {self.footprint.wkt[:80]}")
        if not (math.isfinite(self.base_m) and math.isfinite(self.top_m) and self.top_m > self.base_m):
            raise ValueError(f"a structure's top ({self.top_m}) is above its base ({self.base_m})")

    def walls(self) -> tuple[np.ndarray, np.ndarray]:
        """(a, b): each wall's ends (k, 2), in the order that puts the structure on the wall's left
        (the exterior counter-clockwise, the holes clockwise): its outward normal is to the right."""
        poly = orient(self.footprint, 1.0)
        rings = [np.asarray(poly.exterior.coords, float), *(np.asarray(r.coords, float) for r in poly.interiors)]
        return np.concatenate([r[:-1] for r in rings]), np.concatenate([r[1:] for r in rings])

    words: ClassVar[str] = "the structure's walls and roof"
    key: ClassVar[str] = "structure.top_m"

    @property
    def where(self) -> str:
        return f"structure.base_m {self.base_m:g} .. top_m {self.top_m:g}, or below its base"

    @property
    def foot(self) -> BaseGeometry:
        return self.footprint

    def area_m2(self, grid_scale: float = 1.0) -> float:
        return float(self.footprint.area / grid_scale ** 2 + self.footprint.length / grid_scale * (self.top_m - self.base_m))

    def points(self, spacing_m: float, grid_scale: float = 1.0) -> FacePoints:
        return face_points(self, spacing_m, grid_scale)

    def inside(self, x: FloatArray, y: FloatArray, z: FloatArray) -> np.ndarray:
        """Whether each place (planning CRS, heights on the structure's datum) is inside the prism or below its base."""
        out: np.ndarray = (shapely.contains_xy(self.footprint, x, y) & (z <= self.top_m)) | (z < self.base_m)
        return out

    def blocked(self, cx: FloatArray, cy: FloatArray, cz: FloatArray, pts: FacePoints, j: np.ndarray,
                grid_scale: float = 1.0) -> np.ndarray | None:
        """Whether the structure lies between each camera and face point j (None: a convex prism
        hides no face turned towards a camera)."""
        if self.footprint.equals(self.footprint.convex_hull):
            return None
        a, b = self.walls()
        step = max(1, PAIRS_PER_BATCH // max(len(a), 1))
        return np.concatenate([np.zeros(0, bool), *(_blocked(self, a, b, cx[lo:lo + step], cy[lo:lo + step], cz[lo:lo + step],
                                                              pts, j[lo:lo + step], grid_scale)
                                                     for lo in range(0, len(j), step))])


class Surface(Protocol):
    """Faces the photos must see (a `Structure`'s walls and roof, a `Terrace`'s inclined faces): their
    sampled points, what of the space is solid, and what lies between a camera and a face point."""

    words: ClassVar[str]  # what the faces rule calls them
    key: ClassVar[str]  # the spec's key an error about a station inside the solid names

    @property
    def where(self) -> str:
        """The solid's extent in the spec's words."""
        ...

    @property
    def foot(self) -> BaseGeometry:
        """What it stands on (planning CRS): over a DEM its heights are above the lowest ground under this."""
        ...

    def area_m2(self, grid_scale: float = 1.0) -> float: ...

    def points(self, spacing_m: float, grid_scale: float = 1.0) -> FacePoints: ...

    def inside(self, x: FloatArray, y: FloatArray, z: FloatArray) -> np.ndarray: ...

    def blocked(self, cx: FloatArray, cy: FloatArray, cz: FloatArray, pts: FacePoints, j: np.ndarray,
                grid_scale: float = 1.0) -> np.ndarray | None: ...


@dataclass(frozen=True)
class Terrace:
    """Inclined faces of benches standing on a straight toe line: an open pit's, a quarry's or a
    dam's (a facade: one bench at 90°). The toe line runs from `a` to `b` (planning CRS) at `base_m`;
    the faces rise on its right (walking from a to b). Bench i's toe lies i · (height / tan angle +
    berm) behind the line and i · height above the base; each face rises `height_m` at `angle_deg`
    from the horizontal, a level berm `berm_m` deep behind it, the last crest a level plateau
    behind. The solid is what lies below that profile between the toe line's ends (beyond them the
    faces stand alone); in front of the toe line is open floor, which hides nothing from cameras
    above it. Its faces (`points`) are the inclined ones; the berms and the plateau only hide."""

    a: tuple[float, float]
    b: tuple[float, float]
    base_m: float
    angle_deg: float
    height_m: float
    benches: int = 1
    berm_m: float = 0.0

    words: ClassVar[str] = "the faces"
    key: ClassVar[str] = "pattern.standoff_m"

    def __post_init__(self) -> None:
        if not (0.0 < self.angle_deg <= 90.0 and self.height_m > 0 and self.benches >= 1 and self.berm_m >= 0
                and math.dist(self.a, self.b) > 0):
            raise ValueError(f"a terrace has a toe line of some length, faces 0..90° high above 0 m, benches ≥ 1, berms ≥ 0: {self}")

    @property
    def where(self) -> str:
        return (f"{self.benches} face(s) {self.height_m:g} m high at {self.angle_deg:g}° behind the toe line, "
                f"berms {self.berm_m:g} m")

    @property
    def foot(self) -> BaseGeometry:
        return shapely.LineString([self.a, self.b])

    @property
    def run_m(self) -> float:
        """How far back a face reaches (metres): its height over the tangent of its angle."""
        return 0.0 if self.angle_deg == 90.0 else self.height_m / math.tan(math.radians(self.angle_deg))

    def toe(self, i: int) -> tuple[float, float]:
        """(metres behind the toe line, height) of bench i's toe."""
        return i * (self.run_m + self.berm_m), self.base_m + i * self.height_m

    def axes(self, grid_scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, float]:
        """(along, into): the toe line's unit direction and the level unit direction into the solid
        (its right), planning CRS; and the toe line's length (metres)."""
        d = np.subtract(self.b, self.a)
        length = float(np.hypot(*d))
        along = d / length
        return along, np.array([along[1], -along[0]]), length / grid_scale

    def local(self, x: FloatArray, y: FloatArray, grid_scale: float = 1.0) -> tuple[FloatArray, FloatArray]:
        """(metres along the toe line from a, metres behind it) of planning-CRS places."""
        along, into, _ = self.axes(grid_scale)
        rx, ry = np.asarray(x, float) - self.a[0], np.asarray(y, float) - self.a[1]
        return (rx * along[0] + ry * along[1]) / grid_scale, (rx * into[0] + ry * into[1]) / grid_scale

    def profile(self) -> tuple[FloatArray, FloatArray]:
        """The section's corners (metres behind the toe line, height): toe, crest, … the last crest."""
        d, z = [], []
        for i in range(self.benches):
            d0, z0 = self.toe(i)
            d += [d0, d0 + self.run_m]
            z += [z0, z0 + self.height_m]
        return np.array(d), np.array(z)

    def clearance(self, d: float, z: float) -> float:
        """How far (metres) a place in the section (metres behind the toe line, height) is from the
        solid's section (its profile closed 10 km below and behind)."""
        pd, pz = self.profile()
        far = 1e4
        ring = [(0.0, self.base_m - far), *zip(pd.tolist(), pz.tolist()), (far, float(pz[-1])), (far, self.base_m - far)]
        return float(shapely.distance(shapely.Polygon(ring), shapely.Point(d, z)))

    def height_at(self, d: FloatArray) -> FloatArray:
        """The solid's top at each distance behind the toe line (−inf in front of it; a vertical face's
        place: its top)."""
        pd, pz = self.profile()
        d = np.asarray(d, float)
        out = np.interp(d, pd, pz, right=pz[-1])  # on a vertical face np.interp may take either end: its top
        on = np.isclose(d[..., None], pd, rtol=0.0, atol=1e-9)
        out = np.where(on.any(axis=-1), np.max(np.where(on, pz, -np.inf), axis=-1), out)
        return np.where(d < 0.0, -np.inf, out)

    def area_m2(self, grid_scale: float = 1.0) -> float:
        return self.benches * self.axes(grid_scale)[2] * self.height_m / math.sin(math.radians(self.angle_deg))

    def normal(self, grid_scale: float = 1.0) -> np.ndarray:
        """The faces' outward unit normal (east, north, up)."""
        _, into, _ = self.axes(grid_scale)
        a = math.radians(self.angle_deg)
        return np.array([-into[0] * math.sin(a), -into[1] * math.sin(a), math.cos(a)])

    def points(self, spacing_m: float, grid_scale: float = 1.0) -> FacePoints:
        """Points on the inclined faces about `spacing_m` apart (true metres), each standing for its cell."""
        if not spacing_m > 0:
            raise ValueError(f"face points' spacing must be above 0, not {spacing_m}")
        along, into, length = self.axes(grid_scale)
        a = math.radians(self.angle_deg)
        slope = self.height_m / math.sin(a)
        n_along, n_up = max(1, math.ceil(length / spacing_m)), max(1, math.ceil(slope / spacing_m))
        uu, tt = np.meshgrid((np.arange(n_along) + 0.5) / n_along * length, (np.arange(n_up) + 0.5) / n_up * slope,
                             indexing="ij")
        u, t = np.tile(uu.ravel(), self.benches), np.tile(tt.ravel(), self.benches)
        face = np.repeat(np.arange(self.benches), uu.size)
        toes = np.array([self.toe(i) for i in range(self.benches)])[face]
        d, z = toes[:, 0] + t * math.cos(a), toes[:, 1] + t * math.sin(a)
        x = self.a[0] + (u * along[0] + d * into[0]) * grid_scale
        y = self.a[1] + (u * along[1] + d * into[1]) * grid_scale
        return FacePoints(x, y, z, np.repeat(self.normal(grid_scale)[None], len(u), axis=0), face.astype(np.intp),
                          np.full(len(u), length / n_along * slope / n_up))

    def inside(self, x: FloatArray, y: FloatArray, z: FloatArray) -> np.ndarray:
        u, d = self.local(x, y)
        out: np.ndarray = (u >= 0) & (u <= self.axes()[2]) & (np.asarray(z, float) <= self.height_at(d))
        return out

    def blocked(self, cx: FloatArray, cy: FloatArray, cz: FloatArray, pts: FacePoints, j: np.ndarray,
                grid_scale: float = 1.0) -> np.ndarray:
        """Whether the segment from each camera to face point j (moved FACE_OFFSET_M off its face) runs
        below the profile between the toe line's ends. Along the segment, its height less the
        profile's is linear between the places it passes a corner of the profile or an end of the
        line: its lowest is at one of those, so they are all that is tested (exact)."""
        _, _, length = self.axes(grid_scale)
        u0, d0 = self.local(cx, cy, grid_scale)
        u1, d1 = self.local(pts.x[j] + pts.normal[j, 0] * FACE_OFFSET_M * grid_scale,
                            pts.y[j] + pts.normal[j, 1] * FACE_OFFSET_M * grid_scale, grid_scale)
        z0, z1 = np.asarray(cz, float), pts.z[j] + pts.normal[j, 2] * FACE_OFFSET_M
        du = u1 - u0
        with np.errstate(divide="ignore", invalid="ignore"):
            ends = np.sort(np.column_stack([-u0 / du, (length - u0) / du]), axis=1)
        inside_ends = (u0 >= 0) & (u0 <= length)
        lo = np.where(du == 0, np.where(inside_ends, 0.0, np.inf), np.clip(ends[:, 0], 0.0, 1.0))
        hi = np.where(du == 0, np.where(inside_ends, 1.0, -np.inf), np.clip(ends[:, 1], 0.0, 1.0))
        pd, pz = self.profile()
        top = np.array([pz[np.isclose(pd, v, rtol=0.0, atol=1e-9)].max() for v in pd])  # a vertical face: its top
        with np.errstate(divide="ignore", invalid="ignore"):
            at = (pd[None] - d0[:, None]) / (d1 - d0)[:, None]  # where the segment passes each corner
        corner = (at >= lo[:, None]) & (at <= hi[:, None]) & ((z0[:, None] + at * (z1 - z0)[:, None]) < top[None] - 1e-9)
        below: np.ndarray = corner.any(axis=1)
        for lam in (lo, hi):
            ok = lam <= hi
            lam = np.where(ok, lam, 0.0)
            below |= ok & (z0 + lam * (z1 - z0) < self.height_at(d0 + lam * (d1 - d0)) - 1e-9)
        return below


@dataclass(frozen=True, eq=False)
class FacePoints:
    """m points on a structure's faces: x, y (planning CRS), z (metres), the face's outward unit
    normal (east, north, up), the face (walls 0…k−1 in `Structure.walls` order, the roof k) and
    the area (m²) each stands for."""

    x: FloatArray
    y: FloatArray
    z: FloatArray
    normal: FloatArray  # (m, 3)
    face: np.ndarray
    area_m2: FloatArray

    def __len__(self) -> int:
        return len(self.x)


def face_points(s: Structure, spacing_m: float, grid_scale: float = 1.0) -> FacePoints:
    """Points on the walls and the roof about `spacing_m` apart (true metres; `grid_scale` planning
    metres a true metre), each standing for its cell's area."""
    if not spacing_m > 0:
        raise ValueError(f"face points' spacing must be above 0, not {spacing_m}")
    a, b = s.walls()
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1]) / grid_scale  # true metres
    height = s.top_m - s.base_m
    n_up = max(1, math.ceil(height / spacing_m))
    xs, ys, zs, nrm, face, area = [], [], [], [], [], []
    for k in np.flatnonzero(length > 0):
        n_along = max(1, math.ceil(length[k] / spacing_m))
        f = (np.arange(n_along) + 0.5) / n_along
        h = s.base_m + (np.arange(n_up) + 0.5) / n_up * height
        ff, hh = np.meshgrid(f, h, indexing="ij")
        xs.append(a[k, 0] + ff.ravel() * d[k, 0])
        ys.append(a[k, 1] + ff.ravel() * d[k, 1])
        zs.append(hh.ravel())
        out = np.array([d[k, 1], -d[k, 0], 0.0]) / (length[k] * grid_scale)
        nrm.append(np.repeat(out[None], ff.size, axis=0))
        face.append(np.full(ff.size, k))
        area.append(np.full(ff.size, length[k] / n_along * height / n_up))
    roof = _roof_cells(s.footprint, spacing_m * grid_scale)
    pts = shapely.point_on_surface(roof)
    xs.append(shapely.get_x(pts))
    ys.append(shapely.get_y(pts))
    zs.append(np.full(len(roof), s.top_m))
    nrm.append(np.repeat(np.array([[0.0, 0.0, 1.0]]), len(roof), axis=0))
    face.append(np.full(len(roof), len(a)))
    area.append(shapely.area(roof) / grid_scale ** 2)
    return FacePoints(np.concatenate(xs), np.concatenate(ys), np.concatenate(zs), np.concatenate(nrm),
                      np.concatenate(face).astype(np.intp), np.concatenate(area))


def _roof_cells(footprint: Polygon, side: float) -> np.ndarray:
    """The footprint cut into the cells of a square grid `side` wide (the non-empty pieces)."""
    x0, y0, x1, y1 = footprint.bounds
    nx, ny = max(1, math.ceil((x1 - x0) / side)), max(1, math.ceil((y1 - y0) / side))
    gx, gy = np.meshgrid(x0 + np.arange(nx) * side, y0 + np.arange(ny) * side, indexing="ij")
    boxes = shapely.box(gx.ravel(), gy.ravel(), gx.ravel() + side, gy.ravel() + side)
    shapely.prepare(footprint)
    cells = shapely.intersection(boxes[shapely.intersects(footprint, boxes)], footprint)
    out: np.ndarray = cells[shapely.area(cells) > 0]
    return out


def seen(photos: Photos, optics: Optics, s: Surface, pts: FacePoints, grid_scale: float = 1.0) -> np.ndarray:
    """(n photos, m points): whether each photo sees each face point (in its image, the face turned
    to the camera, nothing of the surface's solid between). ValueError when a camera is inside the
    solid (a structure: or below its base)."""
    cx, cy, cz = (np.asarray(v, float) for v in (photos.x, photos.y, photos.z))
    if s.inside(cx, cy, cz).any():
        raise ValueError("a camera is inside the structure or below its base")
    out = np.zeros((len(cx), len(pts)), bool)
    rows = max(1, PAIRS_PER_BATCH // max(len(pts), 1))
    for lo in range(0, len(cx), rows):
        sl = slice(lo, lo + rows)
        part = Photos(cx[sl], cy[sl], cz[sl], Attitudes(*(np.asarray(v, float)[sl] for v in (
            photos.attitude.yaw_deg, photos.attitude.pitch_deg, photos.attitude.roll_deg))))
        facing = ((cx[sl, None] - pts.x[None]) / grid_scale * pts.normal[None, :, 0]
                  + (cy[sl, None] - pts.y[None]) / grid_scale * pts.normal[None, :, 1]
                  + (cz[sl, None] - pts.z[None]) * pts.normal[None, :, 2]) > 0
        out[sl] = image_points(part, optics, pts.x, pts.y, pts.z, grid_scale).seen & facing
    i, j = np.nonzero(out)
    hidden = s.blocked(cx[i], cy[i], cz[i], pts, j, grid_scale)
    if hidden is not None:
        out[i, j] = ~hidden
    return out


def _blocked(s: Structure, a: np.ndarray, b: np.ndarray, cx: FloatArray, cy: FloatArray, cz: FloatArray,
             pts: FacePoints, j: np.ndarray, grid_scale: float) -> np.ndarray:
    """Whether the segment from each camera (cx, cy, cz) to face point j (moved FACE_OFFSET_M off
    its face) crosses a wall between the base and the top. Both ends outside the prism, that is
    the only way through it: a straight segment crosses the roof's plane at most once, so one that
    enters through the roof leaves through a wall, and the cameras are above the base."""
    qx = pts.x[j] + pts.normal[j, 0] * FACE_OFFSET_M * grid_scale
    qy = pts.y[j] + pts.normal[j, 1] * FACE_OFFSET_M * grid_scale
    qz = pts.z[j] + pts.normal[j, 2] * FACE_OFFSET_M
    dx, dy = (qx - cx)[:, None], (qy - cy)[:, None]
    ex, ey = (b - a)[None, :, 0], (b - a)[None, :, 1]
    wx, wy = a[None, :, 0] - cx[:, None], a[None, :, 1] - cy[:, None]
    denom = dx * ey - dy * ex
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (wx * ey - wy * ex) / denom  # along the segment
        u = (wx * dy - wy * dx) / denom  # along the wall
    z = cz[:, None] + t * (qz - cz)[:, None]
    crossed: np.ndarray = ((t > 0) & (t < 1) & (u >= 0) & (u <= 1) & (z >= s.base_m) & (z <= s.top_m)).any(axis=1)
    return crossed


def face_gsd(photos: Photos, optics: Optics, pts: FacePoints, i: np.ndarray, j: np.ndarray,
             grid_scale: float = 1.0) -> FloatArray:
    """GSD (metres a pixel, the larger of its two sides) of photo i[k] at face point j[k], on the
    face's plane: where the rays through the pixel at the point and its right and lower
    neighbours meet the plane."""
    # each photo's axis, and its image's right and top on the sensor's plane at the focal length
    d = ray_directions(optics, photos.attitude, np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    axis = d[:, 0]
    right = (d[:, 1] / np.einsum("pk,pk->p", d[:, 1], axis)[:, None] - axis) * optics.focal_mm / (optics.width_mm / 2)
    top = (d[:, 2] / np.einsum("pk,pk->p", d[:, 2], axis)[:, None] - axis) * optics.focal_mm / (optics.height_mm / 2)
    axis, right, top = axis[i], right[i], top[i]
    rel = np.stack([(pts.x[j] - np.asarray(photos.x, float)[i]) / grid_scale,
                    (pts.y[j] - np.asarray(photos.y, float)[i]) / grid_scale, pts.z[j] - np.asarray(photos.z, float)[i]], -1)
    depth = np.einsum("pk,pk->p", rel, axis)
    u = optics.focal_mm * np.einsum("pk,pk->p", rel, right) / depth  # mm on the sensor
    v = optics.focal_mm * np.einsum("pk,pk->p", rel, top) / depth
    f = optics.focal_mm * axis
    rays = np.stack([f + u[:, None] * right + v[:, None] * top, f + (u + optics.pixel_mm)[:, None] * right + v[:, None] * top,
                     f + u[:, None] * right + (v - optics.pixel_mm)[:, None] * top], axis=1)  # (p, 3, 3)
    n = pts.normal[j]
    t = np.einsum("pk,pk->p", rel, n)[:, None] / np.einsum("prk,pk->pr", rays, n)
    hit = rays * t[..., None]
    side: FloatArray = np.maximum(np.linalg.norm(hit[:, 1] - hit[:, 0], axis=-1), np.linalg.norm(hit[:, 2] - hit[:, 0], axis=-1))
    return side


@dataclass(frozen=True, eq=False)
class FaceCoverage:
    """Each face point's photos (those that see it) and the finest GSD among them (inf: none); and
    the forward overlap on the faces of each two consecutive photos of a run that both see them
    (the share of the first's seen face area the second also sees)."""

    points: FacePoints
    images: np.ndarray  # (m,) photos seeing each point
    finest_gsd_m: FloatArray  # (m,)
    overlap_pairs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.intp))  # (k, 2) photo indices
    forward_overlap: FloatArray = field(default_factory=lambda: np.zeros(0))  # (k,)

    @property
    def area_m2(self) -> float:
        return float(self.points.area_m2.sum())


def face_coverage(photos: Photos, optics: Optics, s: Surface, pts: FacePoints, grid_scale: float = 1.0,
                  max_gsd_m: float = math.inf, run: np.ndarray | None = None) -> FaceCoverage:
    """The photos seeing each face point, counting only those at most `max_gsd_m` there, and the
    finest GSD among all that see it; with `run` (each photo's run, the photos in flight order)
    the forward overlap on the faces of consecutive photos of a run that both see them."""
    vis = seen(photos, optics, s, pts, grid_scale)
    i, j = np.nonzero(vis)
    g = np.concatenate([np.zeros(0), *(face_gsd(photos, optics, pts, i[lo:lo + PAIRS_PER_BATCH], j[lo:lo + PAIRS_PER_BATCH],
                                                 grid_scale) for lo in range(0, len(i), PAIRS_PER_BATCH))])
    finest = np.full(len(pts), math.inf)
    np.minimum.at(finest, j, g)
    images = np.bincount(j[g <= max_gsd_m], minlength=len(pts))
    if run is None or len(vis) < 2:
        return FaceCoverage(pts, images, finest)
    first = vis[:-1] @ pts.area_m2
    both = (vis[:-1] & vis[1:]) @ pts.area_m2
    k = np.flatnonzero((np.asarray(run)[:-1] == np.asarray(run)[1:]) & (both > 0))
    return FaceCoverage(pts, images, finest, np.column_stack([k, k + 1]), both[k] / first[k])


#: face points the planner's check samples a structure with, about (fewer on a small one: one a
#: square metre); the check's time and memory grow with them times the photos
FACE_POINTS = 5000
#: the planner's rule on a structure's faces, as the manifest records rule results
FACES_RULE = "structure-faces"


@dataclass(frozen=True, eq=False)
class FacesCheck:
    """The planner's proof on a structure's faces ([structure]): the structure in the planning CRS,
    the ground under it its heights stand on, what each face point needs (`min_images` photos, each
    at most `max_gsd_m` there) and what the plan's photos give."""

    structure: Surface
    ground_m: float
    min_images: int
    max_gsd_m: float | None
    coverage: FaceCoverage
    station_ids: list[str]  # the photos', in flight order

    @property
    def short(self) -> np.ndarray:
        """The face points seen by fewer photos than asked."""
        short: np.ndarray = self.coverage.images < self.min_images
        return short

    @property
    def short_m2(self) -> float:
        return float(self.coverage.points.area_m2[self.short].sum())


def check_faces(s: Surface, ground_m: float, photos: Photos, station_ids: list[str], run: np.ndarray, optics: Optics,
                grid_scale: float, min_images: int, max_gsd_m: float | None) -> FacesCheck:
    """Which of the surface's face points the photos (heights on its datum) see `min_images` times;
    InputError naming a station inside its solid (a structure: or below its base)."""
    inside = s.inside(np.asarray(photos.x, float), np.asarray(photos.y, float), np.asarray(photos.z, float))
    if inside.any():
        k = int(np.argmax(inside))
        raise InputError(f"station {station_ids[k]} is {photos.z[k]:.1f} m above the ground inside {s.words} "
                         f"({s.where}): the vehicle would hit it", key=s.key)
    spacing = max(1.0, math.sqrt(s.area_m2(grid_scale) / FACE_POINTS))
    pts = s.points(spacing, grid_scale)
    cov = face_coverage(photos, optics, s, pts, grid_scale, math.inf if max_gsd_m is None else max_gsd_m, run)
    return FacesCheck(s, ground_m, min_images, max_gsd_m, cov, station_ids)


def faces_rule(c: FacesCheck, profile: str) -> dict[str, object]:
    """The planner's rule result on the faces, as the manifest records rule results. A check that saw
    no face area fails: it proves nothing."""
    cov = c.coverage
    short = c.short
    gsd = f" at most {c.max_gsd_m * 100:g} cm a pixel there" if c.max_gsd_m is not None else ""
    xy = np.unique(np.round(np.column_stack([cov.points.x[short], cov.points.y[short]]), 2), axis=0)  # a wall's heights at one place
    where = [{"xy": [float(x), float(y)]} for x, y in xy[:50]]
    seen_at = cov.finest_gsd_m[np.isfinite(cov.finest_gsd_m)]
    finest = f"; GSD on the faces {seen_at.min() * 100:.2f} to {seen_at.max() * 100:.2f} cm (finest photo at each point)" \
        if len(seen_at) else "; no photo sees the structure"
    return {"profile": profile, "rule": FACES_RULE, "status": "pass" if cov.area_m2 > 0 and c.short_m2 == 0 else "fail",
            "severity": "error",
            "statement": f"every point of {c.structure.words} is seen by at least {c.min_images} photos{gsd}",
            "measured": f"{c.short_m2:.2f} m² of {cov.area_m2:.2f} m² seen by fewer{finest}",
            "required": "0 m² (of more than 0 m² checked)", "evidence": [f"{len(cov.points)} points on the faces, "
                                                                        f"{int(short.sum())} short", *_overlap_words(c)],
            "where": where, "source": "aerosurvey planner (plan/surfaces.py)"}


def _overlap_words(c: FacesCheck) -> list[str]:
    """The lowest and the median forward overlap on the faces, between consecutive photos that both see them."""
    f = c.coverage.forward_overlap
    if not len(f):
        return ["no two consecutive photos of a run see the same face point"]
    a, b = c.coverage.overlap_pairs[int(np.argmin(f))]
    return [f"forward overlap on the faces (consecutive photos of a run that both see them): lowest {f.min():.0%} "
            f"({c.station_ids[a]} / {c.station_ids[b]}), median {float(np.median(f)):.0%}"]
