"""Shared helpers for the accuracy QA tests (not a test module)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.qa.accuracy_input import CheckPoints

REF = Path(__file__).resolve().parents[3] / "shared" / "reference"
KUBAD = REF / "kubad_abad_gcp_residuals.csv"
OBRATAN = REF / "bayes_obratan.csv"
COUNTS_2014 = REF / "asprs2014_checkpoint_counts.csv"


def make_points(dx: Any, dy: Any, dz: Any = None, x: Any = None, y: Any = None, ids: Any = None, roles: Any = None,
                vegetated: Any = None, sigma_xy: Any = None, sigma_z: Any = None, crs: str | None = None) -> CheckPoints:
    n = len(dx)
    nan = np.full(n, np.nan)

    def arr(v: Any) -> np.ndarray:
        return nan.copy() if v is None else np.asarray(v, float)

    return CheckPoints(tuple(ids or [f"P{i + 1}" for i in range(n)]), tuple(roles or ["check"] * n),
                       np.asarray(dx, float), np.asarray(dy, float), arr(dz),
                       np.zeros(n, bool) if vegetated is None else np.asarray(vegetated, bool), arr(x), arr(y),
                       arr(sigma_xy), arr(sigma_z), "test", "m", True, crs, False)


def scaled_to(e: np.ndarray, rms: float) -> np.ndarray:
    """`e` rescaled so that sqrt(mean(e²)) = rms."""
    return e * rms / math.sqrt(float(np.mean(e**2)))
