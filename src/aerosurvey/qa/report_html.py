"""A self-contained HTML accuracy report: residual vector map, histograms per axis,
the posterior density (inline SVG drawn here: no scripts, no external files)."""

from __future__ import annotations

import json
import math
from html import escape
from typing import Any

import numpy as np

from aerosurvey.qa.accuracy_input import CheckPoints
from aerosurvey.qa.report_text import uncertainty_lines, verdict_line

_CSS = ("body{font-family:sans-serif;margin:2em;max-width:1100px;color:#222} table{border-collapse:collapse;"
        "margin:.5em 0} td,th{border:1px solid #ccc;padding:2px 8px;text-align:right} th{background:#f0f0f0}"
        " td.l{text-align:left} .warn{color:#a40} .ok{color:#060} .bad{color:#b00} pre{background:#f6f6f6;"
        "padding:1em;overflow:auto;font-size:12px} svg{background:#fff;border:1px solid #ddd;margin:4px}")


def _nice(x: float) -> float:
    """A round length (1, 2 or 5 × 10^k) close to x, for scale bars."""
    if not x > 0:
        return 1.0
    k = math.floor(math.log10(x))
    return float(min((m * 10.0**k for m in (1, 2, 5, 10)), key=lambda v: abs(v - x)))


def vector_map(pts: CheckPoints, flagged: set[str], w: int = 520, h: int = 520) -> str:
    """Horizontal residual vectors at the points (exaggerated; scale bars for both), dz as colour."""
    if pts.has_positions:
        x, y = pts.local_xy()
        note = ""
    else:
        k = math.ceil(math.sqrt(pts.n))
        x, y = (np.arange(pts.n) % k).astype(float), -(np.arange(pts.n) // k).astype(float)
        note = " (no positions given: points laid out in file order)"
    pad = 64
    span = max(float(np.ptp(x)), float(np.ptp(y)), 1e-9)
    s = (w - 2 * pad) / span
    x0, y0 = float(x.min()), float(y.min())
    emax = max(float(np.max(np.hypot(pts.dx, pts.dy))), 1e-12)
    vscale = 0.1 * (w - 2 * pad) / emax  # the longest vector is a tenth of the map, inside the margin
    dzmax = float(np.nanmax(np.abs(pts.dz))) if np.isfinite(pts.dz).any() else 0.0
    out = [f'<svg width="{w}" height="{h + 40}" viewBox="0 0 {w} {h + 40}" xmlns="http://www.w3.org/2000/svg">',
           '<defs><marker id="arr" markerWidth="7" markerHeight="7" refX="6" refY="3.5" orient="auto">'
           '<path d="M0,0 L7,3.5 L0,7 z" fill="#b00"/></marker></defs>']
    for pid, px, py, dx, dy, dz, role in zip(pts.ids, x, y, pts.dx, pts.dy, pts.dz, pts.role):
        cx, cy = pad + (px - x0) * s, h - pad - (py - y0) * s
        if np.isfinite(dz) and dzmax > 0:
            t = dz / dzmax
            fill = f"rgb({int(128 + 127 * max(t, 0))},{int(128 - 100 * abs(t))},{int(128 + 127 * max(-t, 0))})"
        else:
            fill = "#888"
        shape = (f'<rect x="{cx - 4:.1f}" y="{cy - 4:.1f}" width="8" height="8" fill="{fill}"' if role == "control"
                 else f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="4" fill="{fill}"')
        dz_txt = f", dz {dz * 100:+.2f} cm" if np.isfinite(dz) else ""
        out.append(f'{shape}><title>{escape(pid)} ({role}): dx {dx * 100:+.2f} cm, dy {dy * 100:+.2f} cm{dz_txt}'
                   f'</title></{"rect" if role == "control" else "circle"}>')
        if pid in flagged:
            out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="9" fill="none" stroke="#b00" stroke-width="1.5"/>')
        out.append(f'<line x1="{cx:.1f}" y1="{cy:.1f}" x2="{cx + dx * vscale:.1f}" y2="{cy - dy * vscale:.1f}" '
                   'stroke="#b00" stroke-width="1.5" marker-end="url(#arr)"/>')
        out.append(f'<text x="{cx + 6:.1f}" y="{cy + 12:.1f}" font-size="9" fill="#555">{escape(pid)}</text>')
    ev = _nice(emax / 2)
    out.append(f'<line x1="{pad}" y1="{h + 10}" x2="{pad + ev * vscale:.1f}" y2="{h + 10}" stroke="#b00" '
               f'stroke-width="2"/><text x="{pad}" y="{h + 25}" font-size="11">vector {ev * 100:g} cm</text>')
    if pts.has_positions:
        gv = _nice(span / 4)
        out.append(f'<line x1="{w - pad - gv * s:.1f}" y1="{h + 10}" x2="{w - pad}" y2="{h + 10}" stroke="#000" '
                   f'stroke-width="2"/><text x="{w - pad - gv * s:.1f}" y="{h + 25}" font-size="11">ground {gv:g} m</text>')
    legend = "circle: check point, square: control; fill: dz (red up, blue down"
    legend += f", +/- {dzmax * 100:.2f} cm)" if dzmax > 0 else ")"
    out.append(f'<text x="10" y="16" font-size="11">{escape(legend)}; ringed: flagged{escape(note)}</text></svg>')
    return "".join(out)


def histogram(e: np.ndarray, label: str, w: int = 340, h: int = 190) -> str:
    """Histogram of one axis's residuals (cm) with the normal curve of the same mean and std."""
    e = np.asarray(e, float)
    e = e[np.isfinite(e)] * 100
    if len(e) == 0:
        return ""
    bins = int(min(15, max(4, math.ceil(math.sqrt(len(e))))))
    lo, hi = float(e.min()), float(e.max())
    if hi - lo < 1e-9:
        lo, hi = lo - 0.5, hi + 0.5
    counts, edges = np.histogram(e, bins=bins, range=(lo, hi))
    pl, pr, pt, pb = 30, 10, 22, 28
    bw = (w - pl - pr) / bins
    top = max(int(counts.max()), 1)
    sy = (h - pt - pb) / top
    parts = [f'<svg width="{w}" height="{h}" xmlns="http://www.w3.org/2000/svg">',
             f'<text x="5" y="14" font-size="12">{escape(label)} residuals (cm), n = {len(e)}</text>']
    for i, c in enumerate(counts):
        parts.append(f'<rect x="{pl + i * bw:.1f}" y="{h - pb - c * sy:.1f}" width="{max(bw - 1, 1):.1f}" '
                     f'height="{c * sy:.1f}" fill="#69c"><title>{edges[i]:.2f} .. {edges[i + 1]:.2f} cm: {c}'
                     '</title></rect>')
    if len(e) > 2 and e.std(ddof=1) > 0:
        mu, sd = float(e.mean()), float(e.std(ddof=1))
        xs = np.linspace(lo, hi, 80)
        ys = len(e) * (hi - lo) / bins * np.exp(-0.5 * ((xs - mu) / sd) ** 2) / (sd * math.sqrt(2 * math.pi))
        poly = " ".join(f"{pl + (a - lo) / (hi - lo) * (w - pl - pr):.1f},{h - pb - b * sy:.1f}" for a, b in zip(xs, ys))
        parts.append(f'<polyline points="{poly}" fill="none" stroke="#c60" stroke-width="1.5"/>')
    parts.append(f'<text x="{pl}" y="{h - 10}" font-size="10">{lo:.2f}</text>'
                 f'<text x="{w - pr - 40}" y="{h - 10}" font-size="10">{hi:.2f}</text>'
                 f'<text x="2" y="{pt + 8}" font-size="10">{top}</text></svg>')
    return "".join(parts)


def posterior_plot(post: dict[str, Any], unit: str = "cm", factor: float = 100.0, w: int = 520, h: int = 230) -> str:
    """The posterior density of σ with the mode and the 95 % credible interval shaded.

    `post` holds metres (`factor` 100 shows cm) or, for summary statistics, the user's
    own unit (`factor` 1, `unit` as given)."""
    xs = np.asarray(post["sigma_m"]) * factor
    ys = np.asarray(post["density"])
    pl, pr, pt, pb = 20, 20, 24, 30
    sx = (w - pl - pr) / (xs[-1] - xs[0])
    sy = (h - pt - pb) / ys.max()

    def vx(v: float) -> float:
        return float(pl + (v - xs[0]) * sx)

    lo, hi, md = post["lower_m"] * factor, post["upper_m"] * factor, post["mode_m"] * factor
    poly = " ".join(f"{vx(a):.1f},{h - pb - b * sy:.1f}" for a, b in zip(xs, ys))
    inside = (xs >= lo) & (xs <= hi)
    area = " ".join(f"{vx(a):.1f},{h - pb - b * sy:.1f}" for a, b in zip(xs[inside], ys[inside]))
    area = f"{vx(lo):.1f},{h - pb} {area} {vx(hi):.1f},{h - pb}"
    label = "one horizontal coordinate" if post["axis"] == "xy" else "height"
    return (f'<svg width="{w}" height="{h}" xmlns="http://www.w3.org/2000/svg">'
            f'<polygon points="{area}" fill="#cde"/>'
            f'<polyline points="{poly}" fill="none" stroke="#036" stroke-width="2"/>'
            f'<line x1="{vx(md):.1f}" y1="{pt}" x2="{vx(md):.1f}" y2="{h - pb}" stroke="#b00"/>'
            f'<text x="{pl}" y="15" font-size="12">posterior of sigma ({escape(label)}): mode {md:.2f} {unit}, 95 % '
            f'credible interval {lo:.2f} .. {hi:.2f} {unit}</text>'
            f'<text x="{pl}" y="{h - 10}" font-size="10">{xs[0]:.2f} {unit}</text>'
            f'<text x="{w - pr - 60}" y="{h - 10}" font-size="10">{xs[-1]:.2f} {unit}</text></svg>')


def _stats_table(r: dict[str, Any]) -> str:
    rows = ["<table><tr><th class='l'>axis</th><th>n</th><th>mean</th><th>std</th><th>RMSE</th><th>min</th>"
            "<th>max</th><th>|e| p50</th><th>|e| p95</th><th>bias p</th><th>skew</th><th>kurtosis</th>"
            "<th>normality p</th></tr>"]

    def c(v: float | None) -> str:
        return "-" if v is None else f"{v * 100:.2f}"

    def f(v: float | None) -> str:
        return "-" if v is None else f"{v:.3f}"

    for axis in ("x", "y", "z"):
        a = r["statistics"][axis]
        if a.get("n"):
            rows.append(f"<tr><td class='l'>{axis} (cm)</td><td>{a['n']}</td><td>{c(a['mean_m'])}</td>"
                        f"<td>{c(a['std_m'])}</td><td>{c(a['rmse_m'])}</td><td>{c(a['min_m'])}</td>"
                        f"<td>{c(a['max_m'])}</td><td>{c(a['abs_p50_m'])}</td><td>{c(a['abs_p95_m'])}</td>"
                        f"<td>{f(a['bias_p_value'])}</td><td>{f(a['skew'])}</td><td>{f(a['kurtosis'])}</td>"
                        f"<td>{f(a['normality_p_value'])}</td></tr>")
    rows.append("</table>")
    h, v = r["statistics"]["horizontal"], r["statistics"]["vertical"]
    rows.append(f"<p>Horizontal: RMSE_r {c(h['rmse_r_m'])} cm, CE90 {c(h['ce90_m'])} cm, CE95 {c(h['ce95_m'])} cm "
                "(exact, bivariate normal)."
                + (f" Vertical: RMSE_z {c(v['rmse_z_m'])} cm, LE90 {c(v['le90_m'])} cm, LE95 {c(v['le95_m'])} cm; "
                   f"RMSE_3D {c(r['statistics']['rmse_3d_m'])} cm." if v.get("n") else "") + "</p>")
    return "".join(rows)


def _points_table(r: dict[str, Any]) -> str:
    rows = ["<table><tr><th class='l'>id</th><th class='l'>role</th><th>dx (cm)</th><th>dy (cm)</th><th>dz (cm)</th>"
            "<th class='l'>land cover</th><th class='l'>flags</th></tr>"]
    for p in r["points"]:
        dz = "-" if p["dz_m"] is None else f"{p['dz_m'] * 100:+.2f}"
        role = p["role"] + ("" if p["tested"] else " (not tested)")
        rows.append(f"<tr><td class='l'>{escape(p['id'])}</td><td class='l'>{escape(role)}</td>"
                    f"<td>{p['dx_m'] * 100:+.2f}</td><td>{p['dy_m'] * 100:+.2f}</td><td>{dz}</td>"
                    f"<td class='l'>{'vegetated' if p['vegetated'] else 'non-vegetated'}</td>"
                    f"<td class='l'>{escape(', '.join(p['flags']))}</td></tr>")
    rows.append("</table>")
    return "".join(rows)


def render(r: dict[str, Any], pts: CheckPoints | None) -> str:
    """The whole report as one HTML string."""
    title = f"Accuracy report: {r['input']['file']} ({r['standard_name']})"
    verdict = verdict_line(r)
    cls = {True: "ok", False: "bad"}.get(r["passed"], "")
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{escape(title)}</title><style>{_CSS}</style>"
             f"</head><body><h1>{escape(title)}</h1>", f"<p class='{cls}'><b>{escape(verdict)}</b></p>"]
    parts += [f"<p><b>{escape(s)}</b></p>" for s in r["sentences"]]
    unc = uncertainty_lines(r)
    if unc:
        parts.append("<h2>Uncertainty</h2><ul>" + "".join(f"<li>{escape(u.strip())}</li>" for u in unc) + "</ul>")
    if r["warnings"]:
        parts.append("<h2>Warnings</h2><ul>" + "".join(f"<li class='warn'>{escape(w)}</li>" for w in r["warnings"])
                     + "</ul>")
    parts.append("<h2>Statistics</h2>" + _stats_table(r))
    if pts is not None:
        flagged = {p["id"] for p in r["points"] if p["flags"]}
        parts.append("<h2>Residual vectors</h2>" + vector_map(pts, flagged))
        tested = {p["id"] for p in r["points"] if p["tested"]}
        keep = np.array([i in tested for i in pts.ids], bool)
        sub = pts.select(keep)
        parts.append("<h2>Histograms (tested points)</h2>" + "".join(
            histogram(e, a) for a, e in (("x", sub.dx), ("y", sub.dy), ("z", sub.dz))))
    if r.get("posterior"):
        parts.append("<h2>Posterior density</h2>" + posterior_plot(r["posterior"]))
    parts.append("<h2>Points</h2>" + _points_table(r))
    if r["notes"]:
        parts.append("<h2>Notes</h2><ul>" + "".join(f"<li>{escape(n)}</li>" for n in r["notes"]) + "</ul>")
    shown = {k: v for k, v in r.items() if k not in ("points", "posterior")}
    return _page(parts, shown)


def posterior_page(title: str, sentences: list[str], post: dict[str, Any], unit: str, data: dict[str, Any]) -> str:
    """A report for `qa bayes` from summary statistics: the sentence and the density plot."""
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{escape(title)}</title><style>{_CSS}</style>"
             f"</head><body><h1>{escape(title)}</h1>"]
    parts += [f"<p><b>{escape(s)}</b></p>" for s in sentences]
    parts.append("<h2>Posterior density</h2>" + posterior_plot(post, unit=unit, factor=1.0))
    return _page(parts, data)


def _page(parts: list[str], shown: dict[str, Any]) -> str:
    parts.append("<h2>All figures (JSON)</h2><pre>" + escape(json.dumps(shown, indent=1, default=str)) + "</pre>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
