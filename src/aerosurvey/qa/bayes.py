"""Bayesian estimate of the product's σ when the reference survey itself has σ = τ.

Czech land-consolidation practice (shared/papers/003, formulas (1) and (2); docs/domain.md
section 2): with Jeffreys' prior, the posterior of σ given m differences with sample
standard deviation s is proportional to σ (σ² + τ²)^(−m/2 − 1) exp(−m s² / (2(σ² + τ²))).
Positions use m = 2n and s = sqrt(Σ(dx² + dy²) / 2n); heights m = n and s = s_Z.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import integrate, optimize


def log_density(sigma: float | np.ndarray, m: int, s: float, tau: float) -> float | np.ndarray:
    """Unnormalised log posterior of σ."""
    v = np.asarray(sigma, float) ** 2 + tau * tau
    with np.errstate(divide="ignore"):
        return np.log(sigma) - (m / 2 + 1) * np.log(v) - m * s * s / (2 * v)


def mode(m: int, s: float, tau: float) -> float:
    """The most probable σ: sqrt((θ + sqrt(θ² + 4(m+1)τ⁴)) / (2(m+1))), θ = m(s² − τ²)."""
    theta = m * (s * s - tau * tau)
    return math.sqrt((theta + math.sqrt(theta * theta + 4 * (m + 1) * tau**4)) / (2 * (m + 1)))


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
    """Mode and equal-tailed credible interval, by integrating the normalised posterior."""
    if m < 1 or not (s > 0) or tau < 0:
        raise ValueError("need m >= 1, s > 0 and tau >= 0")
    peak = mode(m, s, tau)
    ref = float(log_density(peak, m, s, tau))
    f = lambda x: math.exp(float(log_density(x, m, s, tau)) - ref) if x > 0 else 0.0
    top = peak + 12 * max(peak, s) / math.sqrt(max(m, 1)) + 5 * s
    total = integrate.quad(f, 0, peak, limit=400)[0] + integrate.quad(f, peak, top, limit=400)[0]

    def cdf(x: float) -> float:
        if x <= peak:
            return integrate.quad(f, 0, x, limit=400)[0] / total
        return (integrate.quad(f, 0, peak, limit=400)[0] + integrate.quad(f, peak, x, limit=400)[0]) / total

    a = (1 - level) / 2
    lo = optimize.brentq(lambda x: cdf(x) - a, 1e-12, top, xtol=1e-10)
    hi = optimize.brentq(lambda x: cdf(x) - (1 - a), 1e-12, top, xtol=1e-10)
    return Posterior(m, s, tau, peak, float(lo), float(hi), level)


def density_curve(p: Posterior, points: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """σ and the normalised density, for plotting."""
    top = p.upper + 2 * (p.upper - p.lower)
    xs = np.linspace(max(p.lower - 2 * (p.upper - p.lower), 1e-9), top, points)
    ld = log_density(xs, p.m, p.s, p.tau)
    ys = np.exp(ld - ld.max())
    return xs, ys / np.trapezoid(ys, xs)
