"""ASPRS Positional Accuracy Standards for Digital Geospatial Data: Edition 1 (2014) and
Edition 2 (2023) tests of check point residuals (pure; metres in, lengths out as `_m`).

Where the numbers come from:

- Edition 1 (2014): the class rules (RMSE_x, RMSE_y ≤ X; RMSE_r ≤ 1.414 X; 95 % ≤
  2.4477 X; NVA RMSE_z ≤ X, NVA 95 % = 1.96 RMSE_z ≤ 1.96 X; VVA 95th percentile ≤ 3.00 X),
  the common classes and the check point table are read from Korumaz and Yıldız, Heritage 4 (2021) (its
  Tables 5, 6, 7, 9 and 10, which reproduce the standard) and
  tests/data/reference/asprs2014_checkpoint_counts.csv; the 3× check point accuracy rule
  from secondary sources and the standard's text quoted on a public page
  ("at least three times more accurate than the required accuracy").
- Edition 2 (2023): the list of changes (RMSE only, no 95 % figures; check point survey
  accuracy in the product accuracy; no VVA pass/fail (for lidar); minimum 30 check
  points; at most 120; RMSE_3D) is confirmed by GPS World, 6 Dec 2023. The standard's
  own text could not be read through the search tool; the following are from a
  secondary source only (a public implementation that cites the standard's sections
  7.11–7.13, Table 7.4 and Table C.1) and are NOT confirmed against the standard:
  the combination RMSE_H = √(RMSE_H1² + RMSE_H2²), RMSE_V = √(RMSE_V1² + RMSE_V2²)
  with RMSE_H2 = √2 × the per-axis survey RMSE; horizontal classes stated on RMSE_H;
  check points about 2× more accurate than the product; the check point counts by area
  (30 up to 500 km², +5 per 250 km², 70 at 2,500 km²). Table 7.4's rows (e.g. 1.00 cm fit
  with a 2.0 cm survey → 2.24 cm) agree with the combination formula. Beyond 2,500 km² we
  carry the table's slope on (+5 per 250 km²) up to the cap of 120 (GPS World: "limiting
  the maximum number of checkpoints for large projects to 120"); that continuation is ours.
  A search of the public documentation (November 2026) found copies of Edition 2 (a
  scribd mirror of the 97-page PDF) but not the text of its count table: every count
  above 30 is reported as NOT confirmed.
- Mean error: Edition 1 (section 7.5) assumes the mean error "removed or small".
  The 25 % limit of secondary sources could not be quoted from either edition, so it flags
  the mean error (review.mean_error_findings) and decides nothing.
- Reporting statements: Edition 1's wording as Korumaz and Yıldız, Heritage 4 (2021), section
  4, reproduces it ("This data set was tested to meet …"); Edition 2's modelled on it with
  RMSE_H / RMSE_V / RMSE_3D (not confirmed against the standard's text). Issued only for a
  valid test with every input named (qa/identity.py); otherwise the figures are given in our
  own words.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aerosurvey.qa import statistics as st

# --- Edition 1 (2014) ------------------------------------------------------------------

#: Common horizontal classes, RMSE_x = RMSE_y (cm): Korumaz and Yıldız, Heritage 4 (2021), Table 7.
HORIZONTAL_CLASSES_2014_CM = (0.63, 1.25, 2.5, 5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0, 22.5, 25.0, 27.5, 30.0, 45.0,
                              60.0, 75.0, 100.0, 150.0, 200.0, 250.0, 300.0, 500.0, 1000.0)
#: Common vertical classes, RMSE_z (cm): Korumaz and Yıldız, Heritage 4 (2021), Table 10.
VERTICAL_CLASSES_2014_CM = (1.0, 2.5, 5.0, 10.0, 15.0, 20.0, 33.3, 66.7, 100.0)
#: Class limits as multiples of X (Korumaz and Yıldız, Heritage 4 (2021), Tables 6 and 9).
RMSE_R_FACTOR, H95_FACTOR, NVA95_FACTOR, VVA_FACTOR = 1.414, 2.4477, 1.96, 3.00
#: Check points per project area, Edition 1: (largest km², horizontal, NVA, VVA) from
#: tests/data/reference/asprs2014_checkpoint_counts.csv (Korumaz and Yıldız, Heritage 4 (2021), Table 5).
COUNTS_2014 = ((500, 20, 20, 5), (750, 25, 20, 10), (1000, 30, 25, 15), (1250, 35, 30, 20), (1500, 40, 35, 25),
               (1750, 45, 40, 30), (2000, 50, 45, 35), (2250, 55, 50, 40), (2500, 60, 55, 45))
MIN_CHECK_POINTS_2014 = 20
SURVEY_RATIO_2014 = 3.0  # check points at least 3× more accurate than the product

# --- Edition 2 (2023) ------------------------------------------------------------------

MIN_CHECK_POINTS_2023 = 30  # GPS World, 6 Dec 2023: "from 20 to 30"
MAX_CHECK_POINTS_2023 = 120  # GPS World, 6 Dec 2023: "maximum number of checkpoints ... to 120"
#: (largest km², total check points): secondary source for Table C.1, NOT confirmed.
COUNTS_2023 = ((500, 30), (750, 35), (1000, 40), (1250, 45), (1500, 50), (1750, 55), (2000, 60), (2250, 65),
               (2500, 70))
SURVEY_RATIO_2023 = 2.0  # secondary source ("7.12"), NOT confirmed; a secondary source says "about 2×"


@dataclass(frozen=True)
class Required:
    horizontal: int
    nva: int
    vva: int
    note: str

    @property
    def total(self) -> int:
        return max(self.horizontal, self.nva + self.vva)


def required_2014(area_km2: float | None) -> Required:
    """Recommended static check points (Edition 1, Table C.1 as in paper 000 Table 5)."""
    if area_km2 is None:
        return Required(MIN_CHECK_POINTS_2014, MIN_CHECK_POINTS_2014, 0, "no project area given: the minimum of 20")
    for limit, h, nva, vva in COUNTS_2014:
        if area_km2 <= limit:
            return Required(h, nva, vva, f"{area_km2:.3g} km2 <= {limit} km2 (Table C.1)")
    extra = math.ceil((area_km2 - 2500) / 500 - 1e-9)
    return Required(60, 55 + 3 * extra, 45 + 2 * extra,
                    f"{area_km2:.4g} km2 > 2,500 km2: +3 NVA and +2 VVA per 500 km2; horizontal by agreement (60 kept)")


def required_2023(area_km2: float | None) -> Required:
    """Minimum check points, Edition 2 (total; the NVA/VVA split is not modelled)."""
    if area_km2 is None:
        n = MIN_CHECK_POINTS_2023
        return Required(n, n, 0, "no project area given: the minimum of 30")
    for limit, n in COUNTS_2023:
        if area_km2 <= limit:
            return Required(n, n, 0, f"{area_km2:.3g} km2 <= {limit} km2 (Table C.1 as transcribed by a secondary "
                                     "source, not confirmed)")
    n = min(70 + 5 * math.ceil((area_km2 - 2500) / 250 - 1e-9), MAX_CHECK_POINTS_2023)
    return Required(n, n, 0, f"{area_km2:.4g} km2 > 2,500 km2: the table's +5 per 250 km2 carried on, capped at "
                             f"{MAX_CHECK_POINTS_2023} (the cap is confirmed by GPS World; the continuation is ours, "
                             "not the standard's text)")


def _smallest_class(x_cm: float, classes: tuple[float, ...]) -> float | None:
    return next((c for c in classes if x_cm <= c + 1e-9), None)


def _round_up_cm(x_m: float) -> float:
    return math.ceil(x_m * 1000 - 1e-9) / 10


def _cm(v: float) -> str:
    return f"{v * 100:.2f}"


def record_verdicts(out: dict[str, Any], horizontal: bool | None, vertical: bool | None) -> None:
    """Store the horizontal and vertical verdicts (None: not tested) and the overall one."""
    if horizontal is not None:
        out["horizontal_met"] = horizontal
    if vertical is not None:
        out["vertical_met"] = vertical
    tested = [v for v in (horizontal, vertical) if v is not None]
    out["passed"] = all(tested) if tested else None


def within(value: float, limit: float) -> bool:
    """value ≤ limit, with a few ulps of room: a figure computed exactly at a class limit (3 cm
    from residuals of 3 cm) meets it whatever the last bit of its floating-point sum."""
    return value <= limit or math.isclose(value, limit, rel_tol=ULPS, abs_tol=0.0)


#: Relative room of a boundary comparison: 8 units in the last place of a double.
ULPS = 8 * 2.0**-52


STD_2014 = "ASPRS Positional Accuracy Standards for Digital Geospatial Data (2014)"
STD_2023 = "ASPRS Positional Accuracy Standards for Digital Geospatial Data, Edition 2 (2023)"


def _lead(std: str, cls: float, what: str, met: bool) -> str:
    if met:
        return f"This data set was tested to meet {std} for a {cls:g} (cm) {what} class."
    return f"This data set was tested against {std} for a {cls:g} (cm) {what} class and does not meet it."


def _split(dz: np.ndarray, vegetated: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ok = np.isfinite(dz)
    return dz[ok & ~vegetated], dz[ok & vegetated]


def evaluate_2014(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, vegetated: np.ndarray,
                  class_h_cm: float | None = None, class_v_cm: float | None = None,
                  exact: bool = True) -> dict[str, Any]:
    """Edition 1 figures, the class met or tested, and the standard's report sentences.

    `exact=False` skips the exact circular errors (informative only, not part of the test)."""
    h = st.horizontal_summary(dx, dy, exact)
    rx, ry, rr = h["rmse_x_m"], h["rmse_y_m"], h["rmse_r_m"]
    # Edition 1 takes the 95 % figure from NSSDA: 1.7308 RMSE_r only for equal axes, the
    # NSSDA rule for unequal ones (see nssda_horizontal_95)
    h95, h95_method = nssda_horizontal_95(rx, ry)
    nonveg, veg = _split(dz, vegetated)
    rz = st.rmse(nonveg) if len(nonveg) else None
    nva = NVA95_FACTOR * rz if rz is not None else None
    vva = float(np.percentile(np.abs(veg), 95)) if len(veg) else None
    # the smallest X each rule allows, then the tightest of them
    x_h = max(rx, ry, rr / RMSE_R_FACTOR, h95 / H95_FACTOR)
    x_v_parts = [v for v in (rz, vva / VVA_FACTOR if vva is not None else None) if v is not None]
    x_v = max(x_v_parts) if x_v_parts else None
    out: dict[str, Any] = {
        "rmse_x_m": rx, "rmse_y_m": ry, "rmse_r_m": rr, "horizontal_95_m": h95, "horizontal_95_method": h95_method,
        "horizontal_95_equal_axes_m": st.CE95_PER_RADIAL * rr, "ce95_exact_m": h["ce95_m"],
        "rmse_z_nva_m": rz, "nva_95_m": nva, "vva_95_m": vva,
        "n_horizontal": int(len(dx)), "n_nva": int(len(nonveg)), "n_vva": int(len(veg)),
        "smallest_x_horizontal_m": x_h, "smallest_x_vertical_m": x_v,
        "horizontal_class_cm": _smallest_class(x_h * 100, HORIZONTAL_CLASSES_2014_CM),
        "vertical_class_cm": _smallest_class(x_v * 100, VERTICAL_CLASSES_2014_CM) if x_v is not None else None,
        "class_h_tested_cm": class_h_cm, "class_v_tested_cm": class_v_cm,
    }
    h_met = v_met = None
    if class_h_cm is not None:
        x = class_h_cm / 100
        out["horizontal_checks"] = {"RMSE_x": within(rx, x), "RMSE_y": within(ry, x),
                                    "RMSE_r": within(rr, RMSE_R_FACTOR * x), "95 %": within(h95, H95_FACTOR * x)}
        h_met = all(out["horizontal_checks"].values())
    if class_v_cm is not None and (rz is not None or vva is not None):
        x = class_v_cm / 100
        checks = {}
        if rz is not None and nva is not None:
            checks["NVA RMSE_z"] = within(rz, x)
            checks["NVA 95 %"] = within(nva, NVA95_FACTOR * x)
        if vva is not None:
            checks["VVA 95th percentile"] = within(vva, VVA_FACTOR * x)
        out["vertical_checks"] = checks
        v_met = all(checks.values())
    record_verdicts(out, h_met, v_met)
    out["sentences"] = sentences_2014(out)
    return out


def sentences_2014(r: dict[str, Any]) -> list[str]:
    """Edition 1's reporting statements, worded as Korumaz and Yıldız, Heritage 4 (2021) (section 4) reproduces them;
    for a valid test only (the verdict's conditions and qa/identity.py)."""
    out = []
    cls = r["class_h_tested_cm"] if r["class_h_tested_cm"] is not None else r["horizontal_class_cm"]
    if cls is not None:
        lead = _lead(STD_2014, cls, "RMSE_x/RMSE_y horizontal accuracy", r.get("horizontal_met", True))
        out.append(f"{lead} Actual positional accuracy was found to be RMSE_x = {_cm(r['rmse_x_m'])} cm and "
                   f"RMSE_y = {_cm(r['rmse_y_m'])} cm which equates to +/- {_cm(r['horizontal_95_m'])} cm at a 95% "
                   "confidence level.")
    vcls = r["class_v_tested_cm"] if r["class_v_tested_cm"] is not None else r["vertical_class_cm"]
    if vcls is not None and (r["rmse_z_nva_m"] is not None or r["vva_95_m"] is not None):
        parts = [_lead(STD_2014, vcls, "RMSE_z vertical accuracy", r.get("vertical_met", True))]
        parts += _vertical_2014(r)
        out.append(" ".join(parts))
    return out


def _vertical_2014(r: dict[str, Any]) -> list[str]:
    parts = []
    if r["rmse_z_nva_m"] is not None:
        parts.append(f"Actual NVA accuracy was found to be RMSE_z = {_cm(r['rmse_z_nva_m'])} cm, equating to "
                     f"+/- {_cm(r['nva_95_m'])} cm at a 95% confidence level.")
    if r["vva_95_m"] is not None:
        parts.append(f"Actual VVA accuracy was found to be +/- {_cm(r['vva_95_m'])} cm at the 95th percentile.")
    return parts


def figures_2014(r: dict[str, Any]) -> list[str]:
    """The figures in our own words, for a set that does not make a valid test (no statement)."""
    out = [f"Figures only, no {STD_2014} statement (see the result's reasons): RMSE_x = {_cm(r['rmse_x_m'])} cm, "
           f"RMSE_y = {_cm(r['rmse_y_m'])} cm, horizontal accuracy at 95 % +/- {_cm(r['horizontal_95_m'])} cm "
           f"({r['horizontal_95_method']})."]
    if r["rmse_z_nva_m"] is not None:
        out.append(f"NVA: RMSE_z = {_cm(r['rmse_z_nva_m'])} cm, +/- {_cm(r['nva_95_m'])} cm at 95 %."
                   + (f" VVA: +/- {_cm(r['vva_95_m'])} cm at the 95th percentile." if r["vva_95_m"] is not None
                      else ""))
    return out


#: NSSDA's range for the approximation, RMSE_min / RMSE_max "between 0.6 and 1.0"; both ends
#: are taken as inside (the wording gives no strict inequality), compared without division and
#: with a few ulps of room (`within`), so that RMSEs of 3 and 5 cm, whose quotient computes as
#: 0.5999999999999999, are at 0.6.
NSSDA_RATIO_MIN = 0.6


def nssda_horizontal_95(rx: float, ry: float) -> tuple[float, str]:
    """Horizontal accuracy at 95 % by the NSSDA (FGDC-STD-007.3-1998, Appendix 3-A) rule.

    What the rule says, as we implement it (the standard's own text was found in public
    copies — studylib.net/doc/18297622, pdfslide.us — but the search tool returned only its
    front matter, so the wording below is ours, not a quotation):
    - RMSE_x = RMSE_y: Accuracy_r = 1.7308 RMSE_r (= 2.4477 RMSE_x);
    - RMSE_min / RMSE_max between 0.6 and 1.0: Accuracy_r ≈ 2.4477 × 0.5 × (RMSE_x + RMSE_y)
      (this equals the first case when the axes are equal, so one formula serves both);
    - outside that range the approximation does not hold: the exact circular error at 95 %
      of the bivariate normal is used.
    At exactly 0.6 the approximation applies ("between 0.6 and 1.0", read inclusively; the
    comparison is 0.6 RMSE_max ≤ RMSE_min within a few ulps, so that the rounding of the RMSEs'
    sums cannot move a ratio of 0.6 out); the step to the exact value just below 0.6 (about
    6 %) is the standard's, and the report gives the exact CE95 beside the figure whatever
    the ratio.
    """
    hi, lo = max(rx, ry), min(rx, ry)
    ratio = lo / hi if hi > 0 else 1.0
    if math.isclose(lo, hi, rel_tol=ULPS, abs_tol=0.0):
        return st.CE95_PER_RADIAL * math.hypot(rx, ry), "1.7308 x RMSE_r (RMSE_x = RMSE_y)"
    if within(NSSDA_RATIO_MIN * hi, lo):
        return (st.CE95_EQUAL * 0.5 * (rx + ry),
                f"2.4477 x 0.5 x (RMSE_x + RMSE_y), the NSSDA approximation for RMSE_min/RMSE_max = {ratio:.3f} "
                "(between 0.6 and 1.0)")
    return (st.circular_error(rx, ry, 0.95),
            f"the exact circular error at 95 % of the bivariate normal (RMSE_min/RMSE_max = {ratio:.3f} < 0.6, "
            "outside the NSSDA approximation's range)")


def survey_rmse(sigma_per_point: np.ndarray, sigma_set: float | None) -> float | None:
    """One RMSE for the reference survey: the set value, else the RMS of the per-point σ."""
    if sigma_set is not None:
        return float(sigma_set)
    s = np.asarray(sigma_per_point, float)
    if len(s) and np.all(np.isfinite(s)):
        return float(np.sqrt(np.mean(s**2)))
    return None


def evaluate_2023(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray, vegetated: np.ndarray,
                  survey_xy_m: float | None, survey_z_m: float | None,
                  class_h_cm: float | None = None, class_v_cm: float | None = None) -> dict[str, Any]:
    """Edition 2: the fit to the check points combined with the check point survey's own error.

    `survey_xy_m` is the survey's RMSE of one horizontal coordinate; the horizontal survey
    term is then RMSE_H2 = √2 · survey_xy_m (secondary source, see the module docstring).
    """
    rx, ry = st.rmse(dx), st.rmse(dy)
    fit_h = math.hypot(rx, ry)
    survey_h = math.sqrt(2) * survey_xy_m if survey_xy_m is not None else None
    rmse_h = math.hypot(fit_h, survey_h or 0.0)
    nonveg, veg = _split(dz, vegetated)
    fit_v = st.rmse(nonveg) if len(nonveg) else None
    rmse_v = math.hypot(fit_v, survey_z_m or 0.0) if fit_v is not None else None
    fit_vva = st.rmse(veg) if len(veg) else None
    out: dict[str, Any] = {
        "rmse_x_m": rx, "rmse_y_m": ry, "rmse_h_fit_m": fit_h, "rmse_h_survey_m": survey_h, "rmse_h_m": rmse_h,
        "rmse_v_fit_m": fit_v, "rmse_v_survey_m": survey_z_m, "rmse_v_m": rmse_v,
        "rmse_3d_m": math.hypot(rmse_h, rmse_v) if rmse_v is not None else None,
        "vva_rmse_v_m": math.hypot(fit_vva, survey_z_m or 0.0) if fit_vva is not None else None,
        "vva_95_percentile_m": float(np.percentile(np.abs(veg), 95)) if len(veg) else None,
        "n_horizontal": int(len(dx)), "n_nva": int(len(nonveg)), "n_vva": int(len(veg)),
        "horizontal_class_cm": _round_up_cm(rmse_h),
        "vertical_class_cm": _round_up_cm(rmse_v) if rmse_v is not None else None,
        "class_h_tested_cm": class_h_cm, "class_v_tested_cm": class_v_cm,
    }
    record_verdicts(out, within(rmse_h, class_h_cm / 100) if class_h_cm is not None else None,
                    within(rmse_v, class_v_cm / 100) if class_v_cm is not None and rmse_v is not None else None)
    out["sentences"] = sentences_2023(out)
    return out


def sentences_2023(r: dict[str, Any]) -> list[str]:
    """Edition 2 statements, modelled on Edition 1's with RMSE_H, RMSE_V and RMSE_3D (not confirmed
    against the standard's text); RMSE_H and RMSE_V include the check point survey's accuracy as
    Edition 2 requires. For a valid test only (the survey accuracy is then known)."""
    out = []
    cls = r["class_h_tested_cm"] if r["class_h_tested_cm"] is not None else r["horizontal_class_cm"]
    lead = _lead(STD_2023, cls, "RMSE_H horizontal positional accuracy", r.get("horizontal_met", True))
    out.append(f"{lead} The tested horizontal positional accuracy was found to be RMSE_H = {_cm(r['rmse_h_m'])} cm "
               f"(RMSE_H1 = {_cm(r['rmse_h_fit_m'])} cm from the check points combined with the check point "
               f"survey's RMSE_H2 = {_cm(r['rmse_h_survey_m'] or 0.0)} cm).")
    if r["rmse_v_m"] is not None:
        vcls = r["class_v_tested_cm"] if r["class_v_tested_cm"] is not None else r["vertical_class_cm"]
        lead = _lead(STD_2023, vcls, "RMSE_V vertical positional accuracy", r.get("vertical_met", True))
        text = (f"{lead} The tested NVA was found to be RMSE_V = {_cm(r['rmse_v_m'])} cm (RMSE_V1 = "
                f"{_cm(r['rmse_v_fit_m'])} cm from the check points combined with the check point survey's RMSE_V2 = "
                f"{_cm(r['rmse_v_survey_m'] or 0.0)} cm).")
        if r["vva_rmse_v_m"] is not None:
            text += f" The VVA was found to be RMSE_V = {_cm(r['vva_rmse_v_m'])} cm (reported, no pass/fail)."
        out.append(text)
        out.append(f"The three-dimensional positional accuracy was found to be RMSE_3D = {_cm(r['rmse_3d_m'])} cm.")
    return out


def figures_2023(r: dict[str, Any]) -> list[str]:
    """The figures in our own words, for a set that does not make a valid test (no statement)."""
    survey = (f" with the check point survey's {_cm(r['rmse_h_survey_m'])} cm" if r["rmse_h_survey_m"] is not None
              else " (the check point survey's accuracy is not given)")
    out = [f"Figures only, no {STD_2023} statement (see the result's reasons): RMSE_H = {_cm(r['rmse_h_m'])} cm "
           f"(RMSE_x = {_cm(r['rmse_x_m'])} cm, RMSE_y = {_cm(r['rmse_y_m'])} cm{survey})."]
    if r["rmse_v_m"] is not None:
        out.append(f"NVA: RMSE_V = {_cm(r['rmse_v_m'])} cm; RMSE_3D = {_cm(r['rmse_3d_m'])} cm.")
    return out
