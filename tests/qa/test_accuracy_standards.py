"""ASPRS 2014 and 2023, NSSDA: the rules, the counts by area, the circular error."""

from __future__ import annotations

import csv
import math
from typing import Any

import numpy as np
import pytest
from qa_accuracy_helpers import COUNTS_2014, make_points, product, scaled_to

from aerosurvey.qa import asprs, nssda
from aerosurvey.qa import statistics as st
from aerosurvey.qa.assessment import Settings, assess


def test_required_counts_2014_match_the_reference_table() -> None:
    with open(COUNTS_2014, encoding="utf-8") as fh:
        rows = list(csv.DictReader(ln for ln in fh if not ln.startswith("#")))
    previous = 0.0
    for r in rows:
        top = float(r["area_max_km2"])
        for area in (previous + 1e-6, (previous + top) / 2, top):
            req = asprs.required_2014(area)
            assert (req.horizontal, req.nva, req.vva) == (int(r["horizontal_total"]), int(r["vertical_nva"]),
                                                          int(r["vertical_vva"])), area
        previous = top
    beyond = asprs.required_2014(3400)  # two more 500 km2 blocks: +3 NVA and +2 VVA each
    assert (beyond.horizontal, beyond.nva, beyond.vva) == (60, 61, 49)
    assert asprs.required_2014(None).horizontal == 20


def test_required_counts_2023() -> None:
    assert asprs.required_2023(None).horizontal == 30
    assert asprs.required_2023(0.72).horizontal == 30
    assert asprs.required_2023(600).horizontal == 35
    assert asprs.required_2023(2500).horizontal == 70
    big = asprs.required_2023(9000)
    assert big.horizontal <= asprs.MAX_CHECK_POINTS_2023 and "120" in big.note


def test_asprs2014_vva_and_classes() -> None:
    rng = np.random.default_rng(2)
    n = 40
    veg = np.arange(n) % 4 == 0
    dz = np.where(veg, rng.normal(0, 0.12, n), rng.normal(0, 0.04, n))
    dx, dy = rng.normal(0, 0.03, n), rng.normal(0, 0.03, n)
    r = asprs.evaluate_2014(dx, dy, dz, veg, class_v_cm=5)
    assert r["vva_95_m"] == pytest.approx(np.percentile(np.abs(dz[veg]), 95))
    assert r["rmse_z_nva_m"] == pytest.approx(math.sqrt(np.mean(dz[~veg] ** 2)))
    assert r["vertical_checks"]["VVA 95th percentile"] == (r["vva_95_m"] <= 0.15 + 1e-12)
    assert "Actual VVA accuracy was found to be +/-" in r["sentences"][-1]
    # the class met is the smallest common class at least as large as every rule's X
    x = max(r["smallest_x_horizontal_m"], 1e-9) * 100
    assert r["horizontal_class_cm"] == min(c for c in asprs.HORIZONTAL_CLASSES_2014_CM if c >= x - 1e-9)


def test_asprs2023_product_accuracy_includes_the_survey() -> None:
    rng = np.random.default_rng(3)
    n = 35
    dx, dy, dz = (scaled_to(rng.normal(size=n), v) for v in (0.03, 0.04, 0.05))
    r = asprs.evaluate_2023(dx, dy, dz, np.zeros(n, bool), survey_xy_m=0.01, survey_z_m=0.02, class_h_cm=6,
                            class_v_cm=5)
    assert r["rmse_h_fit_m"] == pytest.approx(0.05)
    assert r["rmse_h_survey_m"] == pytest.approx(0.01 * math.sqrt(2))
    assert r["rmse_h_m"] == pytest.approx(math.sqrt(0.05**2 + 2 * 0.01**2))
    assert r["rmse_v_m"] == pytest.approx(math.hypot(0.05, 0.02))
    assert r["rmse_3d_m"] == pytest.approx(math.hypot(r["rmse_h_m"], r["rmse_v_m"]))
    assert r["horizontal_met"] and not r["vertical_met"] and r["passed"] is False  # 5.39 cm > 5 cm
    assert not any("95" in s for s in r["sentences"])  # Edition 2 reports RMSE only


