"""Cadastral data snooping (the Hellenic Cadastre orthoimage paper, ISPRS Archives XXXV (2004)): worked thresholds,
a planted blunder, the 5 % limit, the global test."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from qa_accuracy_helpers import make_points
from scipy import stats

from aerosurvey.cli import main
from aerosurvey.qa.assessment import Settings, assess
from aerosurvey.qa.snooping import snoop

# nine points of similar size (the source's test had nine), scaled below to its sigmas
DX = np.array([0.9, -1.1, 1.3, -0.8, 1.0, -1.2, 1.4, -1.5, 0.7])
DY = np.array([-1.0, 1.2, -0.6, 1.1, -1.3, 0.9, -0.8, 1.0, -1.2])
DZ = np.array([0.5, -0.4, 0.3, -0.6, 0.45, -0.35, 0.4, -0.5, 0.3])


def _source_set() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    k = 1.245 / math.sqrt(float(np.sum(DX**2 + DY**2)) / 18)
    return DX * k, DY * k, DZ * 0.412 / math.sqrt(float(np.mean(DZ**2)))


def test_worked_thresholds_of_the_source() -> None:
    dx, dy, dz = _source_set()
    s = snoop(dx, dy, dz)
    assert s.sigma_h == pytest.approx(1.245) and s.sigma_v == pytest.approx(0.412)
    assert s.threshold_v is not None
    assert round(s.threshold_h, 2) == 2.44 and round(s.threshold_v, 2) == 0.89
    assert not s.rejected.any() and s.passed  # as in the source: no point had to be rejected


def test_planted_blunder_is_rejected_and_fails_nine_points() -> None:
    dx, dy, dz = _source_set()
    dx[4] = 9.0
    s = snoop(dx, dy, dz)
    assert list(np.flatnonzero(s.rejected)) == [4]
    assert s.rejected_share == pytest.approx(1 / 9) and not s.share_ok and not s.passed
    # sigma is recomputed on the eight kept points
    keep = np.arange(9) != 4
    assert s.sigma_h_kept == pytest.approx(math.sqrt(float(np.sum(dx[keep] ** 2 + dy[keep] ** 2)) / 16))
    # a height blunder alone is caught by the vertical test
    dx, dy, dz = _source_set()
    dz[2] = 3.0
    s = snoop(dx, dy, dz)
    assert list(np.flatnonzero(s.rejected_v)) == [2] and not s.rejected_h.any()


def test_five_percent_limit() -> None:
    rng = np.random.default_rng(1)
    ex, ey = rng.uniform(-1, 1, 41), rng.uniform(-1, 1, 41)  # |e| <= 1.73 rms: nothing to reject
    clean = snoop(ex, ey)
    assert not clean.rejected.any()
    ex[0] = 8.0  # 1 of 41 = 2.4 %: allowed
    one = snoop(ex, ey)
    assert one.rejected.sum() == 1 and one.share_ok and one.passed
    ex[1], ey[2] = -8.0, 7.5  # 3 of 41 = 7.3 %: fails
    three = snoop(ex, ey)
    assert three.rejected.sum() == 3 and not three.share_ok and not three.passed
    # the limit and the factors are settings
    assert snoop(ex, ey, max_share=0.10).passed
    assert snoop(ex, ey, k_h=100.0).rejected.sum() == 0


def test_global_chi_square_test() -> None:
    rng = np.random.default_rng(4)
    ex, ey = rng.uniform(-0.5, 0.5, 50), rng.uniform(-0.5, 0.5, 50)  # sigma about 0.29, nothing rejected
    s = snoop(ex, ey, sigma0_h=0.35)
    g = s.global_h
    assert g is not None and s.sigma_h_kept is not None
    f = 2 * int((~s.rejected).sum())
    assert g["dof"] == f and g["statistic"] == pytest.approx(f * s.sigma_h_kept**2 / 0.35**2)
    assert g["limit"] == pytest.approx(stats.chi2.ppf(0.95, f)) and g["passed"] and s.passed
    tight = snoop(ex, ey, sigma0_h=0.2)
    assert tight.global_h is not None and not tight.global_h["passed"] and not tight.passed


def test_snooping_standard_and_cli(tmp_path: Path) -> None:
    dx, dy, dz = _source_set()
    dx[4] = 9.0
    r = assess(make_points(dx, dy, dz), Settings(standard="snooping"))
    assert r["result"]["rejected"] == ["P5"] and r["passed"] is False
    assert "P5" in r["sentences"][0] and "the data set fails" in r["sentences"][0]
    assert "snooping_rejected" in next(p for p in r["points"] if p["id"] == "P5")["flags"]
    path = tmp_path / "pts.csv"
    dx, dy, dz = _source_set()
    path.write_text("id,dx,dy,dz\n" + "".join(f"Q{i},{a},{b},{c}\n" for i, (a, b, c) in enumerate(zip(dx, dy, dz))))
    ok = CliRunner().invoke(main, ["qa", "accuracy", str(path), "--standard", "snooping"])
    assert ok.exit_code == 0, ok.output
    assert "thresholds 2.44 m horizontal" in ok.output and "0.89 m vertical" in ok.output
    bad = CliRunner().invoke(main, ["qa", "accuracy", str(path), "--standard", "snooping", "--sigma0-h", "0.5"])
    assert bad.exit_code == 1 and "Global test (horizontal)" in bad.output
