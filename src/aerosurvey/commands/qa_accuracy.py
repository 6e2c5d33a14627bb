"""`aerosurvey qa accuracy` and `aerosurvey qa bayes`: accuracy of finished products."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import click
import numpy as np

from aerosurvey.errors import CheckFailed, InputError
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.qa import bayes as bz
from aerosurvey.qa import standards
from aerosurvey.qa.points import read_points
from aerosurvey.qa.report_html import render
from aerosurvey.qa.snooping import snoop

STANDARDS = ("asprs2014", "asprs2023", "nssda", "snooping", "bayes")


def _campaign_area_km2(campaign: Path) -> float:
    m = campaign / "manifest.json"
    if not m.exists():
        raise InputError(f"--campaign {campaign}: manifest.json is missing; give a folder written by `aerosurvey plan`")
    return float(json.loads(m.read_text())["derived"]["area_ha"]) / 100.0


def _bayes_result(pts, tau_h: float | None, tau_v: float | None) -> tuple[dict[str, Any], tuple | None]:
    if tau_h is None and tau_v is None:
        raise InputError("--standard bayes needs the reference survey's standard deviation: --tau-h and/or --tau-v (in metres)")
    out: dict[str, Any] = {"standard": "Bayesian estimate with uncertain check points (Jeffreys prior)", "n": pts.n,
                           "sentences": [], "warnings": standards.reviewer_warnings(pts, 0, None), "passed": None}
    plot = None
    if tau_h is not None:
        s = math.sqrt(float(np.sum(pts.dx**2 + pts.dy**2)) / (2 * pts.n))
        p = bz.posterior(2 * pts.n, s, tau_h)
        out["horizontal"] = {"m": p.m, "s_m": s, "tau_m": tau_h, "mode_m": p.mode, "ci95_m": [p.lower, p.upper]}
        out["sentences"].append(f"Horizontal sigma (posterior mode) {p.mode * 100:.2f} cm, 95 % credible interval "
                                f"{p.lower * 100:.2f} .. {p.upper * 100:.2f} cm (s = {s * 100:.2f} cm, tau = {tau_h * 100:.2f} cm, m = {p.m})")
        plot = (*bz.density_curve(p), p.lower, p.upper, p.mode)
    dz = pts.dz[np.isfinite(pts.dz)]
    if tau_v is not None and len(dz):
        s = math.sqrt(float(np.sum(dz**2)) / len(dz))
        p = bz.posterior(len(dz), s, tau_v)
        out["vertical"] = {"m": p.m, "s_m": s, "tau_m": tau_v, "mode_m": p.mode, "ci95_m": [p.lower, p.upper]}
        out["sentences"].append(f"Vertical sigma (posterior mode) {p.mode * 100:.2f} cm, 95 % credible interval "
                                f"{p.lower * 100:.2f} .. {p.upper * 100:.2f} cm (s = {s * 100:.2f} cm, tau = {tau_v * 100:.2f} cm, m = {p.m})")
        plot = plot or (*bz.density_curve(p), p.lower, p.upper, p.mode)
    return out, plot


@click.command()
@click.argument("points", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--standard", type=click.Choice(STANDARDS), default="asprs2014", show_default=True)
@click.option("--units", type=click.Choice(["m", "cm", "mm"]), default=None, help="Unit of columns without a unit suffix (default m).")
@click.option("--role", "default_role", type=click.Choice(["check", "control"]), default="check", show_default=True,
              help="Role of points when the file has no role column.")
@click.option("--class-h", type=click.FloatRange(min=0, min_open=True), default=None, help="Horizontal class to test, cm.")
@click.option("--class-v", type=click.FloatRange(min=0, min_open=True), default=None, help="Vertical class to test, cm.")
@click.option("--area-km2", type=click.FloatRange(min=0, min_open=True), default=None, help="Project area for the required check point count.")
@click.option("--campaign", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="A plan folder: the project area comes from its manifest.")
@click.option("--survey-rmse-h", type=float, default=None, help="ASPRS 2023: RMSE of the check point survey, horizontal (m).")
@click.option("--survey-rmse-v", type=float, default=None, help="ASPRS 2023: RMSE of the check point survey, vertical (m).")
@click.option("--sigma0-h", type=float, default=None, help="Snooping: the specification's sigma0, horizontal (m).")
@click.option("--sigma0-v", type=float, default=None, help="Snooping: the specification's sigma0, vertical (m).")
@click.option("--k-h", type=float, default=1.96, show_default=True, help="Snooping: horizontal blunder factor.")
@click.option("--k-v", type=float, default=2.16, show_default=True, help="Snooping: vertical blunder factor.")
@click.option("--tau-h", type=float, default=None, help="Bayes: reference survey sigma, horizontal (m).")
@click.option("--tau-v", type=float, default=None, help="Bayes: reference survey sigma, vertical (m).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON.")
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Write accuracy.json, accuracy.txt and accuracy.html there.")
def accuracy(points: Path, standard: str, units: str | None, default_role: str, class_h: float | None,
             class_v: float | None, area_km2: float | None, campaign: Path | None, survey_rmse_h: float | None,
             survey_rmse_v: float | None, sigma0_h: float | None, sigma0_v: float | None, k_h: float, k_v: float,
             tau_h: float | None, tau_v: float | None, as_json: bool, outdir: Path | None) -> None:
    """Accuracy of a product from check points. Exit 0 when the class/spec is met, 1 when not, 2 for bad input."""
    pts = read_points(points, units, default_role)
    if campaign is not None:
        area_km2 = _campaign_area_km2(campaign)
    plot = None
    if standard == "asprs2014":
        result = standards.asprs2014(pts, area_km2, class_h, class_v)
    elif standard == "asprs2023":
        result = standards.asprs2023(pts, area_km2, class_h, class_v, survey_rmse_h, survey_rmse_v)
    elif standard == "nssda":
        result = standards.nssda(pts)
    elif standard == "snooping":
        s = snoop(pts.ids, pts.dx, pts.dy, pts.dz if np.all(np.isfinite(pts.dz)) else None, k_h, k_v,
                  sigma0_h=sigma0_h, sigma0_v=sigma0_v)
        result = {"standard": "cadastral data snooping", "n": pts.n, "sigma_h_m": s.sigma_h, "sigma_v_m": s.sigma_v,
                  "threshold_h_m": s.threshold_h, "threshold_v_m": s.threshold_v, "rejected": s.rejected,
                  "rejected_share": s.rejected_share, "max_share": s.max_share, "sigma_h_kept_m": s.sigma_h_kept,
                  "sigma_v_kept_m": s.sigma_v_kept, "global_test_h": s.global_h, "global_test_v": s.global_v,
                  "passed": s.passed, "warnings": standards.reviewer_warnings(pts, 0, None),
                  "sentences": [f"{len(s.rejected)} of {pts.n} points rejected ({100 * s.rejected_share:.1f} %, limit "
                                f"{100 * s.max_share:.0f} %): thresholds {s.threshold_h:.2f} m horizontal"
                                + (f", {s.threshold_v:.2f} m vertical" if s.threshold_v is not None else "")]}
    else:
        result, plot = _bayes_result(pts, tau_h, tau_v)
    text = "\n".join(result.get("sentences", []) + [f"warning: {w}" for w in result.get("warnings", [])])
    if outdir is not None:
        with staged_directory(outdir) as stage:
            atomic_write_text(stage / "accuracy.json", json.dumps(result, indent=1, default=str) + "\n")
            atomic_write_text(stage / "accuracy.txt", text + "\n")
            atomic_write_text(stage / "accuracy.html", render(f"Accuracy report: {points.name}", result, pts, plot))
    click.echo(json.dumps(result, indent=1, default=str) if as_json else text)
    if result.get("passed") is False:
        raise CheckFailed(f"{result['standard']}: the data set does not meet the tested class or specification")


@click.command()
@click.option("--points", type=click.IntRange(min=1), required=True, help="Number of check points.")
@click.option("--s", "s", type=click.FloatRange(min=0, min_open=True), required=True, help="Sample standard deviation (any unit).")
@click.option("--tau", type=click.FloatRange(min=0), required=True, help="Reference survey sigma (same unit).")
@click.option("--axis", type=click.Choice(["xy", "z"]), default="xy", show_default=True, help="xy: m = 2 x points; z: m = points.")
@click.option("--json", "as_json", is_flag=True)
def bayes(points: int, s: float, tau: float, axis: str, as_json: bool) -> None:
    """Bayesian sigma from summary statistics alone (as published tables give them)."""
    m = 2 * points if axis == "xy" else points
    p = bz.posterior(m, s, tau)
    res = {"m": m, "s": s, "tau": tau, "mode": p.mode, "ci95": [p.lower, p.upper], "half_width": p.half_width}
    if as_json:
        click.echo(json.dumps(res, indent=1))
    else:
        click.echo(f"posterior mode {p.mode:.2f}, 95 % credible interval {p.lower:.2f} .. {p.upper:.2f} "
                   f"(half-width {p.half_width:.2f}); m = {m}, s = {s:g}, tau = {tau:g}")
