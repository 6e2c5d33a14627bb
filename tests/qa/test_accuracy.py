"""Accuracy QA against the published test vectors, and properties of the statistics."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from aerosurvey.cli import main
from aerosurvey.errors import InputError
from aerosurvey.qa import bayes as bz
from aerosurvey.qa import standards
from aerosurvey.qa import statistics as qs
from aerosurvey.qa.points import CheckPoints, read_points
from aerosurvey.qa.snooping import snoop

REF = Path(__file__).resolve().parents[3] / "shared" / "reference"
KUBAD = REF / "kubad_abad_gcp_residuals.csv"


def test_kubad_abad_table_4():
    pts = read_points(KUBAD, default_role="control")
    r = standards.asprs2014(pts, 1.22, None, None)
    assert r["rmse_x_cm"] == pytest.approx(4.063, abs=0.0005)
    assert r["rmse_y_cm"] == pytest.approx(3.324, abs=0.0005)
    assert r["rmse_z_nva_cm"] == pytest.approx(3.288, abs=0.0005)
    assert r["rmse_r_cm"] == pytest.approx(5.249, abs=0.0005)
    assert round(r["horizontal_95_cm"], 2) == 9.09  # the paper prints 9.06: a typo
    assert round(r["nva_95_cm"], 2) == 6.45  # the paper prints 6.49
    warnings = " ".join(r["warnings"])
    assert "14 of 14 points are ground control" in warnings
    assert "14 points, of which 0 independent check points: fewer than 25" in warnings


def test_kubad_cli_writes_reports_and_warns(tmp_path):
    res = CliRunner().invoke(main, ["qa", "accuracy", str(KUBAD), "--role", "control", "--area-km2", "1.22",
                                    "-o", str(tmp_path / "qa")])
    assert res.exit_code == 0, res.output
    assert "+/- 9.09 cm" in res.output and "ground control" in res.output
    html = (tmp_path / "qa" / "accuracy.html").read_text()
    assert "<svg" in html and "Residual vectors" in html
    assert json.loads((tmp_path / "qa" / "accuracy.json").read_text())["rmse_r_cm"] == pytest.approx(5.249, abs=5e-4)


def test_class_test_exit_codes():
    ok = CliRunner().invoke(main, ["qa", "accuracy", str(KUBAD), "--class-h", "5", "--class-v", "5"])
    assert ok.exit_code == 0, ok.output
    bad = CliRunner().invoke(main, ["qa", "accuracy", str(KUBAD), "--class-h", "3"])
    assert bad.exit_code == 1 and "does not meet" in bad.output


def _bayes_rows():
    with open(REF / "bayes_obratan.csv") as fh:
        return list(csv.DictReader(ln for ln in fh if not ln.startswith("#")))


@pytest.mark.parametrize("row", _bayes_rows(), ids=lambda r: r["list"])
def test_bayes_modes_match_the_formula_columns(row):
    # the formula, not the printed table: the two Stage 1 XY values in the source are swapped
    pxy = bz.posterior(2 * int(row["n_position"]), float(row["s_xy_mm"]), 12.0)
    pz = bz.posterior(int(row["n_height"]), float(row["s_z_mm"]), 17.0)
    assert pxy.mode == pytest.approx(float(row["formula_sigma_xy_mm"]), abs=0.1)
    assert pz.mode == pytest.approx(float(row["formula_sigma_z_mm"]), abs=0.1)


@pytest.mark.parametrize("m,s,tau", [(216, 57.0, 12.0), (66, 251.0, 17.0), (154, 40.0, 12.0), (55, 128.0, 17.0)])
def test_credible_interval_against_independent_integration(m, s, tau):
    p = bz.posterior(m, s, tau)
    def logd(x: float) -> float:
        return math.log(x) - (m / 2 + 1) * math.log(x * x + tau * tau) - m * s * s / (2 * (x * x + tau * tau))

    ref = logd(p.mode)
    dens = lambda x: math.exp(logd(x) - ref) if x > 0 else 0.0
    f = dens
    total = integrate.quad(f, 0, np.inf, limit=500, points=None)[0]
    below = integrate.quad(f, 0, p.lower, limit=500)[0] / total
    above = integrate.quad(f, p.upper, np.inf, limit=500)[0] / total
    assert below == pytest.approx(0.025, abs=5e-4)
    assert above == pytest.approx(0.025, abs=5e-4)
    # the mode is where the density peaks
    assert dens(p.mode) >= dens(p.mode * 1.001) and dens(p.mode) >= dens(p.mode * 0.999)


def test_bayes_cli_from_summary_statistics():
    res = CliRunner().invoke(main, ["qa", "bayes", "--points", "108", "--s", "57", "--tau", "12", "--axis", "xy", "--json"])
    assert res.exit_code == 0
    out = json.loads(res.output)
    assert out["m"] == 216 and out["mode"] == pytest.approx(55.59, abs=0.01)
    assert out["ci95"][0] < 55.59 < out["ci95"][1]


def _points(dx, dy, dz=None, ids=None) -> CheckPoints:
    n = len(dx)
    nan = np.full(n, np.nan)
    return CheckPoints(ids or [f"P{i}" for i in range(n)], ["check"] * n, np.asarray(dx, float), np.asarray(dy, float),
                       np.asarray(dz if dz is not None else nan, float), np.zeros(n, bool), nan, nan, nan, nan, "test")


def test_snooping_worked_numbers_and_blunder():
    rng = np.random.default_rng(3)
    dx, dy, dz = rng.normal(0, 1, 9), rng.normal(0, 1, 9), rng.normal(0, 1, 9)
    k = 1.245 / math.sqrt(np.sum(dx**2 + dy**2) / 18)
    dx, dy = dx * k, dy * k
    dz = dz * 0.412 / math.sqrt(np.mean(dz**2))
    s = snoop([f"P{i}" for i in range(9)], dx, dy, dz)
    assert s.sigma_h == pytest.approx(1.245) and s.sigma_v == pytest.approx(0.412)
    assert round(s.threshold_h, 2) == 2.44 and round(s.threshold_v, 2) == 0.89
    # plant a blunder: it is rejected, and one of nine (11 %) is over the 5 % limit
    dx2 = dx.copy()
    dx2[4] = 10.0
    s2 = snoop([f"P{i}" for i in range(9)], dx2, dy, dz)
    assert "P4" in s2.rejected and not s2.passed
    # forty clean points and one blunder: 2.4 % rejected, the set passes
    rng = np.random.default_rng(1)
    ex, ey = rng.normal(0, 0.5, 41), rng.normal(0, 0.5, 41)
    ex[0] = 8.0
    s3 = snoop([f"Q{i}" for i in range(41)], ex, ey, None)
    assert s3.rejected == ["Q0"] and s3.passed
    # the global test against a specification sigma0
    s4 = snoop([f"Q{i}" for i in range(41)], ex, ey, None, sigma0_h=0.2)
    assert s4.global_h is not None and not s4.global_h["passed"] and not s4.passed


def test_circular_error_exact_and_nssda_branches():
    assert qs.circular_error(1.0, 1.0, 0.95) == pytest.approx(2.4477, abs=1e-4)
    assert qs.circular_error(1.0, 1.0, 0.90) == pytest.approx(2.1460, abs=1e-4)
    # very unequal: the exact value lies between the two single-axis 95 % values
    ce = qs.circular_error(1.0, 0.2, 0.95)
    assert 1.96 < ce < 2.4477
    r = standards.nssda(_points([0.1, -0.1, 0.1, -0.1] * 5, [0.02, -0.02, 0.02, -0.02] * 5))
    assert "exact circular error" in r["horizontal_method"]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-5, 5), min_size=3, max_size=60), st.floats(0.1, 10))
def test_statistics_properties(values, k):
    e = np.asarray(values)
    s = qs.axis_stats(e)
    assert s["rmse"] == pytest.approx(float(np.sqrt(np.mean(e**2))), abs=1e-12)
    assert s["abs_p95"] == pytest.approx(float(np.percentile(np.abs(e), 95)), abs=1e-12)
    # the order of the points does not matter
    s2 = qs.axis_stats(e[::-1].copy())
    assert s2["rmse"] == pytest.approx(s["rmse"]) and s2["abs_p90"] == pytest.approx(s["abs_p90"])
    # scaling the residuals scales the results
    s3 = qs.axis_stats(e * k)
    assert s3["rmse"] == pytest.approx(k * s["rmse"], rel=1e-9, abs=1e-12)
    assert s3["abs_p50"] == pytest.approx(k * s["abs_p50"], rel=1e-9, abs=1e-12)


def test_asprs2023_adds_the_survey_error():
    pts = read_points(KUBAD, units=None)
    r = standards.asprs2023(pts, None, None, None, survey_rmse_h=0.02, survey_rmse_v=0.01)
    assert r["rmse_h_cm"] == pytest.approx(math.hypot(5.249, 2.0), abs=1e-3)
    assert r["rmse_v_cm"] == pytest.approx(math.hypot(3.288, 1.0), abs=1e-3)
    assert r["rmse_3d_cm"] == pytest.approx(math.hypot(r["rmse_h_cm"], r["rmse_v_cm"]), abs=1e-3)
    assert r["required_check_points"] == 30
    assert any("fewer than 30" in w for w in r["warnings"])


@pytest.mark.parametrize("content,needle", [
    ("id,dx,dz\nA,1,2\n", "needs residual columns"),
    ("id,dx,dy\nA,1,x\n", "'x' is not a number"),
    ("id,dx,dy\nA,1,2\nA,2,3\n", "duplicate id(s) A"),
    ("id,dx_cm,dy_mm\nA,1,2\n", "mixed units"),
    ("name_of_point,dx,dy\nA,1,2\n", "no id column"),
])
def test_bad_point_files(tmp_path, content, needle):
    p = tmp_path / "pts.csv"
    p.write_text(content)
    with pytest.raises(InputError, match=needle.replace("(", r"\(").replace(")", r"\)")):
        read_points(p)
    res = CliRunner().invoke(main, ["qa", "accuracy", str(p)])
    assert res.exit_code == 2


def test_coordinates_and_geojson_input(tmp_path):
    p = tmp_path / "pts.geojson"
    feats = [{"type": "Feature", "properties": {"id": f"C{i}", "x": 10 + 0.01 * i, "y": 20.0, "z": 5.0, "role": "CP"},
              "geometry": {"type": "Point", "coordinates": [10.0, 20.0, 5.02]}} for i in range(5)]
    p.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    pts = read_points(p)
    assert pts.dx == pytest.approx([0.0, 0.01, 0.02, 0.03, 0.04])
    assert pts.dz == pytest.approx([-0.02] * 5)
    assert pts.role == ["check"] * 5
