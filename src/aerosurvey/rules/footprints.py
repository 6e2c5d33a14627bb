"""Evidence measured from the planned photo footprints, not from the planner's spacing.

Footprints are nadir rectangles from the camera's sensor and each station's height above
ground, turned to the station's heading. Coverage is counted on a sample grid; overlaps
are measured between consecutive photos of a run and between neighbouring parallel runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.rules.planview import PlanView


@dataclass(frozen=True)
class Footprints:
    x: np.ndarray
    y: np.ndarray
    heading_rad: np.ndarray  # compass bearing in radians
    across: np.ndarray
    along: np.ndarray

    def count_at(self, px: np.ndarray, py: np.ndarray) -> np.ndarray:
        """How many footprints contain each point."""
        counts = np.zeros(len(px), int)
        s, c = np.sin(self.heading_rad), np.cos(self.heading_rad)
        x0, y0, x1, y1 = px.min(), py.min(), px.max(), py.max()
        reach = np.hypot(self.across, self.along) / 2
        near = (self.x + reach >= x0) & (self.x - reach <= x1) & (self.y + reach >= y0) & (self.y - reach <= y1)
        for i in np.flatnonzero(near):
            dx, dy = px - self.x[i], py - self.y[i]
            u = dx * s[i] + dy * c[i]
            v = dx * c[i] - dy * s[i]
            counts += (np.abs(u) <= self.along[i] / 2 + 1e-6) & (np.abs(v) <= self.across[i] / 2 + 1e-6)
        return counts


def footprints(view: PlanView) -> Footprints:
    cam = view.camera
    sw, sh = cam["sensor_mm"]
    f = cam["focal_mm"]
    k = float(view.manifest.get("derived", {}).get("grid_scale", 1.0))  # ground metres to grid metres
    long_, short = sw / f * view.agl * k, sh / f * view.agl * k
    across, along = (long_, short) if cam["mount"] == "landscape" else (short, long_)
    return Footprints(view.x, view.y, np.radians(view.heading_deg), across, along)


def sample_grid(geom: BaseGeometry, target_points: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    """A regular grid of points inside `geom`, about `target_points` of them."""
    step = math.sqrt(max(geom.area, 1.0) / target_points)
    x0, y0, x1, y1 = geom.bounds
    gx, gy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    gx, gy = gx.ravel(), gy.ravel()
    keep = shapely.contains_xy(geom, gx, gy)
    return gx[keep], gy[keep]


def runs(view: PlanView) -> dict[str, np.ndarray]:
    """Station indices of each run, in flight order."""
    out: dict[str, list[int]] = {}
    for i, r in enumerate(view.run_ids):
        out.setdefault(r, []).append(i)
    return {k: np.asarray(v) for k, v in out.items()}


def forward_overlaps(view: PlanView, fp: Footprints) -> list[tuple[str, float]]:
    """(run id, lowest overlap between consecutive photos of that run)."""
    out = []
    for rid, idx in runs(view).items():
        if len(idx) < 2:
            continue
        d = np.hypot(np.diff(fp.x[idx]), np.diff(fp.y[idx]))
        along = np.minimum(fp.along[idx][:-1], fp.along[idx][1:])
        out.append((rid, float(np.min(1 - d / along))))
    return out


def side_overlaps(view: PlanView, fp: Footprints) -> list[tuple[str, str, float]]:
    """(run, nearest parallel run beside it, overlap of their strips) for every run."""
    rs = runs(view)
    info = {}
    for rid, idx in rs.items():
        h = float(np.median(fp.heading_rad[idx]))
        s, c = math.sin(h), math.cos(h)
        u = fp.x[idx] * s + fp.y[idx] * c
        v = fp.x[idx] * c - fp.y[idx] * s
        info[rid] = (h, float(u.min()), float(u.max()), float(v.mean()), float(fp.across[idx].min()))
    out = []
    for rid, (h, umin, umax, v, w) in info.items():
        s, c = math.sin(h), math.cos(h)
        best = None
        for q, (hq, _, _, _, wq) in info.items():
            if q == rid or abs(math.sin(hq - h)) > 0.052:  # parallel within 3°: flown yaw wanders a little
                continue
            idx = rs[q]
            uq = fp.x[idx] * s + fp.y[idx] * c
            vq = float(np.mean(fp.x[idx] * c - fp.y[idx] * s))
            if uq.max() < umin or uq.min() > umax:
                continue
            d = abs(vq - v)
            if d > 1e-6 and (best is None or d < best[0]):
                best = (d, q, min(w, wq))
        if best is not None:
            out.append((rid, best[1], 1 - best[0] / best[2]))
    return out


def boundary_crossings(view: PlanView, min_outside: int) -> list[dict]:
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
        found.append({"run": rid, "where": "entry", "outside_photos": first, "ok": first >= min_outside})
        found.append({"run": rid, "where": "exit", "outside_photos": len(idx) - 1 - last, "ok": len(idx) - 1 - last >= min_outside})
        gaps = np.flatnonzero(np.diff(pos) > 1)
        for g in gaps:
            n = int(pos[g + 1] - pos[g] - 1)
            found.append({"run": rid, "where": "notch crossed with the camera on", "outside_photos": n, "ok": True})
    return found