@pytest.mark.parametrize("fit_cm,product_cm", [(1.00, 2.24), (1.50, 2.50), (2.00, 2.83), (5.00, 5.39)])
def test_asprs2023_vertical_rows_of_table_7_4(fit_cm: Any, product_cm: Any) -> None:
    """Rows of Edition 2 Table 7.4 (2.0 cm check point survey) as transcribed by a secondary
    source (see qa/asprs.py): the combination formula reproduces them to the printed 0.01 cm."""
    dz = np.array([fit_cm, -fit_cm]) / 100
    r = asprs.evaluate_2023(np.zeros(2), np.zeros(2), dz, np.zeros(2, bool), None, 0.02)
    assert round(r["rmse_v_m"] * 100, 2) == product_cm


def test_asprs2023_missing_survey_is_not_tested() -> None:
    rng = np.random.default_rng(8)
    pts = make_points(rng.normal(0, 0.02, 30), rng.normal(0, 0.02, 30), rng.normal(0, 0.03, 30), crs="EPSG:32633")
    r = assess(pts, Settings(standard="asprs2023", product=product()))
    assert r["verdict"]["status"] == "not tested"
    assert any("the check point survey's horizontal accuracy (--ref-sigma-xy or sigma_xy)" in x
               for x in r["verdict"]["reasons"])
    assert "the check point survey's accuracy is not given" in r["sentences"][0]
    assert any("not confirmed" in n for n in r["notes"])


def test_nssda_ratio_branches() -> None:
    e = np.array([1.0, -1.0, 1.0, -1.0] * 5)
    eq = nssda.evaluate(0.1 * e, 0.1 * e, 0.2 * e)
    assert eq["horizontal_95_m"] == pytest.approx(1.7308 * math.hypot(0.1, 0.1))
    assert eq["vertical_95_m"] == pytest.approx(1.96 * 0.2)
    assert eq["sentences"] == ["Tested 0.245 meters horizontal accuracy at 95% confidence level",
                               "Tested 0.392 meters vertical accuracy at 95% confidence level"]
    mid = nssda.evaluate(0.1 * e, 0.08 * e, np.full(20, np.nan))
    assert mid["horizontal_95_m"] == pytest.approx(2.4477 * 0.5 * 0.18) and "approximation" in mid["horizontal_method"]
    far = nssda.evaluate(0.1 * e, 0.02 * e, np.full(20, np.nan))
    assert far["horizontal_95_m"] == pytest.approx(st.circular_error(0.1, 0.02, 0.95))
    assert "exact circular error" in far["horizontal_method"]
    assert nssda.evaluate(0.1 * e, 0.1 * e, 0.2 * e, max_h95_cm=24)["passed"] is False
    assert nssda.evaluate(0.1 * e, 0.1 * e, 0.2 * e, max_h95_cm=25, max_v95_cm=40)["passed"] is True


def test_circular_error_exact() -> None:
    for p in (0.5, 0.9, 0.95):
        assert st.circular_error(2.0, 2.0, p) == pytest.approx(2.0 * math.sqrt(-2 * math.log(1 - p)), rel=1e-9)
    assert st.circular_error(1.0, 0.0, 0.95) == pytest.approx(1.959964, rel=1e-6)
    rng = np.random.default_rng(9)
    for sx, sy in ((1.0, 0.5), (0.3, 1.0), (1.0, 0.05)):
        r = np.hypot(rng.normal(0, sx, 400_000), rng.normal(0, sy, 400_000))
        assert st.circular_error(sx, sy, 0.95) == pytest.approx(np.quantile(r, 0.95), rel=5e-3)
        assert st.circular_error(sx, sy, 0.90) == pytest.approx(np.quantile(r, 0.90), rel=5e-3)
