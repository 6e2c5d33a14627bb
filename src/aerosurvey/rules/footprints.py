"""Evidence measured from the planned photo footprints, not from the planner's spacing.

Footprints are nadir rectangles from the camera's sensor and each station's height above
ground, turned to the station's heading; their size comes from the planner's own formula
(aerosurvey.plan.photogrammetry.footprint_m). Coverage is counted on a sample grid;
overlaps are measured between consecutive photos of a run and between neighbouring
parallel runs.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.camera import Camera, camera_from_mapping
from aerosurvey.errors import InputError
from aerosurvey.plan import capture
from aerosurvey.plan import photogrammetry as pg
from aerosurvey.rules.planview import PlanView
from aerosurvey.spec import MOUNTS

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class ViewCamera:
    """The camera and its mount as the plan's manifest records them (section `camera`)."""

    camera: Camera
    mount: str  # landscape or portrait

    @classmethod
    def of(cls, view: PlanView) -> ViewCamera:
        cam = view.camera
        (sw, sh), (nw, nh) = cam["sensor_mm"], cam["image_px"]
        table = {"name": cam["name"], "sensor_width_mm": sw, "sensor_height_mm": sh, "image_width_px": nw,
                 "image_height_px": nh, "focal_mm": cam["focal_mm"]}
        camera = camera_from_mapping(str(cam.get("id", "camera")), table, "manifest camera")
        mount = cam["mount"]
        if mount not in MOUNTS:
            raise InputError(f"manifest camera.mount = {mount!r}; allowed: {', '.join(MOUNTS)}")
        return cls(camera, str(mount))

    def gsd_m(self, agl_m: FloatArray, pitch_deg: FloatArray) -> FloatArray:
        """GSD of each photo taken `agl_m` above ground with its camera at `pitch_deg`, at the image centre
        (`photogrammetry.gsd_at_centre_m`; NaN for a level camera, whose centre ray meets no ground)."""
        return pg.gsd_at_centre_m(agl_m, pitch_deg, self.camera.pixel_pitch_mm, self.camera.focal_mm)

    @property
    def optics(self) -> capture.Optics:
        return capture.Optics.of(self.camera, self.mount)


def coarsest_gsd_m(view: PlanView) -> float:
    """The coarsest GSD of the view's photos at their centres (`ViewCamera.gsd_m`): what a ground target must be
    seen at. With no photo looking down to the ground (a level camera), the GSD straight down from the highest."""
    cam = ViewCamera.of(view)
    gsd = cam.gsd_m(view.agl, view.pitch_deg)
    if np.isfinite(gsd).any():
        return float(np.nanmax(gsd))
    return float(np.max(cam.gsd_m(view.agl, np.full(len(view.agl), -90.0))))


@dataclass(frozen=True, eq=False)
class Footprints:
    """Photo footprints in the planning CRS from the capture model (plan/capture.py) of the view's
    photos that have one (`capture.bounded_footprints`; a level camera's photos have none and
    count for no ground point): their station indices in the view, centres, compass heading,
    and the corners of each (image top-right, top-left, bottom-left, bottom-right)."""

    station: IntArray
    x: FloatArray
    y: FloatArray
    heading_rad: FloatArray  # compass bearing in radians
    corners: FloatArray  # (n, 4, 2) grid metres

    @cached_property
    def across(self) -> FloatArray:
        """Each footprint's width across the image on the ground, at its narrower edge (grid metres)."""
        c = self.corners
        width: FloatArray = np.minimum(np.linalg.norm(c[:, 0] - c[:, 1], axis=1), np.linalg.norm(c[:, 3] - c[:, 2], axis=1))
        return width

    @cached_property
    def along(self) -> FloatArray:
        """Each footprint's length along the image on the ground, at its shorter side (grid metres)."""
        c = self.corners
        length: FloatArray = np.minimum(np.linalg.norm(c[:, 1] - c[:, 2], axis=1), np.linalg.norm(c[:, 0] - c[:, 3], axis=1))
        return length

    @cached_property
    def polygons(self) -> npt.NDArray[np.object_]:
        polygons: npt.NDArray[np.object_] = shapely.polygons(self.corners)
        return polygons

    @cached_property
    def tree(self) -> shapely.STRtree:
        """The polygons' STRtree, built once for every count (the GCP search asks many times)."""
        return shapely.STRtree(self.polygons)

    def count_at(self, px: FloatArray, py: FloatArray) -> IntArray:
        """How many footprints contain each point (their edges included)."""
        px, py = np.asarray(px, float), np.asarray(py, float)
        if not len(px) or not len(self.x):
            return np.zeros(len(px), np.intp)
        return capture.images_seeing(px, py, self.tree)


