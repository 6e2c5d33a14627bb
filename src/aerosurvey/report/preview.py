"""A self-contained SVG picture of the plan for the pilot: area, exclusion zones, lines in
flight order, stations, take-off point and start, with a scale bar and a north arrow.

Drawn in the planning CRS (metres, grid north up), so distances on the picture are true.
"""

from __future__ import annotations

import math
from html import escape
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from aerosurvey.jsontext import float_texts, join_rows
from aerosurvey.plan.planner import Plan
from aerosurvey.report.summary import Summary, title_figures

if TYPE_CHECKING:
    from aerosurvey.rules.control_points import ControlPoint

_W, _H, _PAD, _HEAD, _FOOT = 1000, 800, 40, 70, 30


class _View:
    def __init__(self, bounds: tuple[float, float, float, float]):
        x0, y0, x1, y1 = bounds
        self.s = min((_W - 2 * _PAD) / max(x1 - x0, 1e-9), (_H - _HEAD - _FOOT - 2 * _PAD) / max(y1 - y0, 1e-9))
        self.x0, self.y1 = x0, y1
        self.ox = _PAD + ((_W - 2 * _PAD) - (x1 - x0) * self.s) / 2
        self.oy = _HEAD + _PAD + ((_H - _HEAD - _FOOT - 2 * _PAD) - (y1 - y0) * self.s) / 2

    def pt(self, x: float, y: float) -> tuple[float, float]:
        return self.ox + (x - self.x0) * self.s, self.oy + (self.y1 - y) * self.s

    def pts(self, x: np.ndarray, y: np.ndarray) -> tuple[list[float], list[float]]:
        """`pt` of many points at once (the same arithmetic, so the same numbers)."""
        px: list[float] = (self.ox + (np.asarray(x, float) - self.x0) * self.s).tolist()
        py: list[float] = (self.oy + (self.y1 - np.asarray(y, float)) * self.s).tolist()
        return px, py

    def path(self, geom: BaseGeometry) -> str:
        out = []
        for poly in shapely.get_parts(geom):
            for ring in [poly.exterior, *poly.interiors]:
                pts = [self.pt(x, y) for x, y in ring.coords]
                out.append("M" + " L".join(f"{a:.1f},{b:.1f}" for a, b in pts) + " Z")
        return " ".join(out)


def tenths(values: list[float]) -> list[str]:
    """`f"{v:.1f}"` of each value, made by numpy and orjson (`jsontext.float_texts`) rather
    than a format a value: the stations' dots, two numbers a photo (measured on the 1,000 ha
    benchmark's 7,309 dots: 6 ms a format each, ~1.5 ms this way).

    `.1f` rounds the value's exact decimal to the nearest tenth, ties to even. Away from a tie
    that is `rint(10 v)` (the product's rounding error is far below the 1e-6 kept from a tie),
    and `repr(k / 10)` is then the text: the double nearest to k/10 reads back from one decimal,
    and -0.0 stays "-0.0". Near a tie, at 1e15 or more, or not finite, the value is formatted."""
    a = np.asarray(values, float)
    big = ~(np.abs(a) < 1e15)  # NaN too
    ten = np.where(big, 0.0, a) * 10.0
    odd = big | (np.abs(ten - np.floor(ten) - 0.5) < 1e-6)
    texts = float_texts(np.where(odd, 0.0, np.rint(ten) / 10.0))
    for i in np.flatnonzero(odd).tolist():
        texts[i] = f"{values[i]:.1f}"
    return texts


def _scale_bar(view: _View) -> str:
    target = 150 / view.s
    nice = 10 ** math.floor(math.log10(target))
    for m in (1, 2, 5, 10):
        if nice * m >= target:
            nice *= m
            break
    px = nice * view.s
    x, y = _PAD, _H - 18
    label = f"{nice / 1000:g} km" if nice >= 1000 else f"{nice:g} m"
    return (f'<g><rect x="{x}" y="{y - 6}" width="{px:.1f}" height="6" fill="#222"/>'
            f'<text x="{x + px + 6:.1f}" y="{y}" font-size="13">{label}</text></g>')


