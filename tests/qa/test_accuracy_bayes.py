"""Bayesian estimate (Zaoralová et al., land consolidation terms paper): modes against the formula columns, credible
intervals against an independent numerical integration done here."""

from __future__ import annotations

import csv
import json
import math
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner
from qa_accuracy_helpers import OBRATAN, make_points, scaled_to
from scipy import integrate, optimize

from aerosurvey.cli import main
from aerosurvey.qa import bayes as bz
from aerosurvey.qa.assessment import Settings, assess


def _rows() -> list[dict[str, str]]:
    with open(OBRATAN, encoding="utf-8") as fh:
        return list(csv.DictReader(ln for ln in fh if not ln.startswith("#")))


def _taus() -> tuple[float, float]:
    """The reference survey's σ as the CSV's header states them."""
    head = OBRATAN.read_text(encoding="utf-8")
    mx = re.search(r"sigma_xy_ref = ([\d.]+) mm", head)
    mz = re.search(r"sigma_z_ref = ([\d.]+) mm", head)
    assert mx is not None and mz is not None
    return float(mx.group(1)), float(mz.group(1))


def _cases() -> list[tuple[str, int, float, float, float, float, float]]:
    """(name, m, s, tau, formula mode, published mode, published ±) per list and axis."""
    txy, tz = _taus()
    out = []
    for r in _rows():
        out.append((r["list"] + "-xy", 2 * int(r["n_position"]), float(r["s_xy_mm"]), txy,
                    float(r["formula_sigma_xy_mm"]), float(r["published_sigma_xy_mm"]), float(r["published_ci_xy_mm"])))
        out.append((r["list"] + "-z", int(r["n_height"]), float(r["s_z_mm"]), tz,
                    float(r["formula_sigma_z_mm"]), float(r["published_sigma_z_mm"]), float(r["published_ci_z_mm"])))
    return out


CASES = _cases()


def _unnormalised(m: int, s: float, tau: float) -> Callable[[float], float]:
    """Formula (1) of the source without its constant, written out again here on purpose."""
    def f(x: float) -> float:
        if x <= 0:
            return 0.0
        v = x * x + tau * tau
        return math.exp(math.log(x) - (m / 2 + 1) * math.log(v) - m * s * s / (2 * v) + (m / 2) * math.log(s * s))
    return f


def _integrate(f: Callable[[float], float], a: float, b: float, peak: float) -> float:
    pts = [p for p in (peak,) if a < p < b]
    return float(integrate.quad(f, a, b, points=pts or None, limit=500, epsabs=0, epsrel=1e-11)[0])


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_mode_equals_formula_column(case: Any) -> None:
    # the formula column, not the printed table: the source's two Stage 1 XY values are swapped
    name, m, s, tau, formula, _, _ = case
    assert bz.mode(m, s, tau) == pytest.approx(formula, abs=0.1)
    # and the mode is where the (independently written) density peaks
    f = _unnormalised(m, s, tau)
    peak = optimize.minimize_scalar(lambda x: -f(x), bounds=(s * 0.3, s * 1.5), method="bounded",
                                    options={"xatol": 1e-9}).x
    assert bz.mode(m, s, tau) == pytest.approx(peak, abs=1e-4)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_credible_interval_against_quad(case: Any) -> None:
    name, m, s, tau, _, _, _ = case
    p = bz.posterior(m, s, tau)
    f = _unnormalised(m, s, tau)
    top = 20 * s  # the posterior is negligible beyond this (it falls off like sigma^-(m+1))
    total = _integrate(f, 0, top, p.mode)
    below = _integrate(f, 0, p.lower, p.mode) / total
    above = _integrate(f, p.upper, top, p.mode) / total
    assert below == pytest.approx(0.025, abs=1e-6)
    assert above == pytest.approx(0.025, abs=1e-6)
    # the normalised density the report plots integrates to 1 and matches f / total pointwise
    xs = np.linspace(p.lower, p.upper, 7)
    assert bz.density(xs, m, s, tau) == pytest.approx([f(x) / total for x in xs], rel=1e-7)