def footprints(view: PlanView) -> Footprints:
    """The footprint of every station of the view (its camera attitude, over flat ground at its
    height above ground), from the capture model, in grid metres."""
    k = float(view.manifest.get("derived", {}).get("grid_scale", 1.0))  # ground metres to grid metres
    cam = ViewCamera.of(view)
    photos = capture.Photos.looking(view.x, view.y, np.asarray(view.agl, float), view.camera_yaw_deg, view.pitch_deg)
    corners, bounded = capture.bounded_footprint_corners(photos, cam.optics, 0.0, k)
    at = np.flatnonzero(bounded)
    return Footprints(at, photos.x[at], photos.y[at], np.radians(np.asarray(view.heading_deg, float)[at]), corners)


def sample_grid(geom: BaseGeometry, target_points: int = 4000) -> tuple[FloatArray, FloatArray]:
    """A regular grid of points inside `geom`, about `target_points` of them."""
    step = math.sqrt(max(geom.area, 1.0) / target_points)
    x0, y0, x1, y1 = geom.bounds
    mx, my = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    gx, gy = mx.ravel(), my.ravel()
    keep = shapely.contains_xy(geom, gx, gy)
    return gx[keep], gy[keep]


def runs(view: PlanView, fp: Footprints | None = None) -> dict[str, IntArray]:
    """Station indices of each run, in flight order (a flown photo on no planned line is in none);
    with `fp`, indices into its footprints instead, of the runs' photos that have one."""
    out: dict[str, list[int]] = {}
    run_ids = view.run_ids if fp is None else [view.run_ids[i] for i in fp.station.tolist()]
    for i, r in enumerate(run_ids):
        if r is not None:
            out.setdefault(r, []).append(i)
    return {k: np.asarray(v, np.intp) for k, v in out.items()}


def forward_overlaps(view: PlanView, fp: Footprints) -> list[tuple[str, float]]:
    """(run id, lowest overlap between consecutive photos of that run)."""
    out = []
    for rid, idx in runs(view, fp).items():
        if len(idx) < 2:
            continue
        d = np.hypot(np.diff(fp.x[idx]), np.diff(fp.y[idx]))
        along = np.minimum(fp.along[idx][:-1], fp.along[idx][1:])
        out.append((rid, float(np.min(1 - d / along))))
    return out


