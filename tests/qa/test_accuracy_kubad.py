"""ASPRS 2014 on the Kubad Abad GCP residuals (shared/papers/000 Table 4): the issue's numbers and warnings."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from qa_accuracy_helpers import KUBAD

from aerosurvey.cli import main
from aerosurvey.qa.accuracy_input import read_points
from aerosurvey.qa.assessment import Settings, assess


def _kubad(**kw):
    return assess(read_points(KUBAD, default_role="control"), Settings(standard="asprs2014", **kw))


def test_kubad_abad_figures():
    r = _kubad(area_km2=1.22)
    res = r["result"]
    assert res["rmse_x_m"] * 100 == pytest.approx(4.063, abs=5e-4)
    assert res["rmse_y_m"] * 100 == pytest.approx(3.324, abs=5e-4)
    assert res["rmse_z_nva_m"] * 100 == pytest.approx(3.288, abs=5e-4)
    assert res["rmse_r_m"] * 100 == pytest.approx(5.249, abs=5e-4)
    assert round(res["horizontal_95_m"] * 100, 2) == 9.09  # the paper prints 9.06 (1.7308 x a truncated 5.24)
    assert round(res["nva_95_m"] * 100, 2) == 6.45  # the paper prints 6.49
    assert r["statistics"]["rmse_3d_m"] * 100 == pytest.approx(6.19432, abs=5e-5)  # the paper's "total" (Table 3)
    assert res["vva_95_m"] is None  # no vegetated points: no VVA (the paper's 9.87 is 3 x RMSE_z, a class limit)
    assert res["horizontal_class_cm"] == 5.0 and res["vertical_class_cm"] == 5.0  # the paper's "5 (cm)" classes
    # the sentence carries our numbers, not the paper's
    assert "RMSE_x = 4.06 cm and RMSE_y = 3.32 cm" in r["sentences"][0]
    assert "+/- 9.09 cm at 95 % confidence level" in r["sentences"][0]
    assert "RMSE_z = 3.29 cm, equating to +/- 6.45 cm" in r["sentences"][1]


def test_kubad_abad_warnings_control_points_and_count():
    r = _kubad(area_km2=1.22)
    w = "\n".join(r["warnings"])
    assert "14 of 14 points are ground control used in the adjustment" in w
    assert "no independent check points" in w
    assert "too few check points: 14 < 20" in w
    assert r["input"]["control_points"] == 14 and r["input"]["check_points"] == 0


def test_kubad_abad_unequal_rmse_note():
    # RMSE_x != RMSE_y: the report names the NSSDA approximation and the exact CE95 beside 1.7308 RMSE_r
    r = _kubad()
    res = r["result"]
    assert res["horizontal_95_nssda_m"] == pytest.approx(2.4477 * 0.5 * (res["rmse_x_m"] + res["rmse_y_m"]))
    assert round(res["horizontal_95_nssda_m"] * 100, 2) == 9.04  # what the paper's report sentence prints
    rng = np.random.default_rng(5)
    r_mc = np.hypot(rng.normal(0, res["rmse_x_m"], 400_000), rng.normal(0, res["rmse_y_m"], 400_000))
    assert res["ce95_exact_m"] == pytest.approx(np.quantile(r_mc, 0.95), rel=5e-3)
    assert any("RMSE_x and RMSE_y differ" in n for n in r["notes"])


def test_kubad_class_tests():
    assert _kubad(class_h_cm=5, class_v_cm=5)["passed"] is True
    r = _kubad(class_h_cm=4)  # RMSE_x = 4.063 cm > 4 cm
    assert r["passed"] is False
    assert r["result"]["horizontal_checks"] == {"RMSE_x": False, "RMSE_y": True, "RMSE_r": True, "95 %": True}
    assert "and does not meet it" in r["sentences"][0]
    assert _kubad(class_v_cm=3.2)["passed"] is False  # RMSE_z = 3.288 cm


def test_kubad_cli_report_files_and_exit_codes(tmp_path):
    out = tmp_path / "qa"
    res = CliRunner().invoke(main, ["qa", "accuracy", str(KUBAD), "--role", "control", "--area-km2", "1.22",
                                    "--standard", "asprs2014", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "+/- 9.09 cm" in res.output and "ground control" in res.output and "14 < 20" in res.output
    data = json.loads((out / "accuracy.json").read_text())
    assert data["result"]["rmse_r_m"] * 100 == pytest.approx(5.249, abs=5e-4)
    html = (out / "accuracy.html").read_text()
    assert html.count("<svg") >= 4 and "Residual vectors" in html and "Histograms" in html
    assert "<script" not in html and "http://" not in html.replace("http://www.w3.org/2000/svg", "")
    assert (out / "accuracy.txt").read_text().startswith("Accuracy QA of kubad_abad_gcp_residuals.csv")
    failed = CliRunner().invoke(main, ["qa", "accuracy", str(KUBAD), "--class-h", "4"])
    assert failed.exit_code == 1 and "RESULT: NOT met" in failed.output
    js = CliRunner().invoke(main, ["qa", "accuracy", str(KUBAD), "--json", "--class-h", "5", "--class-v", "5"])
    assert js.exit_code == 0 and json.loads(js.output)["passed"] is True
