"""Cadastral acceptance by data snooping (Hellenic Cadastre practice, the Hellenic Cadastre orthoimage paper, ISPRS Archives XXXV (2004)),
run iteratively in Baarda's manner.

σ_hor = √(Σ(dx² + dy²) / 2n) and σ_ver = √(Σ dz² / n) (the source's formulas (1), (2)).
A point is rejected when |dx| or |dy| ≥ k_h σ_hor, or |dz| ≥ k_v σ_ver (the source's (3),
(4): k_h = 1.96, k_v = 2.16; both settable). Iteration (Baarda's data snooping): the point
with the largest |e| / threshold is rejected, σ is re-estimated on the points left and the
test repeated until no point exceeds its threshold; a blunder thus no longer hides behind
the σ it inflated. More than 5 % rejected fails the set. σ of the kept points is tested
globally against the specification's σ₀ with the chi-square statistic f σ² / σ₀²
(f = 2n horizontally, n vertically), one-sided at α: our formulation, because the
source's inequalities (5), (6) are garbled in its scan. The first pass's σ and thresholds
are the source's worked numbers (n = 9, σ_hor = 1.245 m, σ_ver = 0.412 m → 2.44 m, 0.89 m).

Internal reliability. σ is estimated from the tested values themselves, so a blunder ∇ on
one of N values (N = 2n horizontally, n vertically) raises σ̂² to (S + ∇²)/N with
S ≈ (N − 1)σ²; it is rejected only when ∇ ≥ c·σ with c = k·√((N − 1)/(N − k²)). When
N ≤ k² no blunder of any size can be rejected (|e| ≤ √N σ̂ always: vertically n ≤ 4 with
k = 2.16). The minimal detectable bias reported for each point is (c + z_β)·σ̂ with power
β = 80 % (z = 0.8416): residuals are direct differences, so every point has redundancy 1
and the MDB is the same for every point of an axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

K_H, K_V, MAX_SHARE = 1.96, 2.16, 0.05
POWER = 0.80
Z_POWER = float(stats.norm.ppf(POWER))


def detectable_factor(n_values: int, k: float) -> float:
    """c such that a blunder ≥ c σ is rejected (inf when none can be: n_values ≤ k²)."""
    if n_values <= k * k:
        return math.inf
    return k * math.sqrt((n_values - 1) / (n_values - k * k))


def mdb(sigma: float | None, n_values: int, k: float) -> float | None:
    """Minimal detectable bias at 80 % power (None without σ, inf when undetectable)."""
    if sigma is None:
        return None
    c = detectable_factor(n_values, k)
    return math.inf if math.isinf(c) else (c + Z_POWER) * sigma


@dataclass(frozen=True)
class Snooping:
    sigma_h: float
    sigma_v: float | None
    threshold_h: float
    threshold_v: float | None
    rejected_h: np.ndarray  # bool per point
    rejected_v: np.ndarray
    max_share: float
    sigma_h_kept: float | None
    sigma_v_kept: float | None
    global_h: dict[str, Any] | None
    global_v: dict[str, Any] | None
    steps: tuple[dict[str, Any], ...] = ()  # one per rejection, in order
    mdb_h: float | None = None  # minimal detectable bias, per coordinate, on the kept points
    mdb_v: float | None = None
    detectable_h: bool = True  # False when no blunder can be rejected at all
    detectable_v: bool = True

    @property
    def rejected(self) -> np.ndarray:
        res: np.ndarray = self.rejected_h | self.rejected_v
        return res

    @property
    def rejected_share(self) -> float:
        return float(self.rejected.mean()) if len(self.rejected) else 0.0

    @property
    def share_ok(self) -> bool:
        return self.rejected_share <= self.max_share + 1e-12

    @property
    def passed(self) -> bool:
        return self.share_ok and all(g["passed"] for g in (self.global_h, self.global_v) if g is not None)


def global_test(sigma: float | None, dof: int, sigma0: float | None, alpha: float) -> dict[str, Any] | None:
    """Chi-square test of H0: σ ≤ σ₀, with statistic f σ² / σ₀² against the upper 1 − α quantile."""
    if sigma0 is None or sigma is None or dof < 1:
        return None
    chi2 = dof * sigma * sigma / (sigma0 * sigma0)
    limit = float(stats.chi2.ppf(1 - alpha, dof))
    return {"statistic": chi2, "limit": limit, "dof": dof, "sigma0_m": sigma0, "sigma_m": sigma, "alpha": alpha,
            "passed": bool(chi2 <= limit)}


def _sigma_h(dx: np.ndarray, dy: np.ndarray) -> float | None:
    return math.sqrt(float(np.sum(dx * dx + dy * dy)) / (2 * len(dx))) if len(dx) else None


def _sigma_v(dz: np.ndarray) -> float | None:
    return math.sqrt(float(np.sum(dz * dz)) / len(dz)) if len(dz) else None


def snoop(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray | None = None, k_h: float = K_H, k_v: float = K_V,
          max_share: float = MAX_SHARE, sigma0_h: float | None = None, sigma0_v: float | None = None,
          alpha: float = 0.05) -> Snooping:
    """Iterative blunder test, the rejection share, σ re-estimated, global tests. NaN dz: no height test there."""
    dx, dy = np.asarray(dx, float), np.asarray(dy, float)
    n = len(dx)
    if n == 0:
        raise ValueError("data snooping needs at least one point")
    dz = np.full(n, np.nan) if dz is None else np.asarray(dz, float)
    has_z = np.isfinite(dz)
    s_h = _sigma_h(dx, dy)
    s_v = _sigma_v(dz[has_z])
    assert s_h is not None
    t_h = k_h * s_h
    t_v = k_v * s_v if s_v is not None else None
    keep = np.ones(n, bool)
    bad_h = np.zeros(n, bool)
    bad_v = np.zeros(n, bool)
    steps: list[dict[str, Any]] = []
    ah = np.maximum(np.abs(dx), np.abs(dy))
    az = np.where(has_z, np.abs(dz), 0.0)
    while keep.sum() > 1:
        sh = _sigma_h(dx[keep], dy[keep]) or 0.0
        sv = _sigma_v(dz[keep & has_z])
        with np.errstate(divide="ignore", invalid="ignore"):
            wh = np.where(keep, ah / (k_h * sh), 0.0) if sh > 0 else np.zeros(n)
            wv = np.where(keep & has_z, az / (k_v * sv), 0.0) if sv else np.zeros(n)
        ih, iv = int(np.argmax(wh)), int(np.argmax(wv))
        if max(wh[ih], wv[iv]) < 1.0:
            break
        if wh[ih] >= wv[iv]:
            i, axis, value, thr, sig = ih, "horizontal", float(ah[ih]), k_h * sh, sh
            bad_h[i] = True
        else:
            i, axis, value, thr, sig = iv, "vertical", float(az[iv]), k_v * (sv or 0.0), sv or 0.0
            bad_v[i] = True
        keep[i] = False
        steps.append({"index": i, "axis": axis, "abs_residual_m": value, "threshold_m": thr, "sigma_m": sig,
                      "kept_after": int(keep.sum())})
    s_hk = _sigma_h(dx[keep], dy[keep])
    s_vk = _sigma_v(dz[keep & has_z])
    nh, nv = 2 * int(keep.sum()), int((keep & has_z).sum())
    return Snooping(s_h, s_v, t_h, t_v, bad_h, bad_v, max_share, s_hk, s_vk,
                    global_test(s_hk, nh, sigma0_h, alpha), global_test(s_vk, nv, sigma0_v, alpha), tuple(steps),
                    mdb(s_hk, nh, k_h), mdb(s_vk, nv, k_v) if nv else None,
                    not math.isinf(detectable_factor(2 * n, k_h)),
                    not math.isinf(detectable_factor(int(has_z.sum()), k_v)) if has_z.any() else True)