def render_svg(plan: Plan, summary: Summary, points: list[ControlPoint] | None = None) -> str:
    """The preview as SVG text (deterministic): the plan's geometry, its head from the plan's
    summary (the figures `plan` prints, the rule count included), control points when given."""
    st = plan.stations
    wp = np.asarray([(w.x, w.y) for w in plan.waypoints])
    geoms = [plan.site.area, shapely.MultiPoint(wp)]
    if plan.site.zones is not None:
        geoms.append(plan.site.zones)
    x0, y0, x1, y1 = shapely.total_bounds(geoms)
    view = _View((x0, y0, x1, y1))
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{_W}" height="{_H}" viewBox="0 0 {_W} {_H}" font-family="sans-serif">',
             f'<rect width="{_W}" height="{_H}" fill="#fafaf7"/>']
    s = summary
    n = len(s.sorties)
    sorties = "" if not n else f", {n} sortie" if n == 1 else f", {n} sorties"
    title = escape(f"{s.name}: {title_figures(s)}, {s.runs} runs, {s.photos} photos, "
                   f"{s.distance_km:.2f} km, {s.time_min:.1f} min{sorties}")
    parts.append(f'<text x="{_PAD}" y="30" font-size="18" font-weight="bold">{title}</text>')
    parts.append(f'<text x="{_PAD}" y="52" font-size="13">heading {s.heading_deg:.1f}° ({escape(s.heading_chosen)}), '
                 f'spacing {s.spacing_m:.1f} m, photo base {s.photo_base_m:.2f} m, CRS {escape(s.crs)}</text>')
    colour = "#b00" if s.rules.failing else "#070"
    parts.append(f'<text x="{_PAD}" y="{_HEAD - 2}" font-size="13" fill="{colour}">{escape("rules: " + s.rules.text())}</text>')
    parts.append(f'<path d="{view.path(plan.site.area)}" fill="#cfe8c4" fill-rule="evenodd" stroke="#3a7d2c" '
                 'stroke-width="2"><title>area</title></path>')
    if plan.site.zones is not None:
        parts.append(f'<path d="{view.path(plan.site.zones)}" fill="#f4b4b4" fill-opacity="0.8" stroke="#b00" '
                     'stroke-width="2"><title>exclusion zone</title></path>')
    # the route's points as `pt` places them, their texts by `tenths` (a format a number took ~1 ms for the 1,000 ha plan's 198)
    wx, wy = view.pts(wp[:, 0], wp[:, 1])
    parts.append('<polyline fill="none" stroke="#888" stroke-width="1" stroke-dasharray="4 3" points="'
                 + join_rows([tenths(wx), ",", tenths(wy)], len(wx), " ") + '"><title>route</title></polyline>')
    colours = {1: "#1f5fbf", 2: "#c0601a"}
    # each run's line as flown with the camera on: first station, bends, last station (every run's
    # points placed and written in one go, then split by run)
    lines = [np.vstack([r.station_xy[:1], r.bends_xy, r.station_xy[-1:]]) for r in plan.route.runs]
    if lines:
        at = np.cumsum([len(line) for line in lines]).tolist()
        xy = np.concatenate(lines)
        lx, ly = view.pts(xy[:, 0], xy[:, 1])
        texts = [f"{x},{y}" for x, y in zip(tenths(lx), tenths(ly))]
        for i, (r, start, end) in enumerate(zip(plan.route.runs, [0, *at[:-1]], at)):
            parts.append(f'<polyline fill="none" points="{" ".join(texts[start:end])}" stroke="{colours.get(r.pass_index, "#555")}" '
                         f'stroke-width="2"><title>run {i + 1}, {len(r.station_xy)} photos</title></polyline>')
    if len(st.ids) <= 20000:
        dx, dy = view.pts(st.x, st.y)
        dots = join_rows(["M", tenths(dx), ",", tenths(dy), "h0.01"], len(dx), "")
        parts.append(f'<path d="{dots}" stroke="#111" stroke-width="2.5" stroke-linecap="round"><title>photo stations</title></path>')
    hx, hy = view.pt(*plan.launch.home_xy)
    parts.append(f'<circle cx="{hx:.1f}" cy="{hy:.1f}" r="7" fill="#fff" stroke="#000" stroke-width="2">'
                 '<title>take-off (home)</title></circle>')
    sx, sy = wx[0], wy[0]
    parts.append(f'<polygon points="{sx:.1f},{sy - 9:.1f} {sx + 8:.1f},{sy + 6:.1f} {sx - 8:.1f},{sy + 6:.1f}" fill="#0a0">'
                 '<title>start of the survey</title></polygon>')
    for p in points or []:
        px, py = view.pt(p.x, p.y)
        if p.role == "gcp":
            parts.append(f'<rect x="{px - 5:.1f}" y="{py - 5:.1f}" width="10" height="10" fill="#e00" stroke="#000">'
                         f'<title>{escape(p.id)}: GCP, {p.images} photos</title></rect>')
        else:
            parts.append(f'<circle cx="{px:.1f}" cy="{py:.1f}" r="5" fill="#08f" stroke="#000">'
                         f'<title>{escape(p.id)}: check point, {p.images} photos</title></circle>')
    parts.append(_scale_bar(view))
    nx, ny = _W - 50, _HEAD + 30
    parts.append(f'<g><polygon points="{nx},{ny - 20} {nx + 8},{ny + 6} {nx},{ny} {nx - 8},{ny + 6}" fill="#222"/>'
                 f'<text x="{nx - 5}" y="{ny + 24}" font-size="14">N</text></g>')
    legend = [("#cfe8c4", "area"), ("#f4b4b4", "exclusion zone"), (colours[1], "lines"), (colours[2], "cross-hatch lines"),
              ("#e00", "GCP"), ("#08f", "check point")]
    x, y = 330, _H - 12
    for c, label in legend:
        parts.append(f'<rect x="{x}" y="{y - 10}" width="14" height="10" fill="{c}" stroke="#444" stroke-width="0.5"/>'
                     f'<text x="{x + 18}" y="{y}" font-size="12">{label}</text>')
        x += 30 + 7 * len(label)
    parts.append("</svg>")
    return "\n".join(parts) + "\n"
