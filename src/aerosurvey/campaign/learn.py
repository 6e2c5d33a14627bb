"""What a campaign learns (`campaign report`): the accuracy its accepted blocks achieved against their
GSD, control-point density and terrain relief, with the spread, beside the class asked, and the
largest GSD the campaign's own spread says meets it. Pure: the blocks' figures in, the report out
(docs/campaign.md, "What a campaign learns"; the JSON's schema is data/campaign_report.schema.json).

Per axis (x, y: the horizontal class; z: the vertical one):

- the ratio RMSE / GSD over the blocks: median, interquartile range and 95th percentile (numpy's
  linear interpolation between order statistics);
- the least-squares line RMSE = a + b GSD (scipy.stats.linregress) with the standard errors of a
  and b and the 95 % interval of b (Student's t with n - 2 degrees of freedom): b is the RMSE each
  centimetre of GSD adds, the interval holds the true b in 95 % of campaigns whose blocks' RMSEs
  scatter independently and normally about a line (tests/campaign/test_campaign_learn.py checks
  the rate by Monte Carlo);
- Spearman's rank correlation (scipy.stats.spearmanr) of the ratio with the control-point density
  (GCPs per ha) and with the relief (the DEM's range under the block), on the blocks that know them:
  whether denser control or flatter ground went with a better ratio in this campaign.

The suggestion: the largest GSD whose predicted RMSE, the GSD times the axis' 95th-percentile
ratio, meets the class asked on every axis that has one (an RMSE per axis at most the class, as
ASPRS 2014 asks of RMSE_x, RMSE_y and the NVA's RMSE_z); said to lie inside the GSDs flown, or
beyond them (an extrapolation). The control density beside it is the median density of the
blocks learned from: the density the ratio was achieved at, not a minimum the data prove.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from aerosurvey.errors import InputError

SCHEMA = "https://aerosurvey.invalid/schemas/campaign-report-1.json"
VERSION = 1
#: the ratio's percentile the suggestion is made with
SUGGESTION_PERCENTILE = 95.0
AXES = ("x", "y", "z")


@dataclass(frozen=True)
class BlockAccuracy:
    """One accepted block's figures: its GSD (cm), area (ha), control points, the relief under it (m; None
    without a DEM), the RMSE per axis of its accuracy test (cm; z None without heights) and the class asked (cm)."""

    name: str
    gsd_cm: float
    area_ha: float
    control_points: int
    relief_m: float | None
    rmse_cm: tuple[float, float, float | None]
    class_h_cm: float | None
    class_v_cm: float | None
    result: str

    @property
    def gcp_per_ha(self) -> float | None:
        """Control points per hectare; None when the test listed none (its file held check points only)."""
        return self.control_points / self.area_ha if self.control_points > 0 and self.area_ha > 0 else None


def line_fit(gsd_cm: Sequence[float], rmse_cm: Sequence[float], level: float = 0.95) -> dict[str, Any] | None:
    """The least-squares line RMSE = intercept + slope GSD with the standard errors and the `level` interval of
    the slope; None with fewer than 3 blocks or a single GSD."""
    import numpy as np
    from scipy import stats

    x, y = np.asarray(gsd_cm, float), np.asarray(rmse_cm, float)
    if len(x) < 3 or np.ptp(x) == 0:
        return None
    fit = stats.linregress(x, y)
    half = float(stats.t.ppf(0.5 + level / 2, len(x) - 2)) * float(fit.stderr)
    return {"slope": float(fit.slope), "slope_se": float(fit.stderr), "intercept_cm": float(fit.intercept),
            "intercept_se_cm": float(fit.intercept_stderr), "slope_interval": [float(fit.slope) - half, float(fit.slope) + half],
            "level": level, "r2": float(fit.rvalue) ** 2, "n": len(x)}


def _spearman(values: Sequence[float | None], ratios: Sequence[float]) -> dict[str, Any] | None:
    import numpy as np
    from scipy import stats

    pairs = [(v, r) for v, r in zip(values, ratios) if v is not None]
    if len(pairs) < 3 or len({v for v, _ in pairs}) < 2 or len({r for _, r in pairs}) < 2:
        return None
    a = np.array(pairs, float)
    res = stats.spearmanr(a[:, 0], a[:, 1])
    return {"rho": float(res.statistic), "p_value": float(res.pvalue), "n": len(pairs)}


def _axis(blocks: Sequence[BlockAccuracy], k: int) -> dict[str, Any] | None:
    import numpy as np

    have = [b for b in blocks if b.rmse_cm[k] is not None]
    if not have:
        return None
    gsd = [b.gsd_cm for b in have]
    rmse = [float(b.rmse_cm[k]) for b in have]  # type: ignore[arg-type]  # None filtered above
    ratio = np.asarray(rmse) / np.asarray(gsd)
    q25, q50, q75, q_s = np.percentile(ratio, [25.0, 50.0, 75.0, SUGGESTION_PERCENTILE]).tolist()
    return {"n": len(have), "ratio": {"median": q50, "q25": q25, "q75": q75, "iqr": q75 - q25, f"p{SUGGESTION_PERCENTILE:g}": q_s},
            "line": line_fit(gsd, rmse),
            "ratio_against_gcp_per_ha": _spearman([b.gcp_per_ha for b in have], ratio.tolist()),
            "ratio_against_relief": _spearman([b.relief_m for b in have], ratio.tolist())}


def asked_classes(blocks: Sequence[BlockAccuracy], class_h_cm: float | None,
                  class_v_cm: float | None) -> tuple[float | None, float | None]:
    """The class the report compares with: the one given, else the one every block's test asked (an
    InputError when they asked different ones)."""
    out: list[float | None] = []
    for given, name, option in ((class_h_cm, "class_h_cm", "--class-h"), (class_v_cm, "class_v_cm", "--class-v")):
        if given is not None:
            out.append(given)
            continue
        asked = {getattr(b, name) for b in blocks} - {None}
        if len(asked) > 1:
            raise InputError(f"the blocks' accuracy tests asked different classes ({name} = "
                             f"{', '.join(f'{v:g}' for v in sorted(asked))} cm): give the class to compare with as {option}",
                             key=option)
        out.append(asked.pop() if asked else None)
    return out[0], out[1]


def learn(blocks: Sequence[BlockAccuracy], class_h_cm: float | None, class_v_cm: float | None) -> dict[str, Any]:
    """The report's body (see the module's doc): the blocks, the figures per axis, the classes and the suggestion."""
    import numpy as np

    axes = {a: _axis(blocks, k) for k, a in enumerate(AXES)}
    classes = {"x": class_h_cm, "y": class_h_cm, "z": class_v_cm}
    gsd = [b.gsd_cm for b in blocks]
    largest: list[tuple[float, str]] = []
    for a, fig in axes.items():
        cls = classes[a]
        if fig is not None and cls is not None:
            ratio = fig["ratio"][f"p{SUGGESTION_PERCENTILE:g}"]
            largest.append((cls / ratio if ratio > 0 else math.inf, a))
    suggestion = None
    if largest:
        g, axis = min(largest)
        densities = [d for d in (b.gcp_per_ha for b in blocks) if d is not None]
        suggestion = {"gsd_cm": g if math.isfinite(g) else None, "limited_by": axis,
                      "within_flown": bool(blocks) and min(gsd) <= g <= max(gsd),
                      "gcp_per_ha": float(np.median(densities)) if densities else None}
    return {"blocks": [{"name": b.name, "gsd_cm": b.gsd_cm, "area_ha": b.area_ha, "control_points": b.control_points,
                        "gcp_per_ha": b.gcp_per_ha, "relief_m": b.relief_m, "rmse_x_cm": b.rmse_cm[0], "rmse_y_cm": b.rmse_cm[1],
                        "rmse_z_cm": b.rmse_cm[2], "result": b.result} for b in blocks],
            "class_h_cm": class_h_cm, "class_v_cm": class_v_cm,
            "gsd_flown_cm": [min(gsd), max(gsd)] if gsd else None,
            "axes": axes, "percentile": SUGGESTION_PERCENTILE, "suggestion": suggestion}


def report_text(body: dict[str, Any], accepted: int, learned: int) -> str:
    """The report as text (what `campaign report` prints)."""

    def num(v: float | None, fmt: str = ".2f") -> str:
        return "-" if v is None else format(v, fmt)

    lines = [f"{learned} of {accepted} accepted block(s) have a QA verdict with an RMSE per axis to learn from"]
    if not body["blocks"]:
        return "\n".join(lines) + "\n"
    lines.append(f"{'block':<16} {'GSD cm':>7} {'GCP/ha':>7} {'relief m':>8} {'RMSE x':>7} {'RMSE y':>7} {'RMSE z':>7}  verdict")
    for b in body["blocks"]:
        relief = "none" if b["relief_m"] is None else f"{b['relief_m']:.1f}"
        lines.append(f"{b['name']:<16} {b['gsd_cm']:>7.2f} {num(b['gcp_per_ha']):>7} {relief:>8} {num(b['rmse_x_cm']):>7} "
                     f"{num(b['rmse_y_cm']):>7} {num(b['rmse_z_cm']):>7}  {b['result']}")
    p = f"p{body['percentile']:g}"
    for a in AXES:
        fig = body["axes"][a]
        if fig is None:
            lines.append(f"{a}: no block tested it")
            continue
        r = fig["ratio"]
        cls = body["class_h_cm"] if a != "z" else body["class_v_cm"]
        text = (f"{a}: RMSE/GSD median {r['median']:.2f} (IQR {r['q25']:.2f}-{r['q75']:.2f}, {p} {r[p]:.2f}) over {fig['n']} "
                f"block(s); class asked {num(cls, 'g')} cm")
        line = fig["line"]
        if line is not None:
            lo, hi = line["slope_interval"]
            text += (f"; line RMSE = {line['intercept_cm']:.2f} (se {line['intercept_se_cm']:.2f}) cm + {line['slope']:.3f} "
                     f"(se {line['slope_se']:.3f}, {line['level']:.0%} {lo:.3f} to {hi:.3f}) x GSD, r2 {line['r2']:.2f}")
        for key, what in (("ratio_against_gcp_per_ha", "GCP density"), ("ratio_against_relief", "relief")):
            c = fig[key]
            if c is not None:
                text += f"; ratio against {what}: Spearman rho {c['rho']:.2f} (p {c['p_value']:.2g}, {c['n']} blocks)"
        lines.append(text)
    s = body["suggestion"]
    if s is None:
        lines.append("no class asked (the blocks' tests asked none; give --class-h or --class-v): no suggestion")
    elif s["gsd_cm"] is None:
        lines.append("suggestion: any GSD (the ratios are 0)")
    else:
        where = "within the GSDs flown" if s["within_flown"] else "outside the GSDs flown: an extrapolation"
        control = f", with about {s['gcp_per_ha']:.2f} GCPs/ha (the blocks' median)" if s["gcp_per_ha"] is not None else ""
        lines.append(f"suggestion: GSD up to {s['gsd_cm']:.2f} cm{control}: the {p} RMSE/GSD ratio of {s['limited_by']} "
                     f"meets the class there ({where})")
    return "\n".join(lines) + "\n"
