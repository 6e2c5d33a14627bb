"""Blunder detection in check point residuals by data snooping, one point per iteration (pure).

The method is the geodetic literature's, chosen per component by what is known about σ:

- **σ₀ known a priori** (the specification's σ, `sigma0_h` / `sigma0_v`): Baarda's w-test
  (W. Baarda, *A testing procedure for use in geodetic networks*, Netherlands Geodetic
  Commission, Publications on Geodesy 2(5), 1968). w_i = e_i / (σ₀ √r_i) is standard normal
  for a value without a blunder; the critical value is k = z(1 − α₀/2) (α₀ = 0.001 → 3.29).
- **σ estimated from the same points**: Pope's τ-test (A. J. Pope, *The statistics of
  residuals and the detection of outliers*, NOAA Technical Report NOS 65 NGS 1, 1976).
  τ_i = e_i / (σ̂ √r_i) with σ̂² = Σe² / f follows the τ distribution with f degrees of
  freedom, τ = √f · t / √(f − 1 + t²) with t Student's t(f − 1); the critical value is that
  transform of t(f − 1) at 1 − α₀/2. (The σ̂ of the Hellenic Cadastre practice, in the Hellenic Cadastre
  orthoimage paper, ISPRS Archives XXXV (2004), formulas (1), (2), is this σ̂:
  σ_hor = √(Σ(dx² + dy²) / 2n), σ_ver = √(Σdz² / n).)

Residuals are direct differences, product − reference, with no parameter estimated: every
value's redundancy number is r_i = 1 and a component's total redundancy is its number of
values, f = 2n horizontally (dx and dy with one pooled σ) and n vertically.

Iteration: the point whose largest |w| or |τ| over its values, divided by the critical
value, is largest and above 1 is rejected (the whole point), and the test is run again on the
points left (σ̂, f and τ's critical value recomputed) until no value exceeds its critical
value. Every iteration's figures are kept.

Size. α₀ is the probability that one blunder-free value is rejected. A blunder-free set of N
tested values loses at least one point with probability α_set = 1 − (1 − α₀)^N (exact for the
w-test, whose values are independent; for the τ-test an approximation, the τ_i sharing σ̂:
the Monte Carlo tests check both). That survey-wide rate is what the report states.

Power. The minimal detectable bias (MDB) is the blunder on one value found with probability
β₀ (the power, 0.80 by default) by that value's test: w-test, δ₀ with
Φ(δ₀ − k) + Φ(−δ₀ − k) = β₀ (α₀ = 0.001, β₀ = 0.80: δ₀ = 4.13, λ₀ = δ₀² = 17.07 as in Baarda's
tables), MDB = δ₀ σ₀ / √r_i; τ-test, |τ_i| > τ_c is the same event as |t_i| > t_c for
t_i = e_i / √(Σ_{j≠i} e_j² / (f − 1)), which with a blunder δσ on value i follows the
noncentral t(f − 1, δ), so δ solves P(|t(f − 1, δ)| > t_c) = β₀ and MDB = δ σ̂.

Global test: f σ̂² / σ₀² against χ²(f) at 1 − α, on every point and on the points kept.
Sufficient evidence: the test decides only when its MDB is at most `max_mdb` σ (default 8);
with the τ-test this asks for a smallest number of values (`fewest_points`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from scipy import integrate, optimize, special, stats

from aerosurvey.qa import choices
from aerosurvey.qa import statistics as st

#: the defaults, as the command shows them (qa/choices.py)
ALPHA0, POWER, MAX_MDB, MAX_SHARE = (choices.SNOOPING_ALPHA0, choices.SNOOPING_POWER, choices.SNOOPING_MAX_MDB,
                                     choices.SNOOPING_MAX_SHARE)

W_TEST, TAU_TEST = "w", "tau"
METHOD_NAMES = {W_TEST: "Baarda's w-test (sigma0 known a priori)",
                TAU_TEST: "Pope's tau-test (sigma estimated from the same points)"}


@lru_cache(maxsize=4096)
def critical_value(method: str, alpha0: float, f: int) -> float:
    """|w| or |τ| above which a value is rejected (inf: no value can be, f < 2 for τ)."""
    if method == W_TEST:
        return float(stats.norm.isf(alpha0 / 2))
    if f < 2:
        return math.inf
    t = float(stats.t.isf(alpha0 / 2, f - 1))
    return math.sqrt(f) * t / math.sqrt(f - 1 + t * t)


def power(method: str, alpha0: float, f: int, delta: float) -> float:
    """Probability that a blunder of δ σ on one value is rejected by that value's test."""
    if method == TAU_TEST and f < 2:
        return 0.0
    if method == W_TEST:
        k = critical_value(W_TEST, alpha0, f)
        return float(stats.norm.sf(k - delta) + stats.norm.cdf(-k - delta))
    # P(|t(ν, δ)| > t_c), ν = f − 1, integrated over x = √χ²(ν) of the other values, whose
    # density is finite at 0 (scipy's noncentral t returns NaN this far in the tail for ν = 1);
    # beyond c = δ + 12 both normal tails are below 1e-32, beyond `top` the density is
    nu = f - 1
    scale = float(stats.t.isf(alpha0 / 2, nu)) / math.sqrt(nu)
    top = min(float(stats.chi.isf(1e-14, nu)), (delta + 12) / scale)
    x = np.linspace(0.0, top, 4001)
    c = scale * x
    tails = (special.ndtr(delta - c) + special.ndtr(-c - delta)) * stats.chi.pdf(x, nu)
    return float(integrate.simpson(tails, x=x))


