"""Bayesian estimate of the product's σ when the reference survey itself has σ = τ.

Czech land-consolidation practice (Zaoralová et al., land consolidation terms paper, formulas (1) and (2);
section 2): with Jeffreys' prior, m differences with sample standard deviation s (about
zero) give the posterior

    f(σ) = 2^(1−m/2) σ (m s²)^(m/2) (σ² + τ²)^(−m/2−1) exp(−m s² / (2(σ² + τ²)))
           / (Γ(m/2) − Γ(m/2, m s² / (2τ²)))

whose mode is σ̂ = √((θ + √(θ² + 4(m+1)τ⁴)) / (2(m+1))), θ = m(s² − τ²). Positions use
m = 2n and s = √(Σ(dx² + dy²) / 2n) with τ = σ of one reference coordinate; heights use
m = n, s = s_Z, τ = σ_Z of the reference.

The credible interval integrates f. The integral has a closed form: with
u = m s² / (2(σ² + τ²)), f(σ) dσ becomes the Gamma(m/2) density of u truncated to
u < m s² / (2τ²) (the denominator above is that truncation), so
P(σ ≤ a) = 1 − P(m/2, u(a)) / P(m/2, u_max) with P the regularised lower incomplete
gamma function, and the quantiles follow from its inverse. The tests check the result
against a plain numerical integration of f.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special


def _check(m: int, s: float, tau: float) -> None:
    if m < 1 or not (s > 0) or not (tau >= 0) or not math.isfinite(s) or not math.isfinite(tau):
        raise ValueError(f"need m >= 1, s > 0 and tau >= 0 (got m={m}, s={s}, tau={tau})")


def mode(m: int, s: float, tau: float) -> float:
    """The most probable σ, formula (2) of the source."""
    _check(m, s, tau)
    theta = m * (s * s - tau * tau)
    return math.sqrt((theta + math.sqrt(theta * theta + 4 * (m + 1) * tau**4)) / (2 * (m + 1)))


def _u(sigma: np.ndarray | float, m: int, s: float, tau: float) -> np.ndarray:
    return m * s * s / (2 * (np.asarray(sigma, float) ** 2 + tau * tau))


def _p_umax(m: int, s: float, tau: float) -> float:
    return 1.0 if tau == 0 else float(special.gammainc(m / 2, m * s * s / (2 * tau * tau)))


def log_density(sigma: np.ndarray | float, m: int, s: float, tau: float) -> np.ndarray:
    """The normalised log posterior, formula (1) of the source (−inf for σ ≤ 0)."""
    _check(m, s, tau)
    sig = np.asarray(sigma, float)
    v = sig**2 + tau * tau
    norm = special.gammaln(m / 2) + math.log(_p_umax(m, s, tau))
    with np.errstate(divide="ignore", invalid="ignore"):
        out = ((1 - m / 2) * math.log(2) + np.log(sig) + (m / 2) * math.log(m * s * s) - (m / 2 + 1) * np.log(v)
               - m * s * s / (2 * v) - norm)
    res: np.ndarray = np.where(sig > 0, out, -np.inf)
    return res


def density(sigma: np.ndarray | float, m: int, s: float, tau: float) -> np.ndarray:
    res: np.ndarray = np.exp(log_density(sigma, m, s, tau))
    return res


def cdf(a: float, m: int, s: float, tau: float) -> float:
    """P(σ ≤ a) under the posterior."""
    _check(m, s, tau)
    if a <= 0:
        return 0.0
    return float(1.0 - special.gammainc(m / 2, float(_u(a, m, s, tau))) / _p_umax(m, s, tau))


def quantile(q: float, m: int, s: float, tau: float) -> float:
    """The σ with P(σ ≤ σ_q) = q."""
    _check(m, s, tau)
    if not 0 < q < 1:
        raise ValueError(f"quantile: q = {q} must be in (0, 1)")
    u = float(special.gammaincinv(m / 2, (1 - q) * _p_umax(m, s, tau)))
    return math.sqrt(max(m * s * s / (2 * u) - tau * tau, 0.0))


@dataclass(frozen=True)
class Posterior:
    m: int
    s: float
    tau: float
    mode: float
    lower: float  # equal-tailed credible interval
    upper: float
    level: float

    @property
    def half_width(self) -> float:
        return (self.upper - self.lower) / 2


def posterior(m: int, s: float, tau: float, level: float = 0.95) -> Posterior:
    """Mode and equal-tailed credible interval at `level`."""
    a = (1 - level) / 2
    return Posterior(m, s, tau, mode(m, s, tau), quantile(a, m, s, tau), quantile(1 - a, m, s, tau), level)


def density_curve(p: Posterior, points: int = 240) -> tuple[np.ndarray, np.ndarray]:
    """σ and the normalised density over the bulk of the posterior, for the report's plot."""
    lo = quantile(0.0005, p.m, p.s, p.tau)
    hi = quantile(0.9995, p.m, p.s, p.tau)
    pad = 0.1 * (hi - lo)
    xs = np.linspace(max(lo - pad, hi * 1e-6), hi + pad, points)
    return xs, density(xs, p.m, p.s, p.tau)
