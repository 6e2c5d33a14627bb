"""The plain-text summary of an assessment (what `qa accuracy` prints and writes to accuracy.txt)."""

from __future__ import annotations

from typing import Any


def _cm(v: float | None, nd: int = 2) -> str:
    return "-" if v is None else f"{v * 100:.{nd}f}"


def _p(v: float | None) -> str:
    return "-" if v is None else f"{v:.3f}"


def verdict_line(r: dict[str, Any]) -> str:
    v = r["verdict"]
    if v["status"] != "valid":
        return f"RESULT: {v['status'].upper()} (no verdict by the standard): " + "; ".join(v["reasons"])
    if r["passed"] is True:
        return "RESULT: met"
    if r["passed"] is False:
        return "RESULT: NOT met"
    return "RESULT: reported only (no class or specification was tested)"


def uncertainty_lines(r: dict[str, Any]) -> list[str]:
    """The confidence interval of each RMSE and the probability of meeting the class."""
    u = r.get("uncertainty") or {}
    out = []
    for axis in ("x", "y", "z"):
        a = u.get(axis) or {}
        if a.get("n") and a.get("ci_lower_m") is not None:
            out.append(f"  RMSE_{axis} {_cm(a['rmse_m'])} cm, {a['level'] * 100:g} % confidence interval "
                       f"{_cm(a['ci_lower_m'])} .. {_cm(a['ci_upper_m'])} cm (n = {a['n']})")
    for comp, p in (u.get("probability_within_class") or {}).items():
        if p.get("probability") is not None:
            out.append(f"  P(true accuracy meets the {p['class_cm']:g} cm {comp} class) = {p['probability']:.3f} "
                       f"({p['rule']})")
    return out


def summary(r: dict[str, Any]) -> str:
    """Header, per-axis table (cm), horizontal/vertical figures, sentences, verdict, warnings, notes."""
    i = r["input"]
    lines = [f"Accuracy QA of {i['file']}: {r['standard_name']}",
             f"{i['points']} points ({i['check_points']} check, {i['control_points']} control); {i['tested']} tested",
             "",
             f"{'axis':<5}{'n':>4}{'mean':>9}{'std':>9}{'RMSE':>9}{'min':>9}{'max':>9}{'|e|95':>9}"
             f"{'bias p':>9}{'normal p':>10}   (cm)"]
    for axis in ("x", "y", "z"):
        a = r["statistics"][axis]
        if not a.get("n"):
            continue
        lines.append(f"{axis:<5}{a['n']:>4}{_cm(a['mean_m']):>9}{_cm(a['std_m']):>9}{_cm(a['rmse_m']):>9}"
                     f"{_cm(a['min_m']):>9}{_cm(a['max_m']):>9}{_cm(a['abs_p95_m']):>9}{_p(a['bias_p_value']):>9}"
                     f"{_p(a['normality_p_value']):>10}")
    h, v = r["statistics"]["horizontal"], r["statistics"]["vertical"]
    lines.append(f"horizontal: RMSE_r {_cm(h['rmse_r_m'])} cm, CE90 {_cm(h['ce90_m'])} cm, CE95 {_cm(h['ce95_m'])} cm "
                 f"(exact, bivariate normal)")
    if v.get("n"):
        lines.append(f"vertical:   RMSE_z {_cm(v['rmse_z_m'])} cm, LE90 {_cm(v['le90_m'])} cm, LE95 {_cm(v['le95_m'])} cm;"
                     f" RMSE_3D {_cm(r['statistics']['rmse_3d_m'])} cm")
    unc = uncertainty_lines(r)
    if unc:
        lines += ["", "Uncertainty:"] + unc
    lines.append("")
    lines += r["sentences"]
    lines += ["", verdict_line(r)]
    if r["warnings"]:
        lines += ["", "Warnings:"] + [f"  - {w}" for w in r["warnings"]]
    if r["notes"]:
        lines += ["", "Notes:"] + [f"  - {n}" for n in r["notes"]]
    return "\n".join(lines) + "\n"
