"""Cadastral acceptance by data snooping (Hellenic Cadastre practice, shared/papers/002).

σ_hor = sqrt(Σ(dx² + dy²) / 2n), σ_ver = sqrt(Σ dz² / n); a point is rejected when |dx| or
|dy| ≥ k_h σ_hor or |dz| ≥ k_v σ_ver (1.96 and 2.16 by default); more than 5 % rejected
fails the set; σ is recomputed on the kept points and tested globally against the
specification's σ₀ with the chi-square statistic f σ² / σ₀² (f = 2n horizontally, n
vertically; our formulation, the source's inequality is garbled in its scan).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class Snooping:
    sigma_h: float
    sigma_v: float | None
    threshold_h: float
    threshold_v: float | None
    rejected: list[str]
    rejected_share: float
    max_share: float
    sigma_h_kept: float
    sigma_v_kept: float | None
    global_h: dict[str, Any] | None
    global_v: dict[str, Any] | None

    @property
    def passed(self) -> bool:
        ok = self.rejected_share <= self.max_share
        for g in (self.global_h, self.global_v):
            if g is not None:
                ok = ok and g["passed"]
        return ok


def _global(sigma: float, f: int, sigma0: float | None, alpha: float) -> dict[str, Any] | None:
    if sigma0 is None or f < 1:
        return None
    chi2 = f * sigma * sigma / (sigma0 * sigma0)
    limit = float(stats.chi2.ppf(1 - alpha, f))
    return {"statistic": chi2, "limit": limit, "dof": f, "sigma0": sigma0, "passed": bool(chi2 <= limit)}


def snoop(ids: list[str], dx: np.ndarray, dy: np.ndarray, dz: np.ndarray | None, k_h: float = 1.96, k_v: float = 2.16,
          max_share: float = 0.05, sigma0_h: float | None = None, sigma0_v: float | None = None,
          alpha: float = 0.05) -> Snooping:
    n = len(ids)
    has_z = dz is not None and np.all(np.isfinite(dz))
    s_h = math.sqrt(float(np.sum(dx * dx + dy * dy)) / (2 * n))
    s_v = math.sqrt(float(np.sum(dz * dz)) / n) if has_z else None
    bad = (np.abs(dx) >= k_h * s_h) | (np.abs(dy) >= k_h * s_h)
    if has_z:
        bad |= np.abs(dz) >= k_v * s_v
    keep = ~bad
    nk = int(keep.sum())
    s_hk = math.sqrt(float(np.sum(dx[keep] ** 2 + dy[keep] ** 2)) / (2 * nk)) if nk else math.nan
    s_vk = math.sqrt(float(np.sum(dz[keep] ** 2)) / nk) if has_z and nk else None
    return Snooping(s_h, s_v, k_h * s_h, k_v * s_v if has_z else None, [i for i, b in zip(ids, bad) if b],
                    float(bad.mean()), max_share, s_hk, s_vk,
                    _global(s_hk, 2 * nk, sigma0_h, alpha), _global(s_vk, nk, sigma0_v, alpha) if has_z else None)
