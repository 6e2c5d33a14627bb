"""How sure a check point test is: confidence intervals on each RMSE and the probability
that the true RMSE meets the class (pure; metres in, metres out).

RMSE about zero from n independent normal residuals: n·RMSE² / σ² follows χ²(n), so the
two-sided interval at `level` is

    σ ∈ [ RMSE·√(n / χ²_{1−a/2}(n)),  RMSE·√(n / χ²_{a/2}(n)) ],  a = 1 − level.

(14 points with RMSE_x = 4.06 cm: 2.97 … 6.41 cm.) The probability that the true σ is
within a class X is the posterior P(σ ≤ X) under Jeffreys' prior p(σ) ∝ 1/σ, i.e.
P(χ²(n) ≥ n·RMSE² / X²): the Bayesian module's posterior with a perfect reference (τ = 0),
which is how it is computed here.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import stats

from aerosurvey.qa import bayes

LEVEL = 0.95


def rmse_interval(rmse: float, n: int, level: float = LEVEL) -> tuple[float, float] | None:
    """Confidence interval on σ from an RMSE of n residuals (None for n = 0 or RMSE = 0)."""
    if n < 1 or not rmse > 0 or not math.isfinite(rmse):
        return None
    a = 1 - level
    lo = rmse * math.sqrt(n / float(stats.chi2.ppf(1 - a / 2, n)))
    hi = rmse * math.sqrt(n / float(stats.chi2.ppf(a / 2, n)))
    return lo, hi


def probability_within(rmse: float, n: int, limit: float) -> float | None:
    """P(σ ≤ limit) given the RMSE of n residuals (Jeffreys prior). 0 for a limit ≤ 0."""
    if n < 1 or not math.isfinite(rmse):
        return None
    if limit <= 0:
        return 0.0
    if not rmse > 0:
        return 1.0
    return bayes.cdf(limit, n, rmse, 0.0)


def axis_intervals(e: np.ndarray, level: float = LEVEL) -> dict[str, Any]:
    """RMSE, n and its confidence interval for one axis (NaN residuals left out)."""
    e = np.asarray(e, float)
    e = e[np.isfinite(e)]
    n = len(e)
    if n == 0:
        return {"n": 0}
    r = float(np.sqrt(np.mean(e * e)))
    ci = rmse_interval(r, n, level)
    return {"n": n, "rmse_m": r, "level": level, "ci_lower_m": ci[0] if ci else None,
            "ci_upper_m": ci[1] if ci else None}


def pooled(dx: np.ndarray, dy: np.ndarray) -> tuple[float, int]:
    """σ of one horizontal coordinate from both axes (2n values)."""
    v = np.concatenate([np.asarray(dx, float), np.asarray(dy, float)])
    v = v[np.isfinite(v)]
    return (float(np.sqrt(np.mean(v * v))) if len(v) else math.nan), len(v)