def test_published_intervals_are_close_to_ours() -> None:
    """The source's '±' is not reproduced exactly (its interval definition is not stated);
    after undoing the swapped Stage 1 XY rows, our 95 % half-widths lie within 5 % of it."""
    ours = {c[0]: bz.posterior(c[1], c[2], c[3]).half_width for c in CASES}
    published = {c[0]: c[6] for c in CASES}
    published["stage1_one_way-xy"], published["stage1_both_ways-xy"] = (published["stage1_both_ways-xy"],
                                                                        published["stage1_one_way-xy"])
    for k in ours:
        assert ours[k] == pytest.approx(published[k], rel=0.05), k


def test_tau_zero_is_the_classical_case() -> None:
    # tau = 0: sigma^2 | s ~ m s^2 / chi2(m), so the interval is the chi-square one
    from scipy import stats
    m, s = 40, 3.0
    p = bz.posterior(m, s, 0.0)
    assert p.lower == pytest.approx(math.sqrt(m * s * s / stats.chi2.ppf(0.975, m)), rel=1e-9)
    assert p.upper == pytest.approx(math.sqrt(m * s * s / stats.chi2.ppf(0.025, m)), rel=1e-9)


def test_bayes_cli_from_summary_statistics(tmp_path: Path) -> None:
    res = CliRunner().invoke(main, ["qa", "bayes", "--points", "108", "--s", "57", "--tau", "12", "--axis", "xy",
                                    "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    p = bz.posterior(216, 57.0, 12.0)
    assert out["m"] == 216 and out["mode"] == pytest.approx(55.59, abs=0.005)
    assert (out["ci_lower"], out["ci_upper"]) == pytest.approx((p.lower, p.upper))
    z = CliRunner().invoke(main, ["qa", "bayes", "--points", "66", "--s", "251", "--tau", "17", "--axis", "z",
                                  "--class", "240", "--unit", "mm", "-o", str(tmp_path / "b")])
    assert z.exit_code == 1 and "248.55 mm" in z.output  # mode above the 240 mm class
    html = (tmp_path / "b" / "bayes.html").read_text()
    assert "Posterior density" in html and "<polyline" in html
    bad = CliRunner().invoke(main, ["qa", "bayes", "--points", "0", "--s", "5", "--tau", "1"])
    assert bad.exit_code == 2


def test_bayes_standard_from_points() -> None:
    rng = np.random.default_rng(11)
    n = 60
    dx, dy = scaled_to(rng.normal(size=n), 0.05), scaled_to(rng.normal(size=n), 0.05)
    dz = scaled_to(rng.normal(size=n), 0.10)
    pts = make_points(dx, dy, dz)
    r = assess(pts, Settings(standard="bayes", ref_sigma_xy_m=0.012, ref_sigma_z_m=0.017, class_h_cm=5.5))
    s_xy = math.sqrt(float(np.sum(dx**2 + dy**2)) / (2 * n))
    assert s_xy == pytest.approx(0.05)
    assert r["result"]["xy"]["m"] == 2 * n and r["result"]["z"]["m"] == n
    assert r["result"]["xy"]["mode_m"] == pytest.approx(bz.mode(2 * n, 0.05, 0.012))
    assert r["result"]["z"]["mode_m"] == pytest.approx(bz.mode(n, 0.10, 0.017))
    assert r["result"]["xy"]["probability_within_class"] == pytest.approx(bz.cdf(0.055, 2 * n, 0.05, 0.012))
    assert r["passed"] is True and r["posterior"]["axis"] == "xy"
    # per-point sigma columns stand in for --ref-sigma-xy (their RMS)
    pts2 = make_points(dx, dy, dz, sigma_xy=np.full(n, 0.012))
    r2 = assess(pts2, Settings(standard="bayes"))
    assert r2["result"]["xy"]["mode_m"] == pytest.approx(r["result"]["xy"]["mode_m"])
    with pytest.raises(ValueError, match="reference survey"):
        assess(pts, Settings(standard="bayes"))
