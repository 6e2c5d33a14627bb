"""One accuracy assessment: statistics, the chosen standard's test, the reviewer's warnings
(pure: data in, one JSON-ready dict out; lengths in keys ending `_m`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerosurvey.qa import asprs, bayes, nssda, review, validity
from aerosurvey.qa import snooping as sn
from aerosurvey.qa import statistics as st
from aerosurvey.qa import uncertainty as un
from aerosurvey.qa.accuracy_input import CheckPoints
from aerosurvey.qa.campaign import Campaign, area_bounds_local, campaign_checks, campaign_roles
from aerosurvey.qa.choices import STANDARDS
from aerosurvey.qa.identity import Identity, Product

EDITION2_UNCONFIRMED = ("Edition 2 figures not confirmed against the standard's own text (a secondary source only): "
                        "RMSE_H = sqrt(RMSE_H1^2 + RMSE_H2^2) with RMSE_H2 = sqrt(2) x the per-coordinate survey "
                        "RMSE, horizontal classes on RMSE_H, check points 2x more accurate than the product, the "
                        "check point counts by area (and, beyond 2,500 km2, our continuation of them up to the cap), "
                        "the wording of the statements. Confirmed (GPS World, 6 Dec 2023): RMSE only, survey accuracy "
                        "included, no VVA pass/fail for lidar, minimum 30, at most 120, RMSE_3D.")


@dataclass(frozen=True)
class Settings:
    """What the user asked for. Lengths in metres except the classes (cm, as the standards state them).

    class_h_cm / class_v_cm mean: ASPRS, the class X; NSSDA, the required accuracy at 95 %;
    Bayes, the largest acceptable σ (one horizontal coordinate / height); unused by snooping.
    `product` names what the statements of ASPRS and NSSDA identify (qa/identity.py).
    """

    standard: str = "asprs2014"
    class_h_cm: float | None = None
    class_v_cm: float | None = None
    area_km2: float | None = None
    ref_sigma_xy_m: float | None = None  # reference survey σ of one coordinate, one value for the set
    ref_sigma_z_m: float | None = None
    alpha0: float = sn.ALPHA0  # snooping: per value
    power: float = sn.POWER  # snooping: of the minimal detectable bias
    max_mdb: float = sn.MAX_MDB  # snooping: the largest MDB (in σ) it decides with
    max_rejected: float = sn.MAX_SHARE
    sigma0_h_m: float | None = None
    sigma0_v_m: float | None = None
    alpha: float = 0.05
    product: Product = field(default_factory=Product)


#: Standards whose reporting statements name the product (qa/identity.py).
STATEMENT_STANDARDS = ("asprs2014", "asprs2023", "nssda")
#: The Bayesian estimate decides on at least this many points per tested component: the
#: minimum NSSDA and ASPRS 2014 set for an RMSE-based verdict (the posterior mode stands where
#: the RMSE stands in them; with τ = 0 it is the RMSE times √(m/(m+1))).
BAYES_MIN_POINTS = 20


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
    #: adds the standard's own conditions of a valid test (counts, survey accuracy, mean error)
    conditions: Callable[[validity.Validity], None] | None = None
    #: P(true RMSE within the class), per component, for the uncertainty section
    probability: dict[str, Any] = field(default_factory=dict)
    #: the report sentences again, for a set that does not make a valid test
    invalid_sentences: Callable[[], list[str]] | None = None


def _class_limits(t: CheckPoints, s: Settings) -> tuple[float | None, float | None, np.ndarray]:
    """The horizontal and vertical class asked for, in metres (None: no class asked, figures only),
    and which points test the non-vegetated vertical accuracy."""
    x_h = s.class_h_cm / 100 if s.class_h_cm is not None else None
    x_v = s.class_v_cm / 100 if s.class_v_cm is not None else None
    return x_h, x_v, np.isfinite(t.dz) & ~t.vegetated


def _run_asprs2014(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    result = asprs.evaluate_2014(t.dx, t.dy, t.dz, t.vegetated, s.class_h_cm, s.class_v_cm)

    def verdict(m: np.ndarray) -> bool | None:
        res: bool | None = asprs.evaluate_2014(t.dx[m], t.dy[m], t.dz[m], t.vegetated[m], s.class_h_cm,
                                               s.class_v_cm, exact=False)["passed"]
        return res

    run = _Run(result, asprs.required_2014(area_km2), verdict)
    if result["n_vva"] == 0 and np.isfinite(t.dz).any():
        run.notes.append("no point is marked vegetated (landcover column): VVA is not reported; the paper's "
                         "'3 x RMSE_z' is the class limit, not a VVA")
    if abs(result["rmse_x_m"] - result["rmse_y_m"]) > 1e-12:
        ratio = min(result["rmse_x_m"], result["rmse_y_m"]) / max(result["rmse_x_m"], result["rmse_y_m"])
        run.notes.append(f"RMSE_x and RMSE_y differ (ratio {ratio:.3f}): the 95 % figure is "
                         f"{_fmt_cm(result['horizontal_95_m'])} by {result['horizontal_95_method']}; 1.7308 x RMSE_r "
                         f"(equal axes only) would give {_fmt_cm(result['horizontal_95_equal_axes_m'])} and the exact "
                         f"circular error at 95 % of the bivariate normal is {_fmt_cm(result['ce95_exact_m'])}")
    sx = asprs.survey_rmse(t.sigma_xy, s.ref_sigma_xy_m)
    sz = asprs.survey_rmse(t.sigma_z, s.ref_sigma_z_m)
    product_h = s.class_h_cm / 100 if s.class_h_cm is not None else result["smallest_x_horizontal_m"]
    product_v = s.class_v_cm / 100 if s.class_v_cm is not None else result["rmse_z_nva_m"]
    run.warnings += review.survey_findings(sx, sz, product_h, product_v, asprs.SURVEY_RATIO_2014,
                                           "ASPRS 2014 asks for 3x")
    # the survey and mean-error conditions apply to the class asked for (none asked: figures reported only)
    x_h, x_v, nva = _class_limits(t, s)

    def conditions(v: validity.Validity) -> None:
        req = run.required
        assert req is not None
        validity.count(v, t.n, req.horizontal, "check points (horizontal)")
        if nva.any():
            validity.count(v, int(nva.sum()), req.nva, "NVA height check points")
        validity.survey_accuracy(v, "horizontal, per coordinate", sx, x_h, asprs.SURVEY_RATIO_2014,
                                 "ASPRS 2014: 3x")
        if nva.any():
            validity.survey_accuracy(v, "vertical", sz, x_v, asprs.SURVEY_RATIO_2014, "ASPRS 2014: 3x")

    run.warnings += review.mean_error_findings([("x", t.dx, x_h), ("y", t.dy, x_h), ("z", t.dz[nva], x_v)])
    run.conditions = conditions
    run.invalid_sentences = lambda: asprs.figures_2014(result)
    if s.class_h_cm is not None:
        x = s.class_h_cm / 100
        px, py = un.probability_within(result["rmse_x_m"], t.n, x), un.probability_within(result["rmse_y_m"], t.n, x)
        run.probability["horizontal"] = {
            "class_cm": s.class_h_cm, "rule": "RMSE_x <= X and RMSE_y <= X",
            "probability": px * py if px is not None and py is not None else None}
    if s.class_v_cm is not None and result["rmse_z_nva_m"] is not None:
        run.probability["vertical"] = {
            "class_cm": s.class_v_cm, "rule": "NVA RMSE_z <= X",
            "probability": un.probability_within(result["rmse_z_nva_m"], int(nva.sum()), s.class_v_cm / 100)}
    return run


def _run_asprs2023(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    sx = asprs.survey_rmse(t.sigma_xy, s.ref_sigma_xy_m)
    sz = asprs.survey_rmse(t.sigma_z, s.ref_sigma_z_m)
    result = asprs.evaluate_2023(t.dx, t.dy, t.dz, t.vegetated, sx, sz, s.class_h_cm, s.class_v_cm)

    def verdict(m: np.ndarray) -> bool | None:
        res: bool | None = asprs.evaluate_2023(t.dx[m], t.dy[m], t.dz[m], t.vegetated[m], sx, sz, s.class_h_cm,
                                               s.class_v_cm)["passed"]
        return res

    run = _Run(result, asprs.required_2023(area_km2), verdict, notes=[EDITION2_UNCONFIRMED])
    per_axis_h = (s.class_h_cm / 100 if s.class_h_cm is not None else result["rmse_h_m"]) / math.sqrt(2)
    product_v = s.class_v_cm / 100 if s.class_v_cm is not None else result["rmse_v_m"]
    run.warnings += review.survey_findings(sx, sz, per_axis_h, product_v, asprs.SURVEY_RATIO_2023,
                                           "Edition 2: about 2x, not confirmed")
    x_h, x_v, nva = _class_limits(t, s)

    def conditions(v: validity.Validity) -> None:
        req = run.required
        assert req is not None
        validity.count(v, t.n, req.total, "check points")
        validity.survey_accuracy(v, "horizontal, per coordinate", sx, x_h / math.sqrt(2) if x_h else None,
                                 asprs.SURVEY_RATIO_2023, "Edition 2: about 2x, not confirmed")
        if nva.any():
            validity.survey_accuracy(v, "vertical", sz, x_v, asprs.SURVEY_RATIO_2023,
                                     "Edition 2: about 2x, not confirmed")

    lim_xy = x_h / math.sqrt(2) if x_h is not None else None
    run.warnings += review.mean_error_findings([("x", t.dx, lim_xy), ("y", t.dy, lim_xy), ("z", t.dz[nva], x_v)])
    run.conditions = conditions
    run.invalid_sentences = lambda: asprs.figures_2023(result)
    if x_h is not None:
        pooled, m = un.pooled(t.dx, t.dy)
        room = x_h * x_h - (result["rmse_h_survey_m"] or 0.0) ** 2
        run.probability["horizontal"] = {
            "class_cm": s.class_h_cm, "rule": "RMSE_H = sqrt(fit^2 + survey^2) <= X, fit from both axes pooled",
            "probability": un.probability_within(pooled, m, math.sqrt(room / 2) if room > 0 else 0.0)}
    if x_v is not None and result["rmse_v_fit_m"] is not None:
        room = x_v * x_v - (sz or 0.0) ** 2
        run.probability["vertical"] = {
            "class_cm": s.class_v_cm, "rule": "RMSE_V = sqrt(fit^2 + survey^2) <= X",
            "probability": un.probability_within(result["rmse_v_fit_m"], int(nva.sum()),
                                                 math.sqrt(room) if room > 0 else 0.0)}
    return run


def _run_nssda(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    def verdict(m: np.ndarray) -> bool | None:
        res: bool | None = nssda.evaluate(t.dx[m], t.dy[m], t.dz[m], s.class_h_cm, s.class_v_cm)["passed"]
        return res

    result = nssda.evaluate(t.dx, t.dy, t.dz, s.class_h_cm, s.class_v_cm)
    run = _Run(result, asprs.Required(nssda.MIN_CHECK_POINTS, 0, 0, "NSSDA: at least 20"), verdict)

    def conditions(v: validity.Validity) -> None:
        validity.count(v, t.n, nssda.MIN_CHECK_POINTS, "check points")

    run.conditions = conditions
    run.invalid_sentences = lambda: nssda.figures(result)
    if s.class_h_cm is not None:
        pooled, m = un.pooled(t.dx, t.dy)
        run.probability["horizontal"] = {
            "class_cm": s.class_h_cm, "rule": "2.4477 sigma (one coordinate, axes pooled) <= the required accuracy",
            "probability": un.probability_within(pooled, m, s.class_h_cm / 100 / st.CE95_EQUAL)}
    if s.class_v_cm is not None and result["rmse_z_m"] is not None:
        run.probability["vertical"] = {
            "class_cm": s.class_v_cm, "rule": "1.96 sigma_z <= the required accuracy",
            "probability": un.probability_within(result["rmse_z_m"], int(np.isfinite(t.dz).sum()),
                                                 s.class_v_cm / 100 / st.LE95)}
    return run


def _run_snooping(t: CheckPoints, s: Settings, area_km2: float | None) -> _Run:
    def run_on(m: np.ndarray) -> sn.Snooping:
        return sn.snoop(t.dx[m], t.dy[m], t.dz[m], s.sigma0_h_m, s.sigma0_v_m, s.alpha0, s.power, s.max_rejected,
                        s.alpha)

    res = run_on(np.ones(t.n, bool))
    rejected = sorted((i for i, f in zip(t.ids, res.rejected) if f), key=review.natural_key)
    heights = bool(np.isfinite(t.dz).any())
    methods = {"horizontal": sn.W_TEST if s.sigma0_h_m is not None else sn.TAU_TEST,
               "vertical": sn.W_TEST if s.sigma0_v_m is not None else sn.TAU_TEST}
    fewest = sn.fewest_points(methods["horizontal"], methods["vertical"] if heights else None, s.alpha0, s.power,
                              s.max_mdb)
    n_values = 2 * t.n + int(np.isfinite(t.dz).sum())
    iterations: list[dict[str, Any]] = [{"iteration": k + 1, "points": it.kept, "tests": [c.as_dict(s.alpha0) for c in it.tests],
                   "rejected": t.ids[it.rejected] if it.rejected >= 0 else None, "axis": it.axis}
                  for k, it in enumerate(res.iterations)]
    result: dict[str, Any] = {
        "methods": {axis: sn.METHOD_NAMES[m] for axis, m in methods.items() if axis == "horizontal" or heights},
        "alpha0": s.alpha0, "power": s.power, "values_tested": n_values, "survey_alpha": res.survey_alpha,
        "max_mdb_sigma": s.max_mdb, "fewest_points": fewest, "iterations": iterations, "rejected": rejected,
        "rejected_share": res.rejected_share, "max_share": res.max_share, "share_ok": res.share_ok,
        "global_test_all": res.global_all, "global_test_kept": res.global_kept, "passed": res.passed,
        **{f"mdb_{c.axis}_m": st.finite_or_none(c.mdb_m) for c in res.last.tests},
        **{f"redundancy_{c.axis}": c.values for c in res.last.tests}}
    sentences = [
        "Data snooping, one point rejected per iteration: " + "; ".join(
            f"{axis}, {name}" for axis, name in result["methods"].items())
        + f"; alpha0 = {s.alpha0:g} per value, so a blunder-free set of these {n_values} values loses a point "
          f"with probability {res.survey_alpha * 100:.1f} %; minimal detectable bias (MDB) at {s.power * 100:g} % "
          "power; every value has redundancy number 1 (direct differences)."]
    for it in iterations:
        parts = [f"{c['axis']} {c['method']}-test, redundancy {c['redundancy']}, sigma {_cm_text(c['sigma_m'])}, "
                 f"critical value {_num(c['critical_value'])} (threshold {_cm_text(c['threshold_m'])}), largest "
                 f"{c['largest_statistic']:.2f}, MDB {_cm_text(c['mdb_m'])}" for c in it["tests"]]
        outcome = f"rejects {it['rejected']} ({it['axis']})" if it["rejected"] else "rejects none"
        sentences.append(f"Iteration {it['iteration']} ({it['points']} points): " + "; ".join(parts) + f": {outcome}.")
    # the figures only: the verdict is the result's one (not tested when the evidence is too little)
    sentences.append(f"{len(rejected)} of {t.n} points rejected{' (' + ', '.join(rejected) + ')' if rejected else ''}"
                     f": {res.rejected_share * 100:.1f} %, " + ("limit" if res.share_ok else "over the limit of")
                     + f" {res.max_share * 100:g} %.")
    for label, every, kept in ((a, res.global_all.get(a), res.global_kept.get(a)) for a in ("horizontal", "vertical")):
        for which, g in (("every point", every), ("the points kept", kept)):
            if g is not None:
                sentences.append(
                    f"Global test ({label}, {which}): sigma = {_cm_text(g['sigma_m'])}, sum e^2 / sigma0^2 = "
                    f"{g['statistic']:.2f} {'<=' if g['passed'] else '>'} chi2({g['dof']}, {1 - g['alpha']:g}) = "
                    f"{g['limit']:.2f} with sigma0 = {_cm_text(g['sigma0_m'])}.")
    result["sentences"] = sentences
    run = _Run(result, None, lambda m: run_on(m).passed, flags={"snooping_rejected": res.rejected})
    why = (f"a blunder of {s.max_mdb:g} sigma on one value must be found with {s.power * 100:g} % power at alpha0 = "
           f"{s.alpha0:g}; with sigma estimated from the same points (Pope's tau-test) this needs enough redundancy")

    def conditions(v: validity.Validity) -> None:
        validity.evidence(v, "data snooping", t.n, fewest, why)

    run.conditions = conditions
    if not any(g is not None for g in res.global_kept.values()):
        run.notes.append("no specification sigma0 given (--sigma0-h / --sigma0-v): sigma is estimated from the points "
                         "(Pope's tau-test) and the global test was not run")
    return run



def _num(v: float | None) -> str:
    return "infinite" if v is None else f"{v:.3f}"


def _cm_text(v: float | None) -> str:
    return "infinite (undetectable)" if v is None else f"{v * 100:.2f} cm"


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
    run = _Run({**res, "passed": passed, "sentences": sentences}, None, lambda m: _bayes(t.select(m), s)[2],
               posterior=plot)
    counts = {"xy": t.n, "z": int(np.isfinite(t.dz).sum())}

    def conditions(v: validity.Validity) -> None:
        validity.evidence(v, "the Bayesian estimate", min(counts[a] for a in res), BAYES_MIN_POINTS,
                          "the verdict compares the posterior mode with the class, as the standards compare the RMSE: "
                          f"at least {BAYES_MIN_POINTS} points per tested component, NSSDA's and ASPRS 2014's minimum")

    run.conditions = conditions
    return run


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
    influence_at = len(warnings)  # the verdict's dependence on single points: once it is known whether there is one
    notes = [f"input lengths in {points.units}" + ("" if points.units_stated else " (assumed: no unit stated)")
             + f"; CRS {points.crs or 'not stated'}"] + notes + run.notes
    if not tested.has_positions:
        notes.append("no reference positions (x_ref, y_ref): the distribution over the area was not checked")
    if campaign is not None and campaign.gsd_target_cm:
        stats["horizontal"]["rmse_r_gsd"] = stats["horizontal"]["rmse_r_m"] / (campaign.gsd_target_cm / 100)
        notes.append(f"RMSE_r = {stats['horizontal']['rmse_r_gsd']:.2f} x the planned GSD of "
                     f"{campaign.gsd_target_cm:g} cm ({campaign.mission or campaign.folder})")
    valid = validity.Validity()
    validity.independence(valid, int(is_check.sum()), int((~is_check).sum()))
    if run.conditions is not None and is_check.any():
        run.conditions(valid)
    identity = None
    if s.standard in STATEMENT_STANDARDS and is_check.any():
        identity = Identity(s.product, tested.crs, tested.n, bool(np.isfinite(tested.dz).any()),
                            asprs.survey_rmse(tested.sigma_xy, s.ref_sigma_xy_m),
                            asprs.survey_rmse(tested.sigma_z, s.ref_sigma_z_m))
        validity.statement_inputs(valid, standard_name, identity.missing())
    if campaign is not None:
        c_warn, c_notes = campaign_checks(campaign, points, tested if is_check.any() else None, valid)
        warnings += c_warn
        notes += c_notes
    # a result without a verdict (not tested, indicative only) has no verdict to rest on single points
    warnings[influence_at:influence_at] = review.influence_findings(tested, run.verdict if valid.status == validity.VALID
                                                                    else None)
    result = dict(run.result)
    sentences = result.pop("sentences", [])
    if valid.status != validity.VALID and run.invalid_sentences is not None:
        sentences = run.invalid_sentences()
    elif identity is not None:
        sentences = [identity.sentence()] + sentences
    if not is_check.any():
        sentences = [f"These are the residuals of {points.n} ground control point(s) used in the adjustment: they "
                     "measure the fit of the adjustment, not the accuracy of the product."] + sentences
    arithmetic = result.get("passed")
    status = valid.status
    verdict = {**valid.as_dict(), "passed_arithmetic": arithmetic,
               "result": status if status != validity.VALID else
               {True: "met", False: "not met", None: "reported only"}[arithmetic]}
    nva = np.isfinite(tested.dz) & (~tested.vegetated if s.standard.startswith("asprs") else True)
    uncertainty = {"x": un.axis_intervals(tested.dx), "y": un.axis_intervals(tested.dy),
                   "z": un.axis_intervals(tested.dz[nva]), "probability_within_class": run.probability,
                   "method": "chi-square interval on sigma from an RMSE of n residuals; probability under "
                             "Jeffreys' prior (qa/uncertainty.py)"}
    return {
        "standard": s.standard, "standard_name": standard_name,
        "input": {"file": points.source, "points": points.n, "check_points": int(is_check.sum()),
                  "control_points": int((~is_check).sum()), "tested": tested.n, "units": points.units,
                  "units_stated": points.units_stated, "crs": points.crs, "positions": tested.has_positions,
                  "product": dict(vars(s.product))},
        "settings": {k: v for k, v in vars(s).items() if k != "product"},
        "campaign": campaign.summary() if campaign is not None else None,
        "area_km2": area_km2,
        "required_check_points": None if run.required is None else {
            "horizontal": run.required.horizontal, "nva": run.required.nva, "vva": run.required.vva,
            "note": run.required.note},
        "statistics": stats, "result": result,
        "passed": arithmetic if status == validity.VALID else None, "verdict": verdict, "uncertainty": uncertainty,
        "sentences": sentences, "warnings": warnings, "notes": notes,
        "points": _points_table(points, set(tested.ids), flags, tested),
        "posterior": run.posterior,
    }
