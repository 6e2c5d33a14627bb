"""`aerosurvey qa accuracy` and `aerosurvey qa bayes`: accuracy of finished products from check points."""

from __future__ import annotations

import json
from pathlib import Path

import click

from aerosurvey.errors import AerosurveyError, CheckFailed, InputError
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.qa.choices import STANDARDS, UNITS  # names only: the statistics (scipy) load in the commands

_POS = click.FloatRange(min=0, min_open=True)
_NONNEG = click.FloatRange(min=0)


class NotTested(AerosurveyError):
    """The points do not make a valid test by the standard: no verdict (exit code 3)."""

    exit_code = 3


def _dumps(data: object) -> str:
    return json.dumps(data, indent=1, allow_nan=False, default=str) + "\n"


@click.command()
@click.argument("points", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--standard", type=click.Choice(list(STANDARDS)), default="asprs2014", show_default=True)
@click.option("--units", type=click.Choice(list(UNITS)), default=None,
              help="Unit of length columns without a unit suffix (default m).")
@click.option("--crs", default=None, help="CRS of the coordinates, e.g. EPSG:5514 (or a crs column / GeoJSON crs).")
@click.option("--role", "default_role", type=click.Choice(["check", "control"]), default="check", show_default=True,
              help="Role of points when the file has no role column (control: GCPs used in the adjustment).")
@click.option("--class-h", type=_POS, default=None,
              help="Horizontal class to test, cm (ASPRS: X; NSSDA: accuracy at 95 %; bayes: sigma of one coordinate).")
@click.option("--class-v", type=_POS, default=None, help="Vertical class to test, cm (as --class-h).")
@click.option("--area-km2", type=_POS, default=None, help="Project area, for the required number of check points.")
@click.option("--area-ha", type=_POS, default=None, help="Project area in hectares (instead of --area-km2).")
@click.option("--campaign", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="A plan folder (aerosurvey plan/gcp output): project area, proposed GCPs and check points, GSD.")
@click.option("--ref-sigma-xy", type=_NONNEG, default=None,
              help="Reference survey: standard deviation of one horizontal coordinate, m (ASPRS 2023, bayes).")
@click.option("--ref-sigma-z", type=_NONNEG, default=None, help="Reference survey: height standard deviation, m.")
@click.option("--sigma0-h", type=_POS, default=None, help="Snooping: the specification's sigma0, horizontal, m.")
@click.option("--sigma0-v", type=_POS, default=None, help="Snooping: the specification's sigma0, vertical, m.")
@click.option("--k-h", type=_POS, default=1.96, show_default=True, help="Snooping: horizontal blunder factor.")
@click.option("--k-v", type=_POS, default=2.16, show_default=True, help="Snooping: vertical blunder factor.")
@click.option("--max-rejected", type=click.FloatRange(0, 1), default=0.05, show_default=True,
              help="Snooping: largest share of rejected points before the set fails.")
@click.option("--alpha", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=0.05, show_default=True,
              help="Snooping: significance level of the global chi-square test.")
@click.option("--json", "as_json", is_flag=True, help="Print the JSON result instead of the text summary.")
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Write accuracy.json, accuracy.txt and accuracy.html there.")
def accuracy(points: Path, standard: str, units: str | None, crs: str | None, default_role: str,
             class_h: float | None, class_v: float | None, area_km2: float | None, area_ha: float | None,
             campaign: Path | None, ref_sigma_xy: float | None, ref_sigma_z: float | None, sigma0_h: float | None,
             sigma0_v: float | None, k_h: float, k_v: float, max_rejected: float, alpha: float, as_json: bool,
             outdir: Path | None) -> None:
    """Accuracy of a product from its check points, by a standard.

    \b
    Exit codes:
      0  a valid test: the tested class or specification is met, or none was asked
         (figures reported only)
      1  a valid test, and the class or specification is NOT met
      2  bad input (nothing written)
      3  no valid test: NOT TESTED (no independent check points: control points
         show the fit, not the accuracy) or INDICATIVE ONLY (too few check points,
         check points not accurate enough, mean error above the standard's limit,
         or the plan's own check point rule not met); the reasons are printed
    """
    # imported here, not at the top: the help pages must not load scipy
    from aerosurvey.qa.accuracy_input import read_points
    from aerosurvey.qa.assessment import Settings, assess
    from aerosurvey.qa.campaign import read_campaign
    from aerosurvey.qa.report_html import render
    from aerosurvey.qa.report_text import summary

    if area_km2 is not None and area_ha is not None:
        raise InputError(f"--area-km2 = {area_km2} and --area-ha = {area_ha}: give the project area once")
    pts = read_points(points, units, default_role, crs)
    camp = read_campaign(campaign) if campaign is not None else None
    settings = Settings(standard=standard, class_h_cm=class_h, class_v_cm=class_v,
                        area_km2=area_km2 if area_ha is None else area_ha / 100.0, ref_sigma_xy_m=ref_sigma_xy,
                        ref_sigma_z_m=ref_sigma_z, k_h=k_h, k_v=k_v, max_rejected=max_rejected, sigma0_h_m=sigma0_h,
                        sigma0_v_m=sigma0_v, alpha=alpha)
    try:
        result = assess(pts, settings, camp)
    except ValueError as exc:
        raise InputError(f"--standard {standard}: {exc}") from None
    text = summary(result)
    if outdir is not None:
        with staged_directory(outdir) as stage:
            atomic_write_text(stage / "accuracy.json", _dumps(result))
            atomic_write_text(stage / "accuracy.txt", text)
            atomic_write_text(stage / "accuracy.html", render(result, pts))
    click.echo(_dumps(result) if as_json else text, nl=False)
    v = result["verdict"]
    if v["status"] != "valid":
        raise NotTested(f"{result['standard_name']}: {v['status']}, no verdict: {'; '.join(v['reasons'])}")
    if result["passed"] is False:
        raise CheckFailed(f"{result['standard_name']}: the data set does not meet the tested class or specification")


@click.command()
@click.option("--points", type=click.IntRange(min=1), required=True, help="Number of check points.")
@click.option("--s", "s", type=_POS, required=True, help="Sample standard deviation of the differences (any unit).")
@click.option("--tau", type=_NONNEG, required=True, help="Reference survey standard deviation (same unit).")
@click.option("--axis", type=click.Choice(["xy", "z"]), default="xy", show_default=True,
              help="xy: positions, m = 2 x points, s and tau per coordinate; z: heights, m = points.")
@click.option("--level", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=0.95, show_default=True,
              help="Probability of the credible interval.")
@click.option("--class", "cls", type=_POS, default=None, help="Largest acceptable sigma (same unit): exit 1 above it.")
@click.option("--unit", default="", help="Name of the unit, for the printout and the plot (e.g. mm).")
@click.option("--json", "as_json", is_flag=True)
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Write bayes.json, bayes.txt and bayes.html (with the posterior density) there.")
def bayes(points: int, s: float, tau: float, axis: str, level: float, cls: float | None, unit: str, as_json: bool,
          outdir: Path | None) -> None:
    """Bayesian sigma from summary statistics alone, as published tables give them."""
    from aerosurvey.qa import bayes as bz  # scipy: loaded by the command, not by its help page
    from aerosurvey.qa.report_html import posterior_page

    m = 2 * points if axis == "xy" else points
    p = bz.posterior(m, s, tau, level)
    res: dict[str, object] = {"axis": axis, "points": points, "m": m, "s": s, "tau": tau, "unit": unit or None,
                              "mode": p.mode, "level": level, "ci_lower": p.lower, "ci_upper": p.upper,
                              "half_width": p.half_width}
    u = f" {unit}" if unit else ""
    text = (f"posterior mode {p.mode:.2f}{u}, {level * 100:g} % credible interval {p.lower:.2f} .. {p.upper:.2f}{u} "
            f"(half-width {p.half_width:.2f}); m = {m}, s = {s:g}{u}, tau = {tau:g}{u}")
    if cls is not None:
        res["class"] = cls
        res["probability_within_class"] = bz.cdf(cls, m, s, tau)
        res["met"] = p.mode <= cls
        text += f"; P(sigma <= {cls:g}{u}) = {res['probability_within_class']:.3f}: {'met' if res['met'] else 'NOT met'}"
    if outdir is not None:
        xs, ys = bz.density_curve(p)
        post = {"axis": axis, "sigma_m": xs.tolist(), "density": ys.tolist(), "mode_m": p.mode, "lower_m": p.lower,
                "upper_m": p.upper}
        with staged_directory(outdir) as stage:
            atomic_write_text(stage / "bayes.json", _dumps(res))
            atomic_write_text(stage / "bayes.txt", text + "\n")
            atomic_write_text(stage / "bayes.html", posterior_page(
                f"Bayesian sigma from summary statistics ({'positions' if axis == 'xy' else 'heights'})", [text],
                post, unit, res))
    click.echo(_dumps(res) if as_json else text, nl=not as_json)
    if cls is not None and not res["met"]:
        raise CheckFailed(f"posterior mode {p.mode:.4g} is above the class {cls:g}")