def side_overlaps(view: PlanView, fp: Footprints) -> list[tuple[str, str, float]]:
    """(run, neighbour, overlap of their strips) for every pair of neighbouring runs, each pair
    once (in the order of its first run): each run and the nearest parallel run on each side of
    it, where there is one. A pair measured from both of its runs (their headings differ a
    little) keeps the smaller overlap. A run whose neighbour on one side was not flown is paired
    with the next run on that side, so a missing line fails the rule on the pair beside it.

    Each run's stations are measured across and along the lines of its heading; runs of the same
    heading (all the runs of one direction of a pass: 4 headings for the 34 runs of the Obrataň
    example) share those measures, made once for all stations of every run (elementwise, the same
    floats as run by run) instead of once for every pair of runs (10-20 ms there, 544 pairs)."""
    rs = runs(view, fp)
    if not rs:
        return []
    ids = list(rs)
    order = np.concatenate(list(rs.values()))  # the stations run by run, each run in flight order
    ends = np.cumsum([len(idx) for idx in rs.values()]).tolist()
    starts = [0, *ends[:-1]]
    xs, ys = fp.x[order], fp.y[order]
    # statistics.median, not np.median: numpy imports numpy.ma for the latter's NaN check (12-17 ms on
    # every `aerosurvey plan`); the headings are finite numbers (the manifest schema) and the value is the same
    heads = [float(statistics.median(fp.heading_rad[idx].tolist())) for idx in rs.values()]
    widths = [float(fp.across[idx].min()) for idx in rs.values()]
    # per heading: each run's least and greatest position along the lines, each station's across them
    frames: dict[float, tuple[list[float], list[float], FloatArray]] = {}
    means: dict[tuple[float, int], float] = {}

    def frame(h: float) -> tuple[list[float], list[float], FloatArray]:
        if h not in frames:
            s, c = math.sin(h), math.cos(h)
            u = xs * s + ys * c
            frames[h] = (np.minimum.reduceat(u, starts).tolist(), np.maximum.reduceat(u, starts).tolist(), xs * c - ys * s)
        return frames[h]

    def across(h: float, k: int) -> float:
        """Run k's mean position across the lines of heading h."""
        if (h, k) not in means:
            means[(h, k)] = float(np.mean(frame(h)[2][starts[k]:ends[k]]))
        return means[(h, k)]

    pairs: dict[tuple[int, int], float] = {}  # (run, neighbour) by their indexes, the first the lower
    for k, h in enumerate(heads):
        umins, umaxs, _ = frame(h)
        umin, umax, v_mean, w = umins[k], umaxs[k], across(h, k), widths[k]
        nearest: dict[bool, tuple[float, int]] = {}  # per side (right of the heading or not)
        for q, hq in enumerate(heads):
            if q == k or abs(math.sin(hq - h)) > 0.052:  # parallel within 3°: flown yaw wanders a little
                continue
            if umaxs[q] < umin or umins[q] > umax:
                continue
            signed = across(h, q) - v_mean
            d = abs(signed)
            side = signed > 0
            if d > 1e-6 and (side not in nearest or d < nearest[side][0]):
                nearest[side] = (d, q)
        for d, q in nearest.values():
            pair = (min(k, q), max(k, q))
            pairs[pair] = min(pairs.get(pair, math.inf), 1 - d / min(w, widths[q]))
    return [(ids[a], ids[b], v) for (a, b), v in sorted(pairs.items())]


@dataclass(frozen=True)
class Crossing:
    """Photos outside the area's outline where a run enters it, leaves it or crosses a notch."""

    run: str
    where: str  # entry, exit, or "notch crossed with the camera on"
    outside_photos: int
    ok: bool


def boundary_crossings(view: PlanView, min_outside: int) -> list[Crossing]:
    """Photos outside the area's outline at every place a run crosses it.

    A run that leaves the area and re-enters it (a notch) with photos all the way across
    counts as continuous there. Holes are not boundaries: only the outline counts.
    """
    outline = shapely.union_all([shapely.Polygon(p.exterior) for p in shapely.get_parts(view.area)])
    inside = shapely.contains_xy(outline, view.x, view.y)
    found = []
    for rid, idx in runs(view).items():
        ins = inside[idx]
        if not ins.any():
            continue
        pos = np.flatnonzero(ins)
        first, last = int(pos[0]), int(pos[-1])
        found.append(Crossing(rid, "entry", first, first >= min_outside))
        found.append(Crossing(rid, "exit", len(idx) - 1 - last, len(idx) - 1 - last >= min_outside))
        gaps = np.flatnonzero(np.diff(pos) > 1)
        for g in gaps:
            n = int(pos[g + 1] - pos[g] - 1)
            found.append(Crossing(rid, "notch crossed with the camera on", n, True))
    return found
