"""Accuracy reports by standard: ASPRS 2014 (Edition 1), ASPRS 2023 (Edition 2), NSSDA.

Sources (docs/qa-accuracy.md): ASPRS 2014 classes and check point table (shared/papers/000,
Tables 5 and 7; shared/reference/asprs2014_checkpoint_counts.csv); NSSDA (FGDC-STD-007.3-
1998) factors 1.7308 and 1.9600 and the 0.6 < ratio < 1 approximation; ASPRS 2023 changes
as summarised by GPS World (6 Dec 2023) and PE&RS 89(10): no 95 % measure, check point
survey error added to the product accuracy, no VVA pass/fail, at least 30 check points,
RMSE_3D. The exact symbols of the 2023 combination formula could not be read from the
standard's own text here; aerosurvey uses RMSE = sqrt(RMSE_fit² + RMSE_survey²) per
standards.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from aerosurvey.qa import statistics as st
from aerosurvey.qa.points import CheckPoints
from aerosurvey.rules.checks import asprs_required


def _cm(v: float) -> float:
    return round(v * 100, 3)


def _class_up(x_m: float) -> float:
    """A class value in cm: the measure rounded up to 0.1 cm."""
    return math.ceil(x_m * 1000 - 1e-9) / 10


def reviewer_warnings(pts: CheckPoints, standard_min: int, required: int | None) -> list[str]:
    w = []
    control = [i for i, r in zip(pts.ids, pts.role) if r == "control"]
    if control:
        w.append(f"{len(control)} of {pts.n} points are ground control used in the adjustment ({', '.join(control[:8])}"
                 f"{' ...' if len(control) > 8 else ''}): their residuals show the fit, not the accuracy; "
                 "an accuracy test needs independent check points")
    n_check = pts.n - len(control)
    need = max(standard_min, required or 0)
    if n_check < need:
        w.append(f"{pts.n} points, of which {n_check} independent check points: fewer than {need}, the minimum for "
                 "this standard and project area")
    for axis, e in (("x", pts.dx), ("y", pts.dy), ("z", pts.dz)):
        s = st.axis_stats(e)
        if s.get("bias_significant"):
            w.append(f"significant bias in {axis}: mean {_cm(s['mean'])} cm (t-test p = {s['bias_p_value']:.3f}); "
                     "a datum or transformation error is likely")
    flagged = [pid for pid, f in zip(pts.ids, st.outliers(np.hypot(pts.dx, pts.dy))) if f]
    if flagged:
        w.append(f"outliers flagged (kept): {', '.join(flagged)}")
    if np.all(np.isfinite(pts.x)) and pts.n >= 4:
        cx, cy = np.median(pts.x), np.median(pts.y)
        quads = [np.mean((pts.x >= cx) & (pts.y >= cy)), np.mean((pts.x < cx) & (pts.y >= cy)),
                 np.mean((pts.x < cx) & (pts.y < cy)), np.mean((pts.x >= cx) & (pts.y < cy))]
        if min(quads) < 0.2:
            w.append("check points are clustered: a quadrant of the area holds fewer than 20 % of them (ASPRS distribution guidance)")
    if pts.n >= 5:
        full = st.rmse(np.hypot(pts.dx, pts.dy))
        loo = [st.rmse(np.hypot(np.delete(pts.dx, i), np.delete(pts.dy, i))) for i in range(pts.n)]
        i = int(np.argmax(np.abs(np.asarray(loo) - full)))
        if full > 0 and abs(loo[i] - full) / full > 0.2:
            w.append(f"the result depends on one point: without {pts.ids[i]} the horizontal RMSE changes by "
                     f"{100 * (loo[i] - full) / full:+.0f} %")
    return w


def _stats_cm(pts: CheckPoints) -> dict[str, Any]:
    out = {}
    for axis, e in (("x", pts.dx), ("y", pts.dy), ("z", pts.dz)):
        s = st.axis_stats(e)
        out[axis] = {k: (_cm(v) if k in ("mean", "std", "rmse", "min", "max", "abs_p50", "abs_p90", "abs_p95")
                         and isinstance(v, float) and math.isfinite(v) else v) for k, v in s.items()}
    return out


def asprs2014(pts: CheckPoints, area_km2: float | None, class_h_cm: float | None, class_v_cm: float | None) -> dict[str, Any]:
    h = st.horizontal_summary(pts.dx, pts.dy)
    rx, ry, rr = h["rmse_x"], h["rmse_y"], h["rmse_r"]
    h95 = 1.7308 * rr
    nonveg = pts.dz[np.isfinite(pts.dz) & ~pts.vegetated]
    veg = pts.dz[np.isfinite(pts.dz) & pts.vegetated]
    rz = st.rmse(nonveg) if len(nonveg) else math.nan
    nva = 1.96 * rz if len(nonveg) else math.nan
    vva = float(np.percentile(np.abs(veg), 95)) if len(veg) else math.nan
    x_h = max(rx, ry, rr / 1.414, h95 / 2.448)
    x_v = max(v for v in (rz, nva / 1.96, vva / 3.0) if math.isfinite(v)) if len(nonveg) or len(veg) else math.nan
    req = asprs_required("2014", area_km2) if area_km2 is not None else None
    met = []
    if class_h_cm is not None:
        met.append(x_h * 100 <= class_h_cm + 1e-9)
    if class_v_cm is not None and math.isfinite(x_v):
        met.append(x_v * 100 <= class_v_cm + 1e-9)
    ratio_note = ("RMSE_x and RMSE_y differ (ratio %.2f): NSSDA's approximation 2.4477 x 0.5 x (RMSE_x + RMSE_y) = %.2f cm, "
                  "the exact circular error at 95 %% from the bivariate normal = %.2f cm" %
                  (h["ratio"], 2.4477 * 0.5 * (rx + ry) * 100, h["ce95"] * 100))
    sentences = [
        f"This data set was tested to meet ASPRS Positional Accuracy Standards for Digital Geospatial Data (2014) for a "
        f"{class_h_cm if class_h_cm is not None else _class_up(x_h):g} (cm) RMSE_x / RMSE_y horizontal accuracy class. "
        f"Actual positional accuracy was found to be RMSE_x = {rx * 100:.2f} cm and RMSE_y = {ry * 100:.2f} cm which "
        f"equates to Positional Horizontal Accuracy = +/- {h95 * 100:.2f} cm at 95 % confidence level.",
    ]
    if math.isfinite(nva):
        sentences.append(
            f"This data set was tested to meet ASPRS Positional Accuracy Standards for Digital Geospatial Data (2014) for a "
            f"{class_v_cm if class_v_cm is not None else _class_up(x_v):g} (cm) RMSE_z vertical accuracy class. Actual NVA "
            f"accuracy was found to be RMSE_z = {rz * 100:.2f} cm, equating to +/- {nva * 100:.2f} cm at 95 % confidence level."
            + (f" Actual VVA accuracy was found to be +/- {vva * 100:.2f} cm at the 95th percentile." if math.isfinite(vva) else ""))
    return {
        "standard": "ASPRS 2014 (Edition 1)", "n": pts.n, "statistics_cm": _stats_cm(pts),
        "rmse_x_cm": _cm(rx), "rmse_y_cm": _cm(ry), "rmse_r_cm": _cm(rr), "horizontal_95_cm": _cm(h95),
        "nssda_unequal_95_cm": _cm(2.4477 * 0.5 * (rx + ry)), "ce95_exact_cm": _cm(h["ce95"]), "ce90_cm": _cm(h["ce90"]),
        "rmse_z_nva_cm": _cm(rz) if math.isfinite(rz) else None, "nva_95_cm": _cm(nva) if math.isfinite(nva) else None,
        "vva_95_cm": _cm(vva) if math.isfinite(vva) else None,
        "le90_cm": _cm(st.LE90 * rz) if math.isfinite(rz) else None,
        "horizontal_class_met_cm": _class_up(x_h), "vertical_class_met_cm": _class_up(x_v) if math.isfinite(x_v) else None,
        "class_tested": {"horizontal_cm": class_h_cm, "vertical_cm": class_v_cm},
        "passed": all(met) if met else None,
        "required_check_points": {"horizontal": req[0], "vertical": req[1]} if req else None,
        "notes": [ratio_note], "sentences": sentences,
        "warnings": reviewer_warnings(pts, 20, max(req) if req else None),
    }


def asprs2023(pts: CheckPoints, area_km2: float | None, class_h_cm: float | None, class_v_cm: float | None,
              survey_rmse_h: float | None, survey_rmse_v: float | None) -> dict[str, Any]:
    rx, ry = st.rmse(pts.dx), st.rmse(pts.dy)
    fit_h = math.hypot(rx, ry)
    sh = survey_rmse_h if survey_rmse_h is not None else (
        float(np.sqrt(np.mean(pts.sigma_h**2))) if np.all(np.isfinite(pts.sigma_h)) else 0.0)
    sv = survey_rmse_v if survey_rmse_v is not None else (
        float(np.sqrt(np.mean(pts.sigma_v**2))) if np.all(np.isfinite(pts.sigma_v)) else 0.0)
    rmse_h = math.hypot(fit_h, sh)
    nonveg = pts.dz[np.isfinite(pts.dz) & ~pts.vegetated]
    veg = pts.dz[np.isfinite(pts.dz) & pts.vegetated]
    fit_v = st.rmse(nonveg) if len(nonveg) else math.nan
    rmse_v = math.hypot(fit_v, sv) if math.isfinite(fit_v) else math.nan
    vva = float(np.percentile(np.abs(veg), 95)) if len(veg) else math.nan
    met = []
    if class_h_cm is not None:
        met.append(rmse_h * 100 <= class_h_cm + 1e-9)
    if class_v_cm is not None and math.isfinite(rmse_v):
        met.append(rmse_v * 100 <= class_v_cm + 1e-9)
    req = (max(30, asprs_required("2014", area_km2)[0]) if area_km2 is not None else 30)
    req = min(req, 120)
    sentences = [f"This data set was tested to meet ASPRS Positional Accuracy Standards for Digital Geospatial Data, "
                 f"Edition 2 (2023) for a {class_h_cm if class_h_cm is not None else _class_up(rmse_h):g} (cm) RMSE_H "
                 f"horizontal positional accuracy class. The tested horizontal positional accuracy was found to be "
                 f"RMSE_H = {rmse_h * 100:.2f} cm."]
    if math.isfinite(rmse_v):
        sentences.append(f"This data set was tested to meet ASPRS Positional Accuracy Standards for Digital Geospatial "
                         f"Data, Edition 2 (2023) for a {class_v_cm if class_v_cm is not None else _class_up(rmse_v):g} (cm) "
                         f"RMSE_V vertical positional accuracy class. The tested vertical positional accuracy was found "
                         f"to be RMSE_V = {rmse_v * 100:.2f} cm.")
    notes = []
    if sh == 0 and sv == 0:
        notes.append("no check point survey accuracy given (--survey-rmse-h/-v or sigma_h/sigma_v columns): the survey term is 0")
    return {
        "standard": "ASPRS 2023 (Edition 2)", "n": pts.n, "statistics_cm": _stats_cm(pts),
        "rmse_x_cm": _cm(rx), "rmse_y_cm": _cm(ry), "rmse_h_fit_cm": _cm(fit_h), "rmse_h_survey_cm": _cm(sh),
        "rmse_h_cm": _cm(rmse_h), "rmse_v_fit_cm": _cm(fit_v) if math.isfinite(fit_v) else None,
        "rmse_v_survey_cm": _cm(sv), "rmse_v_cm": _cm(rmse_v) if math.isfinite(rmse_v) else None,
        "rmse_3d_cm": _cm(math.hypot(rmse_h, rmse_v)) if math.isfinite(rmse_v) else None,
        "vva_95_cm_reported": _cm(vva) if math.isfinite(vva) else None,
        "class_tested": {"horizontal_cm": class_h_cm, "vertical_cm": class_v_cm},
        "passed": all(met) if met else None, "required_check_points": req,
        "notes": notes + ["VVA is reported without a pass/fail requirement in Edition 2"],
        "sentences": sentences, "warnings": reviewer_warnings(pts, 30, req),
    }


def nssda(pts: CheckPoints) -> dict[str, Any]:
    h = st.horizontal_summary(pts.dx, pts.dy)
    rx, ry, rr = h["rmse_x"], h["rmse_y"], h["rmse_r"]
    ratio = h["ratio"]
    if ratio >= 0.999:
        acc_h, how = 1.7308 * rr, "1.7308 x RMSE_r (RMSE_x = RMSE_y)"
    elif ratio > 0.6:
        acc_h, how = 2.4477 * 0.5 * (rx + ry), "2.4477 x 0.5 x (RMSE_x + RMSE_y) (0.6 < RMSE_min/RMSE_max < 1)"
    else:
        acc_h, how = h["ce95"], "exact circular error at 95 % of the bivariate normal (RMSE_min/RMSE_max <= 0.6)"
    v = st.vertical_summary(pts.dz)
    sentences = [f"Tested {acc_h:.3f} (m) horizontal accuracy at 95 % confidence level"]
    if v:
        sentences.append(f"Tested {v['le95']:.3f} (m) vertical accuracy at 95 % confidence level")
    return {"standard": "NSSDA (FGDC-STD-007.3-1998)", "n": pts.n, "statistics_cm": _stats_cm(pts),
            "horizontal_95_m": acc_h, "horizontal_method": how, "vertical_95_m": v.get("le95"),
            "passed": None, "sentences": sentences, "warnings": reviewer_warnings(pts, 20, None)}
