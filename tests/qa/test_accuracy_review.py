"""The reviewer's warnings, and linking a test to its plan with --campaign."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from qa_accuracy_helpers import STATEMENT_ARGS, make_points, planned_square, product

from aerosurvey.cli import main
from aerosurvey.qa.assessment import Settings, assess
from aerosurvey.qa.campaign import read_campaign


def _grid(n_side: int = 6, size: float = 600.0) -> tuple[np.ndarray, np.ndarray]:
    g = (np.arange(n_side) + 0.5) * size / n_side
    x, y = np.meshgrid(g, g)
    return x.ravel() + 500000.0, y.ravel() + 5470000.0


def _residuals(n: int, seed: int = 0, s: float = 0.03) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.normal(0, s, n), rng.normal(0, s, n), rng.normal(0, s, n)


def test_clean_well_spread_set_has_no_warnings() -> None:
    x, y = _grid()
    dx, dy, dz = _residuals(len(x))
    r = assess(make_points(dx, dy, dz, x=x, y=y, crs="EPSG:32633"), Settings(standard="asprs2014", area_km2=0.36))
    assert [w for w in r["warnings"] if "VVA" not in w] == []


def test_clustered_points_are_flagged() -> None:
    x, y = _grid(8)
    keep = ~((x > 500300) & (y > 5470300))  # an L: nothing in the north-east quadrant
    x, y = x[keep], y[keep]
    dx, dy, dz = _residuals(len(x))
    r = assess(make_points(dx, dy, dz, x=x, y=y, crs="EPSG:32633"), Settings(standard="asprs2014"))
    assert any("clustered" in w and "NE 0 %" in w for w in r["warnings"])
    close = make_points(dx[:5], dy[:5], dz[:5], x=[0, 1, 300, 0, 300], y=[0, 0, 0, 300, 300], crs="EPSG:32633")
    r = assess(close, Settings(standard="nssda"))
    assert any("closer than 10 % of the diagonal" in w and "P1-P2" in w for w in r["warnings"])


def test_bias_outlier_and_single_point_dependence() -> None:
    x, y = _grid()
    dx, dy, dz = _residuals(len(x), seed=3)
    r = assess(make_points(dx, dy, dz + 0.05, x=x, y=y), Settings(standard="asprs2014"))
    assert any(w.startswith("significant bias in z") for w in r["warnings"])
    dx2 = dx.copy()
    dx2[7] = 0.6  # a blunder: flagged and kept (it is in the RMSE), and the RMSE rests on it
    points = make_points(dx2, dy, dz, x=x, y=y, crs="EPSG:32633")
    r = assess(points, Settings(standard="asprs2014", class_h_cm=10, ref_sigma_xy_m=0.005, ref_sigma_z_m=0.008,
                                product=product()))
    assert r["verdict"]["status"] == "valid"
    assert any("outliers in x" in w and "P8" in w for w in r["warnings"])
    assert r["result"]["rmse_x_m"] == pytest.approx(np.sqrt(np.mean(dx2**2)))
    assert "outlier_x" in next(p for p in r["points"] if p["id"] == "P8")["flags"]
    assert any("depends on one point: without P8" in w for w in r["warnings"])
    assert any("verdict rests on single points" in w and "P8" in w for w in r["warnings"])
    # a result without a verdict (the statement's inputs not given: not tested) has none to rest on one point
    r = assess(points, Settings(standard="asprs2014", class_h_cm=10))
    assert r["verdict"]["status"] == "not tested" and not any("verdict rests" in w for w in r["warnings"])
    assert any("depends on one point: without P8" in w for w in r["warnings"])  # the RMSE does


def test_survey_not_accurate_enough() -> None:
    dx, dy, dz = _residuals(30, seed=5, s=0.02)
    r = assess(make_points(dx, dy, dz), Settings(standard="asprs2014", class_h_cm=3, ref_sigma_xy_m=0.015))
    assert any("not 3x more accurate" in w for w in r["warnings"])


def test_mixed_roles_test_only_the_check_points() -> None:
    dx, dy, dz = _residuals(25, seed=6)
    roles = ["control"] * 5 + ["check"] * 20
    r = assess(make_points(dx, dy, dz, roles=roles), Settings(standard="asprs2014"))
    assert r["input"]["tested"] == 20
    assert r["result"]["rmse_x_m"] == pytest.approx(np.sqrt(np.mean(dx[5:] ** 2)))
    assert any("5 of 25 points are ground control" in w and "left out" in w for w in r["warnings"])
    assert sum(not p["tested"] for p in r["points"]) == 5


def _campaign(folder: Path, proposed: dict[str, str]) -> Path:
    """A plan folder as `aerosurvey plan` + `aerosurvey gcp` write it: 36 ha planned at 2 cm."""
    planned_square(folder, 600.0, "grid test")
    (folder / "control_points.csv").write_text(
        "id,role,easting,northing,lat,lon,crs,target_size_cm,images,note\n"
        + "".join(f"{k},{v},0,0,0,0,EPSG:32633,7,10,\n" for k, v in proposed.items()))
    return folder


def test_campaign_links_area_layout_and_gsd(tmp_path: Path) -> None:
    x, y = _grid()
    x = 500000 + (x - 500000) / 2  # all in the western half of the planned area
    y = 5470000 + (y - 5470000) / 2
    dx, dy, dz = _residuals(len(x), seed=7, s=0.02)
    proposed = {f"P{i}": "check" for i in range(1, 40)} | {"P1": "GCP", "G1": "GCP"}
    proposed = {k: ("control" if v == "GCP" else v) for k, v in proposed.items()}
    camp = _campaign(tmp_path / "plan", {k: ("GCP" if v == "control" else "CP") for k, v in proposed.items()})
    c = read_campaign(camp)
    photos = json.loads((camp / "manifest.json").read_text())["estimates"]["photos"]
    assert c.area_km2 == pytest.approx(0.36) and c.proposed["P1"] == "control" and c.photos == photos > 100
    r = assess(make_points(dx, dy, dz, x=x, y=y, crs="EPSG:32633"), Settings(standard="asprs2014"), c)
    assert r["area_km2"] == pytest.approx(0.36) and r["required_check_points"]["horizontal"] == 20
    assert any("proposed by the plan's layout as GCPs (P1)" in w for w in r["warnings"])
    assert r["input"]["tested"] == 35  # P1 moved to control
    assert any("quadrant of the project area" in w for w in r["warnings"])  # compared with the planned area
    assert any("P37, P38, P39" in n and "not in the file" in n for n in r["notes"])
    assert r["statistics"]["horizontal"]["rmse_r_gsd"] == pytest.approx(
        r["statistics"]["horizontal"]["rmse_r_m"] / 0.02)
    csv_path = tmp_path / "pts.csv"
    csv_path.write_text("id,dx,dy,dz,x_ref,y_ref\n" + "".join(
        f"P{i + 1},{a},{b},{c_},{u},{v}\n" for i, (a, b, c_, u, v) in enumerate(zip(dx, dy, dz, x, y))))
    res = CliRunner().invoke(main, ["qa", "accuracy", str(csv_path), "--campaign", str(camp), *STATEMENT_ARGS])
    assert res.exit_code == 0, res.output
    assert "x the planned GSD of 2 cm (grid test)" in res.output
    nope = CliRunner().invoke(main, ["qa", "accuracy", str(csv_path), "--campaign", str(tmp_path)])
    assert nope.exit_code == 2 and "manifest.json is missing" in nope.output


def test_outlier_rule_needs_both_tests() -> None:
    from aerosurvey.qa import statistics as st
    # a two-humped dozen: the MAD alone would flag -3.3, but it is not far from the others
    assert not st.outliers(np.array([-3.3, -2.4, -0.3, -0.1, 0.0, 0.2, 0.6, 0.7, 0.8, 2.7, 2.7])).any()
    e = np.array([0.1, -0.2, 0.15, -0.05, 0.0, 0.12, -0.1, 2.0, np.nan])
    assert list(st.outliers(e)) == [False] * 7 + [True, False]
    assert list(st.outliers(np.array([1.0] * 10 + [5.0]))) == [False] * 10 + [True]  # MAD = 0
