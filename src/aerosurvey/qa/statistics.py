"""Error statistics of check point residuals (pure maths; metres in, metres out)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import integrate, optimize, stats

#: normal-theory factors (standards.md): CE90 = 2.1460 σ, CE95 = 2.4477 σ for σx = σy;
#: LE90 = 1.6449 σ, LE95 = 1.9600 σ
LE90, LE95 = 1.6449, 1.9600


def rmse(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(e))))


def axis_stats(e: np.ndarray) -> dict[str, Any]:
    """Count, bias with a t-test, spread, RMSE, extremes, percentiles of |e|, shape, normality."""
    e = np.asarray(e, float)
    e = e[np.isfinite(e)]
    n = len(e)
    out: dict[str, Any] = {"n": n}
    if n == 0:
        return out
    mean = float(e.mean())
    sd = float(e.std(ddof=1)) if n > 1 else math.nan
    out.update({
        "mean": mean, "std": sd, "rmse": rmse(e), "min": float(e.min()), "max": float(e.max()),
        "abs_p50": float(np.percentile(np.abs(e), 50)), "abs_p90": float(np.percentile(np.abs(e), 90)),
        "abs_p95": float(np.percentile(np.abs(e), 95)),
    })
    if n > 2 and np.ptp(e) > 0:  # tests and shape need spread; identical residuals have none
        t = stats.ttest_1samp(e, 0.0)
        out["bias_p_value"] = float(t.pvalue)
        out["bias_significant"] = bool(t.pvalue < 0.05)
        out["skew"] = float(stats.skew(e, bias=False))
        out["kurtosis"] = float(stats.kurtosis(e, bias=False)) if n > 3 else math.nan
        sw = stats.shapiro(e)
        out["normality_p_value"] = float(sw.pvalue)
        out["normal"] = bool(sw.pvalue >= 0.05)
    return out


def outliers(e: np.ndarray, k: float = 3.0) -> np.ndarray:
    """Flags (never drops) residuals whose robust z-score (median, 1.4826·MAD) exceeds k."""
    e = np.asarray(e, float)
    med = np.nanmedian(e)
    mad = 1.4826 * np.nanmedian(np.abs(e - med))
    if not mad > 0:
        return np.zeros(len(e), bool)
    return np.abs(e - med) / mad > k


def circular_error(sx: float, sy: float, p: float) -> float:
    """Radius holding probability p of a zero-mean bivariate normal with σx, σy (exact).

    P(R ≤ r) = ∫₀^2π (1 − exp(−r² g(θ)/2)) / (2π σx σy g(θ)) dθ, g = cos²θ/σx² + sin²θ/σy².
    """
    if sx <= 0 and sy <= 0:
        return 0.0
    sx, sy = max(sx, 1e-15), max(sy, 1e-15)

    def cdf(r: float) -> float:
        f = lambda th: (1 - math.exp(-r * r * g(th) / 2)) / (2 * math.pi * sx * sy * g(th))
        return integrate.quad(f, 0, 2 * math.pi, limit=200)[0]

    def g(th: float) -> float:
        return math.cos(th) ** 2 / sx**2 + math.sin(th) ** 2 / sy**2

    hi = 5 * max(sx, sy)
    return float(optimize.brentq(lambda r: cdf(r) - p, 0.0, hi, xtol=1e-12))


def horizontal_summary(dx: np.ndarray, dy: np.ndarray) -> dict[str, Any]:
    rx, ry = rmse(dx), rmse(dy)
    rr = math.hypot(rx, ry)
    return {"rmse_x": rx, "rmse_y": ry, "rmse_r": rr,
            "ce90": circular_error(rx, ry, 0.90), "ce95": circular_error(rx, ry, 0.95),
            "ce95_shortcut": 1.7308 * rr, "ratio": min(rx, ry) / max(rx, ry) if max(rx, ry) > 0 else 1.0}


def vertical_summary(dz: np.ndarray) -> dict[str, Any]:
    dz = dz[np.isfinite(dz)]
    if len(dz) == 0:
        return {}
    r = rmse(dz)
    return {"rmse_z": r, "le90": LE90 * r, "le95": LE95 * r}
