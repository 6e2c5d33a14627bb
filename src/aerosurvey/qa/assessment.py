"""One accuracy assessment: statistics, the chosen standard's test, the reviewer's warnings
(pure: data in, one JSON-ready dict out; lengths in keys ending `_m`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerosurvey.qa import asprs, bayes, nssda, review
from aerosurvey.qa import statistics as st
from aerosurvey.qa.accuracy_input import CheckPoints
from aerosurvey.qa.campaign import Campaign, area_bounds_local, campaign_roles
from aerosurvey.qa.snooping import K_H, K_V, MAX_SHARE, Snooping, snoop

STANDARDS = {
    "asprs2014": "ASPRS Positional Accuracy Standards, Edition 1 (2014)",
    "asprs2023": "ASPRS Positional Accuracy Standards, Edition 2 (2023)",
    "nssda": "NSSDA (FGDC-STD-007.3-1998)",
    "snooping": "Cadastral data snooping (Hellenic Cadastre practice)",
    "bayes": "Bayesian estimate with an uncertain reference survey (Jeffreys prior)",
}

EDITION2_UNCONFIRMED = ("Edition 2 figures not confirmed against the standard's own text (a secondary source only): "
                        "RMSE_H = sqrt(RMSE_H1^2 + RMSE_H2^2) with RMSE_H2 = sqrt(2) x the per-coordinate survey "
                        "RMSE, horizontal classes on RMSE_H, check points 2x more accurate than the product, the "
                        "check point counts by area. Confirmed (GPS World, 6 Dec 2023): RMSE only, survey accuracy "
                        "included, no VVA pass/fail for lidar, minimum 30, at most 120, RMSE_3D.")


@dataclass(frozen=True)
class Settings:
    """What the user asked for. Lengths in metres except the classes (cm, as the standards state them).

    class_h_cm / class_v_cm mean: ASPRS, the class X; NSSDA, the required accuracy at 95 %;
    Bayes, the largest acceptable σ (one horizontal coordinate / height); unused by snooping.
    """

    standard: str = "asprs2014"
    class_h_cm: float | None = None
    class_v_cm: float | None = None
    area_km2: float | None = None
    ref_sigma_xy_m: float | None = None  # reference survey σ of one coordinate, one value for the set
    ref_sigma_z_m: float | None = None
    k_h: float = K_H
    k_v: float = K_V
    max_rejected: float = MAX_SHARE
    sigma0_h_m: float | None = None
    sigma0_v_m: float | None = None
    alpha: float = 0.05


def _statistics(p: CheckPoints) -> dict[str, Any]:
    h = st.horizontal_summary(p.dx, p.dy)
    v = st.vertical_summary(p.dz)
    rz = v.get("rmse_z_m")
    return {"x": st.axis_stats(p.dx), "y": st.axis_stats(p.dy), "z": st.axis_stats(p.dz), "horizontal": h,
            "vertical": v, "rmse_3d_m": math.hypot(h["rmse_r_m"], rz) if rz is not None else None}


def _points_table(all_pts: CheckPoints, tested_ids: set[str], flags: dict[str, np.ndarray],
                  tested: CheckPoints) -> list[dict[str, Any]]:
    where = {pid: k for k, pid in enumerate(tested.ids)}
    rows = []
    for i, pid in enumerate(all_pts.ids):
        k = where.get(pid)
        rows.append({
            "id": pid, "role": all_pts.role[i], "tested": pid in tested_ids,
            "dx_m": float(all_pts.dx[i]), "dy_m": float(all_pts.dy[i]),
            "dz_m": float(all_pts.dz[i]) if np.isfinite(all_pts.dz[i]) else None,
            "vegetated": bool(all_pts.vegetated[i]),
            "flags": [name for name, f in flags.items() if k is not None and bool(f[k])],
        })
    return rows


def _fmt_cm(v: float) -> str:
    return f"{v * 100:.2f} cm"


def _bayes(tested: CheckPoints, s: Settings) -> tuple[dict[str, Any], list[str], bool | None]:
    sx = asprs.survey_rmse(tested.sigma_xy, s.ref_sigma_xy_m)
    sz = asprs.survey_rmse(tested.sigma_z, s.ref_sigma_z_m)
    out: dict[str, Any] = {}
    sentences: list[str] = []
    verdicts: list[bool] = []
    dz = tested.dz[np.isfinite(tested.dz)]
    for axis, tau, m, sample, cls in (
            ("xy", sx, 2 * tested.n, math.sqrt(float(np.sum(tested.dx**2 + tested.dy**2)) / (2 * tested.n)),
             s.class_h_cm),
            ("z", sz, len(dz), math.sqrt(float(np.sum(dz**2)) / len(dz)) if len(dz) else None, s.class_v_cm)):
        if tau is None or sample is None or not sample > 0:
            continue
        p = bayes.posterior(m, sample, tau)
        res: dict[str, Any] = {"m": m, "s_m": sample, "tau_m": tau, "mode_m": p.mode, "ci95_lower_m": p.lower,
                               "ci95_upper_m": p.upper, "ci95_half_width_m": p.half_width}
        label = "one horizontal coordinate" if axis == "xy" else "height"
        text = (f"sigma of {label} (posterior mode) = {_fmt_cm(p.mode)}, 95 % credible interval {_fmt_cm(p.lower)} "
                f".. {_fmt_cm(p.upper)} (m = {m}, s = {_fmt_cm(sample)}, reference tau = {_fmt_cm(tau)})")
        if cls is not None:
            res["class_cm"] = cls
            res["probability_within_class"] = bayes.cdf(cls / 100, m, sample, tau)
            res["met"] = p.mode <= cls / 100 + 1e-12
            verdicts.append(res["met"])
            text += (f"; P(sigma <= {cls:g} cm) = {res['probability_within_class']:.3f}, "
                     f"{'met' if res['met'] else 'not met'} by the mode")
        out[axis] = res
        sentences.append(text[0].upper() + text[1:] + ".")
    return out, sentences, (all(verdicts) if verdicts else None)


@dataclass
class _Run:
    """What one standard contributes: its figures, the counts it asks for, a verdict on a
    subset of the points (for the single-point review), and its own warnings and notes."""

    result: dict[str, Any]
    required: asprs.Required | None = None
    verdict: Callable[[np.ndarray], bool | None] | None = None
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    flags: dict[str, np.ndarray] = field(default_factory=dict)
    posterior: dict[str, Any] | None = None


def _run_asprs2014(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    result = asprs.evaluate_2014(t.dx, t.dy, t.dz, t.vegetated, s.class_h_cm, s.class_v_cm)

    def verdict(m: np.ndarray) -> bool | None:
        return asprs.evaluate_2014(t.dx[m], t.dy[m], t.dz[m], t.vegetated[m], s.class_h_cm, s.class_v_cm,
                                   exact=False)["passed"]

    run = _Run(result, asprs.required_2014(area_km2), verdict)
    if result["n_vva"] == 0 and np.isfinite(t.dz).any():
        run.notes.append("no point is marked vegetated (landcover column): VVA is not reported; the paper's "
                         "'3 x RMSE_z' is the class limit, not a VVA")
    if abs(result["rmse_x_m"] - result["rmse_y_m"]) > 1e-12:
        ratio = min(result["rmse_x_m"], result["rmse_y_m"]) / max(result["rmse_x_m"], result["rmse_y_m"])
        run.notes.append(f"RMSE_x and RMSE_y differ (ratio {ratio:.3f}): the 95 % figure 1.7308 x RMSE_r = "
                         f"{_fmt_cm(result['horizontal_95_m'])} assumes them equal; NSSDA gives "
                         f"{_fmt_cm(result['horizontal_95_nssda_m'])} and the exact circular error at 95 % of the "
                         f"bivariate normal is {_fmt_cm(result['ce95_exact_m'])}")
    sx = asprs.survey_rmse(t.sigma_xy, s.ref_sigma_xy_m)
    sz = asprs.survey_rmse(t.sigma_z, s.ref_sigma_z_m)
    product_h = s.class_h_cm / 100 if s.class_h_cm is not None else result["smallest_x_horizontal_m"]
    product_v = s.class_v_cm / 100 if s.class_v_cm is not None else result["rmse_z_nva_m"]
    run.warnings += review.survey_findings(sx, sz, product_h, product_v, asprs.SURVEY_RATIO_2014,
                                           "ASPRS 2014 asks for 3x")
    return run


def _run_asprs2023(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    sx = asprs.survey_rmse(t.sigma_xy, s.ref_sigma_xy_m)
    sz = asprs.survey_rmse(t.sigma_z, s.ref_sigma_z_m)
    result = asprs.evaluate_2023(t.dx, t.dy, t.dz, t.vegetated, sx, sz, s.class_h_cm, s.class_v_cm)

    def verdict(m: np.ndarray) -> bool | None:
        return asprs.evaluate_2023(t.dx[m], t.dy[m], t.dz[m], t.vegetated[m], sx, sz, s.class_h_cm,
                                   s.class_v_cm)["passed"]

    run = _Run(result, asprs.required_2023(area_km2), verdict, notes=[EDITION2_UNCONFIRMED])
    if sx is None or (sz is None and result["rmse_v_fit_m"] is not None):
        run.warnings.append("the check point survey's accuracy is not given (--ref-sigma-xy / --ref-sigma-z or the "
                            "sigma_xy / sigma_z columns): Edition 2 adds it into the product accuracy; it is taken "
                            "as 0 here, which overstates the accuracy")
    per_axis_h = (s.class_h_cm / 100 if s.class_h_cm is not None else result["rmse_h_m"]) / math.sqrt(2)
    product_v = s.class_v_cm / 100 if s.class_v_cm is not None else result["rmse_v_m"]
    run.warnings += review.survey_findings(sx, sz, per_axis_h, product_v, asprs.SURVEY_RATIO_2023,
                                           "Edition 2: about 2x, not confirmed")
    return run


def _run_nssda(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    def verdict(m: np.ndarray) -> bool | None:
        return nssda.evaluate(t.dx[m], t.dy[m], t.dz[m], s.class_h_cm, s.class_v_cm)["passed"]

    return _Run(nssda.evaluate(t.dx, t.dy, t.dz, s.class_h_cm, s.class_v_cm),
                asprs.Required(nssda.MIN_CHECK_POINTS, 0, 0, "NSSDA: at least 20"), verdict)


def _run_snooping(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    def run_on(m: np.ndarray) -> Snooping:
        return snoop(t.dx[m], t.dy[m], t.dz[m], s.k_h, s.k_v, s.max_rejected, s.sigma0_h_m, s.sigma0_v_m, s.alpha)

    sn = run_on(np.ones(t.n, bool))
    rejected = sorted((i for i, f in zip(t.ids, sn.rejected) if f), key=review.natural_key)
    result = {"sigma_h_m": sn.sigma_h, "sigma_v_m": sn.sigma_v, "k_h": s.k_h, "k_v": s.k_v,
              "threshold_h_m": sn.threshold_h, "threshold_v_m": sn.threshold_v, "rejected": rejected,
              "rejected_share": sn.rejected_share, "max_share": sn.max_share, "share_ok": sn.share_ok,
              "sigma_h_kept_m": sn.sigma_h_kept, "sigma_v_kept_m": sn.sigma_v_kept,
              "global_test_h": sn.global_h, "global_test_v": sn.global_v, "passed": sn.passed}
    sentence = (f"{len(rejected)} of {t.n} points rejected by data snooping"
                f"{' (' + ', '.join(rejected) + ')' if rejected else ''}: {sn.rejected_share * 100:.1f} %, "
                f"limit {sn.max_share * 100:g} %; thresholds {sn.threshold_h:.3g} m horizontal "
                f"({s.k_h:g} x sigma_hor = {sn.sigma_h:.4g} m)")
    if sn.threshold_v is not None:
        sentence += f", {sn.threshold_v:.3g} m vertical ({s.k_v:g} x sigma_ver = {sn.sigma_v:.4g} m)"
    result["sentences"] = [sentence + ("." if sn.share_ok else "; the data set fails.")]
    for label, g in (("horizontal", sn.global_h), ("vertical", sn.global_v)):
        if g is not None:
            result["sentences"].append(
                f"Global test ({label}): sigma = {g['sigma_m']:.4g} m on the kept points, f sigma^2 / sigma0^2 = "
                f"{g['statistic']:.2f} {'<=' if g['passed'] else '>'} chi2({g['dof']}, {1 - g['alpha']:g}) = "
                f"{g['limit']:.2f} with sigma0 = {g['sigma0_m']:.4g} m: {'passed' if g['passed'] else 'failed'}.")
    run = _Run(result, None, lambda m: run_on(m).passed, flags={"snooping_rejected": sn.rejected})
    if sn.global_h is None and sn.global_v is None:
        run.notes.append("no specification sigma0 given (--sigma0-h / --sigma0-v): the global test was not run")
    return run


def _run_bayes(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    res, sentences, passed = _bayes(t, s)
    if not res:
        raise ValueError("the Bayesian estimate needs the reference survey's standard deviation (--ref-sigma-xy "
                         "and/or --ref-sigma-z, or sigma_xy / sigma_z columns) and residuals that are not all zero")
    axis = "xy" if "xy" in res else "z"
    a = res[axis]
    p = bayes.Posterior(a["m"], a["s_m"], a["tau_m"], a["mode_m"], a["ci95_lower_m"], a["ci95_upper_m"], 0.95)
    xs, ys = bayes.density_curve(p)
    plot = {"axis": axis, "sigma_m": xs.tolist(), "density": ys.tolist(), "mode_m": p.mode, "lower_m": p.lower,
            "upper_m": p.upper}
    return _Run({**res, "passed": passed, "sentences": sentences}, None, lambda m: _bayes(t.select(m), s)[2],
                posterior=plot)


_RUNNERS: dict[str, Callable[[CheckPoints, Settings, float | None], _Run]] = {
    "asprs2014": _run_asprs2014, "asprs2023": _run_asprs2023, "nssda": _run_nssda, "snooping": _run_snooping,
    "bayes": _run_bayes,
}


def assess(points: CheckPoints, s: Settings, campaign: Campaign | None = None) -> dict[str, Any]:
    """The whole assessment as one dict. Raises ValueError for settings the data cannot serve."""
    if s.standard not in STANDARDS:
        raise ValueError(f"unknown standard {s.standard!r}")
    warnings: list[str] = []
    notes: list[str] = []
    area_km2 = s.area_km2
    if campaign is not None:
        roles, w, n = campaign_roles(campaign, points)
        points = points.with_roles(roles)
        warnings += w
        notes += n
        area_km2 = area_km2 if area_km2 is not None else campaign.area_km2
    is_check = np.array([r == "check" for r in points.role], bool)
    tested = points.select(is_check) if is_check.any() else points
    if tested.n == 0:
        raise ValueError("no points to test")
    stats = _statistics(tested)
    run = _RUNNERS[s.standard](tested, s, area_km2)
    flags = {"outlier_x": st.outliers(tested.dx), "outlier_y": st.outliers(tested.dy),
             "outlier_z": st.outliers(tested.dz), **run.flags}
    standard_name = STANDARDS[s.standard]
    warnings = review.control_findings(points, tested) + warnings + run.warnings
    warnings += review.count_findings(tested, run.required, standard_name)
    warnings += review.bias_findings(tested)
    warnings += review.outlier_findings(tested)
    bounds = area_bounds_local(campaign, tested) if campaign is not None else None
    warnings += review.distribution_findings(tested, bounds)
    warnings += review.influence_findings(tested, run.verdict)
    notes = [f"input lengths in {points.units}" + ("" if points.units_stated else " (assumed: no unit stated)")
             + f"; CRS {points.crs or 'not stated'}"] + notes + run.notes
    if not tested.has_positions:
        notes.append("no reference positions (x_ref, y_ref): the distribution over the area was not checked")
    if campaign is not None and campaign.gsd_target_cm:
        stats["horizontal"]["rmse_r_gsd"] = stats["horizontal"]["rmse_r_m"] / (campaign.gsd_target_cm / 100)
        notes.append(f"RMSE_r = {stats['horizontal']['rmse_r_gsd']:.2f} x the planned GSD of "
                     f"{campaign.gsd_target_cm:g} cm ({campaign.mission or campaign.folder})")
    result = dict(run.result)
    sentences = result.pop("sentences", [])
    return {
        "standard": s.standard, "standard_name": standard_name,
        "input": {"file": points.source, "points": points.n, "check_points": int(is_check.sum()),
                  "control_points": int((~is_check).sum()), "tested": tested.n, "units": points.units,
                  "units_stated": points.units_stated, "crs": points.crs, "positions": tested.has_positions},
        "settings": dict(vars(s)),
        "campaign": campaign.summary() if campaign is not None else None,
        "area_km2": area_km2,
        "required_check_points": None if run.required is None else {
            "horizontal": run.required.horizontal, "nva": run.required.nva, "vva": run.required.vva,
            "note": run.required.note},
        "statistics": stats, "result": result, "passed": result.get("passed"),
        "sentences": sentences, "warnings": warnings, "notes": notes,
        "points": _points_table(points, set(tested.ids), flags, tested),
        "posterior": run.posterior,
    }
