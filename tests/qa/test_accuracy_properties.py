"""Properties: statistics against numpy, invariance to the order of the points, scaling."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs
from qa_accuracy_helpers import make_points

from aerosurvey.qa import statistics as st
from aerosurvey.qa.assessment import Settings, assess

floats = hs.floats(-5, 5, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(hs.lists(floats, min_size=1, max_size=80))
def test_axis_statistics_against_numpy(values: Any) -> None:
    e = np.asarray(values)
    s = st.axis_stats(e)
    assert s["n"] == len(e)
    assert s["rmse_m"] == pytest.approx(float(np.sqrt(np.mean(e**2))), rel=1e-12, abs=1e-15)
    assert s["mean_m"] == pytest.approx(float(np.mean(e)), rel=1e-12, abs=1e-15)
    for p in st.PERCENTILES:
        key = f"abs_p{p:g}_m".replace(".", "_")
        assert s[key] == pytest.approx(float(np.percentile(np.abs(e), p)), rel=1e-12, abs=1e-15)
    assert (s["min_m"], s["max_m"]) == (float(e.min()), float(e.max()))
    if len(e) > 1:
        assert s["std_m"] == pytest.approx(float(np.std(e, ddof=1)), rel=1e-9, abs=1e-15)


def _point_sets() -> hs.SearchStrategy:
    @hs.composite
    def build(draw: Any) -> dict[str, Any]:
        n = draw(hs.integers(6, 30))
        seed = draw(hs.integers(0, 2**32 - 1))
        rng = np.random.default_rng(seed)
        scale = draw(hs.sampled_from([0.01, 0.05, 0.5]))
        return {"dx": rng.normal(0, scale, n), "dy": rng.normal(0, scale * draw(hs.sampled_from([0.3, 1.0])), n),
                "dz": rng.normal(draw(hs.sampled_from([0.0, scale])), scale, n), "x": rng.uniform(0, 500, n),
                "y": rng.uniform(0, 300, n), "vegetated": rng.uniform(size=n) < 0.3,
                "perm": rng.permutation(n), "k": draw(hs.sampled_from([0.1, 3.0, 250.0]))}
    return build()


STANDARD_SETTINGS = [
    Settings(standard="asprs2014", area_km2=600.0),
    Settings(standard="asprs2023", ref_sigma_xy_m=0.004, ref_sigma_z_m=0.006),
    Settings(standard="nssda"),
    Settings(standard="snooping", sigma0_h_m=0.05, sigma0_v_m=0.08),
    Settings(standard="bayes", ref_sigma_xy_m=0.004, ref_sigma_z_m=0.006),
]


def _leaves(obj: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, f"{path}.{k}")
    elif isinstance(obj, (list, tuple)) and obj and not isinstance(obj[0], (dict, list)):
        yield path, obj
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            yield from _leaves(v, f"{path}[{i}]")
    else:
        yield path, obj


def _comparable(r: dict[str, Any]) -> dict[str, Any]:
    out = {k: v for k, v in r.items() if k != "points"}
    out["points"] = {p["id"]: p for p in r["points"]}
    return out


def _same(a: Any, b: Any, key: str, rel: float = 1e-9) -> None:
    if isinstance(a, float) and isinstance(b, float):
        assert b == pytest.approx(a, rel=rel, abs=1e-13), key
    elif isinstance(a, (list, tuple)) and a and isinstance(a[0], float):
        assert list(b) == pytest.approx(list(a), rel=rel, abs=1e-13), key
    else:
        assert a == b, key


@settings(max_examples=12, deadline=None)
@given(_point_sets())
def test_every_result_is_invariant_to_the_order_of_the_points(d: Any) -> None:
    pts = make_points(d["dx"], d["dy"], d["dz"], x=d["x"], y=d["y"], vegetated=d["vegetated"], crs="EPSG:32633")
    p = d["perm"]
    shuffled = make_points(d["dx"][p], d["dy"][p], d["dz"][p], x=d["x"][p], y=d["y"][p],
                           vegetated=d["vegetated"][p], ids=[pts.ids[i] for i in p], crs="EPSG:32633")
    for s in STANDARD_SETTINGS:
        a, b = _comparable(assess(pts, s)), _comparable(assess(shuffled, s))
        la, lb = dict(_leaves(a)), dict(_leaves(b))
        assert la.keys() == lb.keys()
        for key in la:
            _same(la[key], lb[key], f"{s.standard}{key}")


def _scaled_settings(s: Settings, k: float) -> Settings:
    return Settings(**{f: (v * k if f.endswith("_m") and v is not None else v) for f, v in vars(s).items()})


@settings(max_examples=12, deadline=None)
@given(_point_sets())
def test_scaling_the_residuals_scales_the_lengths_and_nothing_else(d: Any) -> None:
    k = d["k"]
    pts = make_points(d["dx"], d["dy"], d["dz"], vegetated=d["vegetated"])
    big = make_points(d["dx"] * k, d["dy"] * k, d["dz"] * k, vegetated=d["vegetated"])
    for s in STANDARD_SETTINGS:
        a, b = assess(pts, s), assess(big, _scaled_settings(s, k))
        for part in ("statistics", "result"):
            la, lb = dict(_leaves(a[part])), dict(_leaves(b[part]))
            assert la.keys() == lb.keys()
            for key, va in la.items():
                vb = lb[key]
                last = key.rsplit(".", 1)[-1]
                if last.endswith("_cm"):
                    continue  # classes: table values and rounded, not lengths of the data
                if last.endswith("_m") and isinstance(va, (float, list)) and va is not None:
                    scaled = [v * k for v in va] if isinstance(va, list) else va * k
                    _same(scaled, vb, f"{s.standard}.{part}{key}", rel=1e-7)
                elif isinstance(va, float) and "statistic" not in last:
                    _same(va, vb, f"{s.standard}.{part}{key}", rel=1e-6)
                elif not isinstance(va, float):
                    assert va == vb, f"{s.standard}.{part}{key}"
        assert a["passed"] == b["passed"] and len(a["warnings"]) == len(b["warnings"])
        for pa, pb in zip(a["points"], b["points"]):
            assert pb["dx_m"] == pytest.approx(pa["dx_m"] * k) and pa["flags"] == pb["flags"]


def test_influence_matches_a_direct_leave_one_out() -> None:
    rng = np.random.default_rng(12)
    dx, dy = rng.normal(size=15), rng.normal(size=15)
    dy[3] = np.nan
    ch = st.influence([dx, dy])
    for i in range(15):
        keep = np.arange(15) != i
        ex, ey = dx[keep], dy[keep]
        direct = math.sqrt(np.mean(ex**2) + np.nanmean(ey**2))
        full = math.sqrt(np.mean(dx**2) + np.nanmean(dy**2))
        assert ch[i] == pytest.approx(direct / full - 1, rel=1e-9, abs=1e-12)
