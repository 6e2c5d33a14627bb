"""`aerosurvey qa accuracy` and `aerosurvey qa bayes`: accuracy of finished products from check points."""

from __future__ import annotations

import json
from datetime import datetime
from pathlib import Path

import click

from aerosurvey.errors import AerosurveyError, CheckFailed, InputError
from aerosurvey.fileio import atomic_write_text, staged_directory
from aerosurvey.qa import choices
from aerosurvey.qa.choices import STANDARDS, UNITS  # names only: the statistics (scipy) load in the commands

_POS = click.FloatRange(min=0, min_open=True)
_NONNEG = click.FloatRange(min=0)


class NotTested(AerosurveyError):
    """The points do not make a valid test by the standard: no verdict (exit code 3)."""

    exit_code = 3


def _text(value: str | None, option: str) -> str | None:
    """A statement's text input: stripped, one line, not empty."""
    if value is None:
        return None
    v = value.strip()
    if not v or "\n" in v or len(v) > 200:
        raise InputError(f"{option} = {value!r} is not allowed: one line of 1 to 200 characters")
    return v


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
              help="A plan folder (aerosurvey plan/gcp output): project area, proposed GCPs and check points, GSD. A "
                   "campaign block's folder: with -o, the verdict is filed in the campaign's register.")
@click.option("--ref-sigma-xy", type=_NONNEG, default=None,
              help="Reference survey: standard deviation of one horizontal coordinate, m (ASPRS 2023, bayes).")
@click.option("--ref-sigma-z", type=_NONNEG, default=None, help="Reference survey: height standard deviation, m.")
@click.option("--sigma0-h", type=_POS, default=None,
              help="Snooping: a-priori sigma0 of one horizontal coordinate, m (Baarda's w-test and the global test; "
                   "without it Pope's tau-test).")
@click.option("--sigma0-v", type=_POS, default=None, help="Snooping: a-priori sigma0 of heights, m (as --sigma0-h).")
@click.option("--alpha0", type=click.FloatRange(0, 0.5, min_open=True), default=choices.SNOOPING_ALPHA0, show_default=True,
              help="Snooping: probability that one blunder-free value is rejected (0.001: Baarda's k = 3.29).")
@click.option("--power", type=click.FloatRange(0.5, 1, max_open=True), default=choices.SNOOPING_POWER, show_default=True,
              help="Snooping: power at which the minimal detectable bias is stated.")
@click.option("--max-mdb", type=_POS, default=choices.SNOOPING_MAX_MDB, show_default=True,
              help="Snooping: decide only when the minimal detectable bias is at most this many sigma.")
@click.option("--max-rejected", type=click.FloatRange(0, 1), default=choices.SNOOPING_MAX_SHARE, show_default=True,
              help="Snooping: largest share of rejected points before the set fails.")
@click.option("--alpha", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=0.05, show_default=True,
              help="Snooping: significance level of the global chi-square test.")
@click.option("--product", "product_kind", default=None,
              help="What was tested, for the statement: e.g. orthoimagery, DEM, DSM.")
@click.option("--gsd-cm", type=_POS, default=None, help="The product's GSD (or cell size), cm, for the statement.")
@click.option("--product-date", type=click.DateTime(formats=["%Y-%m-%d"]), default=None,
              help="The product's date, YYYY-MM-DD, for the statement.")
@click.option("--vertical-datum", default=None,
              help="Vertical datum or geoid of the heights, when the CRS has no vertical part (e.g. 'EGM2008').")
@click.option("--survey-source", default=None,
              help="How the check points were surveyed, for the statement (e.g. 'GNSS RTK, CZEPOS network').")
@click.option("--json", "as_json", is_flag=True, help="Print the JSON result instead of the text summary.")
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Write accuracy.json, accuracy.txt and accuracy.html there.")
def accuracy(points: Path, standard: str, units: str | None, crs: str | None, default_role: str,
             class_h: float | None, class_v: float | None, area_km2: float | None, area_ha: float | None,
             campaign: Path | None, ref_sigma_xy: float | None, ref_sigma_z: float | None, sigma0_h: float | None,
             sigma0_v: float | None, alpha0: float, power: float, max_mdb: float, max_rejected: float, alpha: float,
             product_kind: str | None, gsd_cm: float | None, product_date: datetime | None,
             vertical_datum: str | None, survey_source: str | None, as_json: bool, outdir: Path | None) -> None:
    """Accuracy of a product from its check points, by a standard.

    \b
    Exit codes:
      0  a valid test: the tested class or specification is met, or none was asked
         (figures reported only)
      1  a valid test, and the class or specification is NOT met
      2  bad input (nothing written)
      3  no valid test: NOT TESTED (no independent check points: control points
         show the fit, not the accuracy; too few points for the method to decide;
         an input the standard's statement names is missing: --product, --gsd-cm,
         --product-date, the CRS, the vertical datum, the check point survey's
         accuracy and --survey-source) or INDICATIVE ONLY (too few check points
         for the standard, check points not accurate enough, or the plan's own
         check point rule not met); the reasons are printed
    """
    # imported here, not at the top: the help pages must not load scipy
    from aerosurvey.qa.accuracy_input import read_points
    from aerosurvey.qa.assessment import Settings, assess
    from aerosurvey.qa.campaign import read_campaign
    from aerosurvey.qa.identity import Product
    from aerosurvey.qa.report_html import render
    from aerosurvey.qa.report_text import summary

    if area_km2 is not None and area_ha is not None:
        raise InputError(f"--area-km2 = {area_km2} and --area-ha = {area_ha}: give the project area once")
    pts = read_points(points, units, default_role, crs)
    camp = read_campaign(campaign) if campaign is not None else None
    settings = Settings(standard=standard, class_h_cm=class_h, class_v_cm=class_v,
                        area_km2=area_km2 if area_ha is None else area_ha / 100.0, ref_sigma_xy_m=ref_sigma_xy,
                        ref_sigma_z_m=ref_sigma_z, alpha0=alpha0, power=power, max_mdb=max_mdb,
                        max_rejected=max_rejected, sigma0_h_m=sigma0_h, sigma0_v_m=sigma0_v, alpha=alpha,
                        product=Product(_text(product_kind, "--product"), gsd_cm,
                                        product_date.date().isoformat() if product_date is not None else None,
                                        _text(vertical_datum, "--vertical-datum"),
                                        _text(survey_source, "--survey-source")))
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
    if campaign is not None:  # a campaign block's folder: its QA verdict filed in the register
        from aerosurvey.commands.block_events import record_block_event

        record_block_event(campaign, "qa", "", accuracy=outdir)
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
