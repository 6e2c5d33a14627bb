"""Cadastral acceptance by data snooping (Hellenic Cadastre practice, shared/papers/002).

σ_hor = √(Σ(dx² + dy²) / 2n) and σ_ver = √(Σ dz² / n) (the source's formulas (1), (2)).
A point is rejected when |dx| or |dy| ≥ k_h σ_hor, or |dz| ≥ k_v σ_ver (the source's (3),
(4): k_h = 1.96, k_v = 2.16; both settable). More than 5 % rejected fails the set. σ is
recomputed on the kept points and tested globally against the specification's σ₀ with the
chi-square statistic f σ² / σ₀² (f = 2n horizontally, n vertically), one-sided at α: our
formulation, because the source's inequalities (5), (6) are garbled in its scan.
Worked numbers in the source: n = 9, σ_hor = 1.245 m, σ_ver = 0.412 m → 2.44 m, 0.89 m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

K_H, K_V, MAX_SHARE = 1.96, 2.16, 0.05


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

    @property
    def rejected(self) -> np.ndarray:
        return self.rejected_h | self.rejected_v

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
    """Blunder test per point, the rejection share, σ recomputed, global tests. NaN dz: no height test there."""
    dx, dy = np.asarray(dx, float), np.asarray(dy, float)
    n = len(dx)
    if n == 0:
        raise ValueError("data snooping needs at least one point")
    dz = np.full(n, np.nan) if dz is None else np.asarray(dz, float)
    has_z = np.isfinite(dz)
    s_h = _sigma_h(dx, dy)
    s_v = _sigma_v(dz[has_z])
    t_h = k_h * s_h
    t_v = k_v * s_v if s_v is not None else None
    bad_h = (np.abs(dx) >= t_h) | (np.abs(dy) >= t_h) if t_h > 0 else np.zeros(n, bool)
    bad_v = np.zeros(n, bool)
    if t_v is not None and t_v > 0:
        bad_v[has_z] = np.abs(dz[has_z]) >= t_v
    keep = ~(bad_h | bad_v)
    s_hk = _sigma_h(dx[keep], dy[keep])
    s_vk = _sigma_v(dz[keep & has_z])
    return Snooping(s_h, s_v, t_h, t_v, bad_h, bad_v, max_share, s_hk, s_vk,
                    global_test(s_hk, 2 * int(keep.sum()), sigma0_h, alpha),
                    global_test(s_vk, int((keep & has_z).sum()), sigma0_v, alpha))
