"""An independent ray caster for a structure's faces: a prism (a footprint polygon from a base
up to a top) photographed by frame cameras, shared by nothing in src/.

The camera's frame is built from its yaw (compass bearing of the image's top) and pitch (−90
straight down) as vectors: the axis, the image's right (level, square to the axis) and top
(right × axis); a roll is not modelled. A face point is seen when it projects inside the image
(pinhole: image width and height and focal length in mm), its face is turned towards the
camera, and no sample of the segment from the camera to the point (moved 1 cm off its face)
lies inside the prism (shapely's contains; 600 samples). A pair whose segment passes within
two samples' length of the prism's outline or roof is "grazing": marching cannot tell it.

Benched faces (a quarry's, a facade: one bench at 90°) are a solid given by its section
(`section`: metres behind the toe line, height; a shapely polygon) between the toe line's ends;
`bench_caster` marches the same segments through it, `distance_to_benches` measures a point's
distance from it (the section's distance, combined with how far beyond the line's ends).
"""

from __future__ import annotations

import math

import numpy as np
import shapely

Sensor = tuple[float, float, float]  # image width, height (mm, as the image is shown), focal length (mm)


def frame(yaw: float, pitch: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(axis, right, top) unit vectors (east, north, up)."""
    y, p = math.radians(yaw), math.radians(pitch)
    axis = np.array([math.sin(y) * math.cos(p), math.cos(y) * math.cos(p), math.sin(p)])
    right = np.array([math.cos(y), -math.sin(y), 0.0])
    return axis, right, np.cross(right, axis)


def project(sensor: Sensor, c: np.ndarray, yaw: float, pitch: float, p: np.ndarray) -> tuple[float, float, float]:
    """(u, v) in mm on the sensor (v up) of point p seen from c, and its depth along the axis."""
    axis, right, top = frame(yaw, pitch)
    rel = p - c
    depth = float(rel @ axis)
    return sensor[2] * float(rel @ right) / depth, sensor[2] * float(rel @ top) / depth, depth


def march(sensor: Sensor, cams: list, p: np.ndarray, n: np.ndarray, samples: int, judge) -> tuple[np.ndarray, np.ndarray]:
    """(seen, grazing), (cameras, points), for every camera (x, y, z, yaw, pitch) and point (m, 3)
    with its face's outward normal (m, 3): a point in the image, its face turned to the camera, and
    `judge(segment samples (samples, 3), step)` → (inside the solid (samples,), grazing (samples,))."""
    vis = np.zeros((len(cams), len(p)), bool)
    graze = np.zeros((len(cams), len(p)), bool)
    t = np.arange(samples) / samples
    for a, (x, y, z, yaw, pitch) in enumerate(cams):
        c = np.array([x, y, z], float)
        for b in range(len(p)):
            u, v, depth = project(sensor, c, yaw, pitch, p[b])
            if depth <= 0 or abs(u) > sensor[0] / 2 or abs(v) > sensor[1] / 2 or (c - p[b]) @ n[b] <= 0:
                continue
            q = p[b] + 0.01 * n[b]
            inside, near = judge(c[None] + t[:, None] * (q - c)[None], float(np.linalg.norm(q - c)) / samples)
            vis[a, b] = not inside.any()
            graze[a, b] = bool(near[: samples - 3].any())
    return vis, graze


def caster(footprint: shapely.Polygon, base: float, top: float, sensor: Sensor, cams: list, p: np.ndarray, n: np.ndarray,
           samples: int = 600) -> tuple[np.ndarray, np.ndarray]:
    """`march` through the prism."""
    outline = footprint.boundary
    grown = footprint.buffer(1.0)

    def judge(seg: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
        near_prism = shapely.contains_xy(grown, seg[:, 0], seg[:, 1]) & (seg[:, 2] <= top + 1.0)
        in_z = (seg[:, 2] >= base) & (seg[:, 2] <= top)
        inside = near_prism & in_z & shapely.contains_xy(footprint, seg[:, 0], seg[:, 1])
        near = near_prism & ((in_z & (shapely.distance(outline, shapely.points(seg[:, :2])) < 2 * step))
                             | ((np.abs(seg[:, 2] - top) < 2 * step)
                                & shapely.contains_xy(footprint.buffer(2 * step), seg[:, 0], seg[:, 1])))
        return inside, near

    return march(sensor, cams, p, n, samples, judge)


def prism_samples(footprint: shapely.Polygon, base: float, top: float, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (m, 3), outward normals (m, 3), areas (m,)): the walls of the exterior ring (the
    footprint counter-clockwise) in cells about `cell` wide and high, the roof at the centres of a
    `cell` grid inside the footprint (each standing for its cell, the roof's area shared out)."""
    ring = np.asarray(shapely.geometry.polygon.orient(footprint, 1.0).exterior.coords)
    pts, nrm, area = [], [], []
    levels = max(1, math.ceil((top - base) / cell))
    for a, b in zip(ring[:-1], ring[1:]):
        length = float(np.hypot(*(b - a)))
        k = max(1, math.ceil(length / cell))
        out = np.array([(b - a)[1], -(b - a)[0], 0.0]) / length
        for i in range(k):
            for j in range(levels):
                xy = a + (b - a) * (i + 0.5) / k
                pts.append([xy[0], xy[1], base + (top - base) * (j + 0.5) / levels])
                nrm.append(out)
                area.append(length / k * (top - base) / levels)
    x0, y0, x1, y1 = footprint.bounds
    gx, gy = np.meshgrid(np.arange(x0 + cell / 2, x1, cell), np.arange(y0 + cell / 2, y1, cell))
    inside = shapely.contains_xy(footprint, gx.ravel(), gy.ravel())
    for x, y in zip(gx.ravel()[inside], gy.ravel()[inside]):
        pts.append([x, y, top])
        nrm.append(np.array([0.0, 0.0, 1.0]))
        area.append(footprint.area / int(inside.sum()))
    return np.array(pts), np.array(nrm), np.array(area)


def section(base: float, angle: float, height: float, benches: int, berm: float, far: float = 1e4) -> shapely.Polygon:
    """The solid of benched faces in its section (metres behind the toe line, height): below the
    faces, berms and the plateau behind the last crest, closed far below and far behind."""
    run = height / math.tan(math.radians(angle)) if angle < 90 else 0.0
    ring = [(0.0, base - far)]
    for i in range(benches):
        d, z = i * (run + berm), base + i * height
        ring += [(d, z), (d + run, z + height)]
    ring += [(far, ring[-1][1]), (far, base - far)]
    return shapely.Polygon(ring)


def bench_samples(toe_a: np.ndarray, toe_b: np.ndarray, base: float, angle: float, height: float, benches: int, berm: float,
                  cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points (m, 3), outward normals (m, 3), areas (m,)) on the inclined faces rising right of the
    toe line a → b (local metres), cells about `cell` wide and up the slope."""
    along = (toe_b - toe_a) / np.linalg.norm(toe_b - toe_a)
    into = np.array([along[1], -along[0]])
    length = float(np.linalg.norm(toe_b - toe_a))
    a = math.radians(angle)
    slope = height / math.sin(a)
    run = height / math.tan(a) if angle < 90 else 0.0
    normal = np.array([-into[0] * math.sin(a), -into[1] * math.sin(a), math.cos(a)])
    n_u, n_t = max(1, math.ceil(length / cell)), max(1, math.ceil(slope / cell))
    pts = []
    for i in range(benches):
        for k in range(n_u):
            for j in range(n_t):
                t = slope * (j + 0.5) / n_t
                d = i * (run + berm) + t * math.cos(a)
                xy = toe_a + along * length * (k + 0.5) / n_u + into * d
                pts.append([xy[0], xy[1], base + i * height + t * math.sin(a)])
    m = len(pts)
    return np.array(pts), np.repeat(normal[None], m, axis=0), np.full(m, length / n_u * slope / n_t)


def to_section(toe_a: np.ndarray, toe_b: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(along the toe line from a, beyond its ends (0 between), behind it) of local points (m, ≥ 2)."""
    length = float(np.linalg.norm(toe_b - toe_a))
    along = (toe_b - toe_a) / length
    rel = p[:, :2] - toe_a
    u = rel @ along
    return u, np.maximum(0.0, np.maximum(-u, u - length)), rel @ np.array([along[1], -along[0]])


def bench_caster(toe_a: np.ndarray, toe_b: np.ndarray, solid: shapely.Polygon, sensor: Sensor, cams: list, p: np.ndarray,
                 n: np.ndarray, samples: int = 600) -> tuple[np.ndarray, np.ndarray]:
    """`march` through the section `solid` between the toe line's ends."""
    outline = solid.boundary
    length = float(np.linalg.norm(toe_b - toe_a))

    def judge(seg: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
        u, out, d = to_section(toe_a, toe_b, seg)
        sec = shapely.points(d, seg[:, 2])
        inside = shapely.contains(solid, sec)
        end = np.minimum(np.abs(u), np.abs(u - length))
        edge = shapely.distance(outline, sec)
        near = (out < 2 * step) & ((edge < 2 * step) | (inside & (end < 2 * step)))
        deep = inside & (out == 0) & (edge >= 2 * step) & (end >= 2 * step)  # surely inside: no graze
        return inside & (out == 0), near & ~deep.any()

    return march(sensor, cams, p, n, samples, judge)


def distance_to_benches(toe_a: np.ndarray, toe_b: np.ndarray, solid: shapely.Polygon, p: np.ndarray) -> np.ndarray:
    """The distance (metres) of each local point (m, 3) from the solid (its section between the toe line's ends)."""
    _, out, d = to_section(toe_a, toe_b, p)
    return np.hypot(out, shapely.distance(solid, shapely.points(d, p[:, 2])))