@lru_cache(maxsize=4096)
def mdb_factor(method: str, alpha0: float, beta: float, f: int) -> float:
    """δ: the minimal detectable bias in units of σ at power β (inf when undetectable)."""
    if method == TAU_TEST and f < 2:
        return math.inf
    hi = 8.0
    while power(method, alpha0, f, hi) < beta:
        hi *= 2
        if hi > 1e6:
            return math.inf
    return float(optimize.brentq(lambda d: power(method, alpha0, f, d) - beta, 0.0, hi, xtol=1e-10))


@lru_cache(maxsize=256)
def fewest_values(method: str, alpha0: float, beta: float, max_mdb: float) -> int | None:
    """The fewest values (redundancy f) for which the MDB is at most max_mdb σ (None: never, up to 10⁵)."""
    if method == W_TEST:
        return 1 if mdb_factor(W_TEST, alpha0, beta, 1) <= max_mdb else None
    lo, hi = 2, 2
    while mdb_factor(TAU_TEST, alpha0, beta, hi) > max_mdb:
        lo, hi = hi, hi * 2
        if hi > 100_000:
            return None
    while lo < hi:  # δ falls as f grows
        mid = (lo + hi) // 2
        if mdb_factor(TAU_TEST, alpha0, beta, mid) <= max_mdb:
            hi = mid
        else:
            lo = mid + 1
    return hi


def fewest_points(horizontal: str, vertical: str | None, alpha0: float, beta: float, max_mdb: float) -> int | None:
    """The fewest points on which snooping decides: each component's fewest values (2 per point
    horizontally, 1 vertically). None: no number of points is enough."""
    need = []
    fh = fewest_values(horizontal, alpha0, beta, max_mdb)
    need.append(None if fh is None else math.ceil(fh / 2))
    if vertical is not None:
        need.append(fewest_values(vertical, alpha0, beta, max_mdb))
    return None if None in need else max(n for n in need if n is not None)


def survey_alpha(alpha0: float, values: int) -> float:
    """Probability that a blunder-free set of `values` tested values loses at least one point."""
    return float(-math.expm1(values * math.log1p(-alpha0)))


@dataclass(frozen=True)
class ComponentTest:
    """One component's test in one iteration."""

    axis: str  # horizontal or vertical
    method: str  # W_TEST or TAU_TEST
    values: int  # f, the redundancy (every value's redundancy number is 1)
    sigma_m: float  # σ₀, or σ̂ of the values tested
    critical: float  # in units of σ
    mdb_m: float  # at the stated power; inf when undetectable
    largest: float  # the largest |w| or |τ|
    worst: int  # index (in the whole set) of the point holding it, -1 when none

    @property
    def threshold_m(self) -> float:
        return self.critical * self.sigma_m

    def as_dict(self, alpha0: float) -> dict[str, Any]:
        return {"axis": self.axis, "method": self.method, "redundancy": self.values, "sigma_m": self.sigma_m,
                "critical_value": st.finite_or_none(self.critical), "threshold_m": st.finite_or_none(self.threshold_m),
                "mdb_m": st.finite_or_none(self.mdb_m), "largest_statistic": self.largest, "alpha0": alpha0}



@dataclass(frozen=True)
class Iteration:
    kept: int  # points tested in this iteration
    tests: tuple[ComponentTest, ...]
    rejected: int  # index of the point rejected, -1 when none (the last iteration)
    axis: str | None  # the component that rejected it


