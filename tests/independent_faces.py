"""An independent ray caster for a structure's faces: a prism (a footprint polygon from a base
up to a top) photographed by frame cameras, shared by nothing in src/.

The camera's frame is built from its yaw (compass bearing of the image's top) and pitch (−90
straight down) as vectors: the axis, the image's right (level, square to the axis) and top
(right × axis); a roll is not modelled. A face point is seen when it projects inside the image
(pinhole: image width and height and focal length in mm), its face is turned towards the
camera, and no sample of the segment from the camera to the point (moved 1 cm off its face)
lies inside the prism (shapely's contains; 600 samples). A pair whose segment passes within
two samples' length of the prism's outline or roof is "grazing": marching cannot tell it.
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


def caster(footprint: shapely.Polygon, base: float, top: float, sensor: Sensor, cams: list, p: np.ndarray, n: np.ndarray,
           samples: int = 600) -> tuple[np.ndarray, np.ndarray]:
    """(seen, grazing), (cameras, points), for every camera (x, y, z, yaw, pitch) and point (m, 3)
    with its face's outward normal (m, 3)."""
    outline = footprint.boundary
    grown = footprint.buffer(1.0)
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
            seg = c[None] + t[:, None] * (q - c)[None]
            step = float(np.linalg.norm(q - c)) / samples
            near_prism = shapely.contains_xy(grown, seg[:, 0], seg[:, 1]) & (seg[:, 2] <= top + 1.0)
            seg, k = seg[near_prism], np.flatnonzero(near_prism)
            in_z = (seg[:, 2] >= base) & (seg[:, 2] <= top)
            inside = in_z & shapely.contains_xy(footprint, seg[:, 0], seg[:, 1])
            near = (in_z & (shapely.distance(outline, shapely.points(seg[:, :2])) < 2 * step)) \
                | ((np.abs(seg[:, 2] - top) < 2 * step) & shapely.contains_xy(footprint.buffer(2 * step), seg[:, 0], seg[:, 1]))
            vis[a, b] = not inside.any()
            graze[a, b] = bool(near[k < samples - 3].any())
    return vis, graze


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
