"""A self-contained HTML accuracy report: residual vectors, histograms, posterior density
(inline SVG drawn here, no external assets)."""

from __future__ import annotations

import json
import math
from html import escape
from typing import Any

import numpy as np

from aerosurvey.qa.points import CheckPoints


def _vector_map(pts: CheckPoints, w: int = 420, h: int = 420) -> str:
    known = np.all(np.isfinite(pts.x)) and np.all(np.isfinite(pts.y))
    if known:
        x, y = pts.x, pts.y
    else:  # no positions: lay the points out in a grid, in file order
        k = math.ceil(math.sqrt(pts.n))
        x = np.arange(pts.n) % k
        y = -(np.arange(pts.n) // k)
    x0, x1, y0, y1 = x.min(), x.max(), y.min(), y.max()
    span = max(x1 - x0, y1 - y0, 1e-9)
    s = (w - 60) / span
    emax = max(float(np.max(np.hypot(pts.dx, pts.dy))), 1e-12)
    scale = 0.12 * (w - 60) / emax  # the longest vector is 12 % of the map
    out = [f'<svg width="{w}" height="{h}" viewBox="0 0 {w} {h}" xmlns="http://www.w3.org/2000/svg">',
           '<defs><marker id="a" markerWidth="6" markerHeight="6" refX="5" refY="3" orient="auto">'
           '<path d="M0,0 L6,3 L0,6 z" fill="#b00"/></marker></defs>']
    for pid, px, py, dx, dy, role in zip(pts.ids, x, y, pts.dx, pts.dy, pts.role):
        cx, cy = 30 + (px - x0) * s, h - 30 - (py - y0) * s
        col = "#06c" if role == "check" else "#f80"
        out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="3" fill="{col}"><title>{escape(pid)}: dx {dx * 100:.2f} cm, '
                   f'dy {dy * 100:.2f} cm</title></circle>')
        out.append(f'<line x1="{cx:.1f}" y1="{cy:.1f}" x2="{cx + dx * scale:.1f}" y2="{cy - dy * scale:.1f}" '
                   f'stroke="#b00" stroke-width="1.5" marker-end="url(#a)"/>')
    out.append(f'<text x="10" y="15" font-size="12">vectors: longest = {emax * 100:.2f} cm'
               f'{"" if known else " (no positions given: points in file order)"}</text></svg>')
    return "".join(out)


def _histogram(e: np.ndarray, label: str, w: int = 300, h: int = 160) -> str:
    e = e[np.isfinite(e)] * 100
    if len(e) == 0:
        return ""
    counts, edges = np.histogram(e, bins=min(12, max(3, len(e) // 2)))
    bw = (w - 40) / len(counts)
    top = max(counts.max(), 1)
    bars = "".join(f'<rect x="{20 + i * bw:.1f}" y="{h - 25 - c / top * (h - 45):.1f}" width="{bw - 2:.1f}" '
                   f'height="{c / top * (h - 45):.1f}" fill="#69c"><title>{edges[i]:.2f}..{edges[i + 1]:.2f} cm: {c}</title></rect>'
                   for i, c in enumerate(counts))
    return (f'<svg width="{w}" height="{h}" xmlns="http://www.w3.org/2000/svg"><text x="5" y="14" font-size="12">{escape(label)} '
            f'residuals (cm)</text>{bars}<text x="20" y="{h - 8}" font-size="10">{edges[0]:.2f}</text>'
            f'<text x="{w - 50}" y="{h - 8}" font-size="10">{edges[-1]:.2f}</text></svg>')


def _posterior(xs: np.ndarray, ys: np.ndarray, lo: float, hi: float, mode: float, w: int = 420, h: int = 200) -> str:
    sx = (w - 40) / (xs[-1] - xs[0])
    sy = (h - 40) / ys.max()
    pts = " ".join(f"{20 + (x - xs[0]) * sx:.1f},{h - 20 - y * sy:.1f}" for x, y in zip(xs, ys))
    def vx(v: float) -> float:
        return 20 + (v - xs[0]) * sx
    return (f'<svg width="{w}" height="{h}" xmlns="http://www.w3.org/2000/svg">'
            f'<rect x="{vx(lo):.1f}" y="20" width="{vx(hi) - vx(lo):.1f}" height="{h - 40}" fill="#def"/>'
            f'<polyline points="{pts}" fill="none" stroke="#036" stroke-width="2"/>'
            f'<line x1="{vx(mode):.1f}" y1="20" x2="{vx(mode):.1f}" y2="{h - 20}" stroke="#b00"/>'
            f'<text x="20" y="14" font-size="12">posterior of sigma: mode {mode:.2f}, 95 % interval {lo:.2f}..{hi:.2f}</text></svg>')


def render(title: str, result: dict[str, Any], pts: CheckPoints | None, posterior: tuple | None = None) -> str:
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{escape(title)}</title>"
             "<style>body{font-family:sans-serif;margin:2em;max-width:1000px} pre{background:#f6f6f6;padding:1em;"
             "overflow:auto} .warn{color:#a40}</style></head><body>", f"<h1>{escape(title)}</h1>"]
    for s in result.get("sentences", []):
        parts.append(f"<p><b>{escape(s)}</b></p>")
    for wtext in result.get("warnings", []):
        parts.append(f"<p class='warn'>Warning: {escape(wtext)}</p>")
    if pts is not None:
        parts.append("<h2>Residual vectors</h2>" + _vector_map(pts))
        parts.append("<h2>Histograms</h2>" + "".join(_histogram(e, a) for a, e in (("x", pts.dx), ("y", pts.dy), ("z", pts.dz))))
    if posterior is not None:
        parts.append("<h2>Posterior density</h2>" + _posterior(*posterior))
    parts.append("<h2>All figures</h2><pre>" + escape(json.dumps(result, indent=1, default=str)) + "</pre></body></html>")
    return "\n".join(parts) + "\n"