@dataclass(frozen=True)
class Snooping:
    iterations: tuple[Iteration, ...]
    rejected_h: np.ndarray  # bool per point
    rejected_v: np.ndarray
    max_share: float
    alpha0: float
    power: float
    survey_alpha: float  # α_set over every tested value of the whole set
    global_all: dict[str, dict[str, Any] | None]  # per axis, on every point
    global_kept: dict[str, dict[str, Any] | None]  # per axis, on the points kept

    @property
    def first(self) -> Iteration:
        return self.iterations[0]

    @property
    def last(self) -> Iteration:
        return self.iterations[-1]

    @property
    def rejected(self) -> np.ndarray:
        res: np.ndarray = self.rejected_h | self.rejected_v
        return res

    @property
    def rejected_share(self) -> float:
        return float(self.rejected.mean()) if len(self.rejected) else 0.0

    @property
    def share_ok(self) -> bool:
        return self.rejected_share <= self.max_share * (1 + 1e-12)

    @property
    def passed(self) -> bool:
        return self.share_ok and all(g["passed"] for g in self.global_kept.values() if g is not None)


def global_test(sq_sum: float, dof: int, sigma0: float | None, alpha: float) -> dict[str, Any] | None:
    """χ² test of H0: σ ≤ σ₀ with the statistic Σe² / σ₀² = f σ̂² / σ₀² against χ²(f) at 1 − α."""
    if sigma0 is None or dof < 1:
        return None
    chi2 = sq_sum / (sigma0 * sigma0)
    limit = float(stats.chi2.isf(alpha, dof))
    return {"statistic": chi2, "limit": limit, "dof": dof, "sigma0_m": sigma0, "sigma_m": math.sqrt(sq_sum / dof),
            "alpha": alpha, "passed": bool(chi2 <= limit)}


def _component(axis: str, per_point: np.ndarray, sq: np.ndarray, counts: np.ndarray, keep: np.ndarray,
               sigma0: float | None, alpha0: float, beta: float) -> ComponentTest | None:
    """per_point: the largest |e| of each point; sq, counts: Σe² and the number of values per point."""
    f = int(counts[keep].sum())
    if f == 0:
        return None
    method = W_TEST if sigma0 is not None else TAU_TEST
    sigma = sigma0 if sigma0 is not None else math.sqrt(float(sq[keep].sum()) / f)
    crit = critical_value(method, alpha0, f)
    stat = np.where(keep & (counts > 0), per_point, 0.0) / sigma if sigma > 0 else np.zeros(len(keep))
    worst = int(np.argmax(stat))
    return ComponentTest(axis, method, f, sigma, crit, mdb_factor(method, alpha0, beta, f) * sigma,
                         float(stat[worst]), worst if stat[worst] > 0 else -1)


def snoop(dx: np.ndarray, dy: np.ndarray, dz: np.ndarray | None = None, sigma0_h: float | None = None,
          sigma0_v: float | None = None, alpha0: float = ALPHA0, beta: float = POWER, max_share: float = MAX_SHARE,
          alpha: float = 0.05) -> Snooping:
    """Iterative data snooping, one point rejected per iteration; the global tests. NaN dz: no height there."""
    dx, dy = np.asarray(dx, float), np.asarray(dy, float)
    n = len(dx)
    if n == 0:
        raise ValueError("data snooping needs at least one point")
    dz = np.full(n, np.nan) if dz is None else np.asarray(dz, float)
    has_z = np.isfinite(dz)
    az = np.where(has_z, np.abs(dz), 0.0)
    parts = {"horizontal": (np.maximum(np.abs(dx), np.abs(dy)), dx * dx + dy * dy, np.full(n, 2), sigma0_h),
             "vertical": (az, az * az, has_z.astype(int), sigma0_v)}
    keep = np.ones(n, bool)
    bad = {"horizontal": np.zeros(n, bool), "vertical": np.zeros(n, bool)}
    iterations = []
    while True:
        tests = tuple(t for axis, (a, sq, cnt, s0) in parts.items()
                      if (t := _component(axis, a, sq, cnt, keep, s0, alpha0, beta)) is not None)
        over = [t for t in tests if t.worst >= 0 and t.largest > t.critical]
        if not over:
            iterations.append(Iteration(int(keep.sum()), tests, -1, None))
            break
        t = max(over, key=lambda c: c.largest / c.critical)
        iterations.append(Iteration(int(keep.sum()), tests, t.worst, t.axis))
        keep[t.worst] = False
        bad[t.axis][t.worst] = True
    n_values = sum(int(cnt.sum()) for _, _, cnt, _ in parts.values())
    glob_all, glob_kept = {}, {}
    for axis, (_, sq, cnt, s0) in parts.items():
        if cnt.sum():
            glob_all[axis] = global_test(float(sq.sum()), int(cnt.sum()), s0, alpha)
            glob_kept[axis] = global_test(float(sq[keep].sum()), int(cnt[keep].sum()), s0, alpha)
    return Snooping(tuple(iterations), bad["horizontal"], bad["vertical"], max_share, alpha0, beta,
                    survey_alpha(alpha0, n_values), glob_all, glob_kept)
