"""The checks a rule can name. Each takes the plan view, the rule's parameters and the
shared evidence, and returns an outcome with the measured value, the required one and
the evidence (which line, which crossing, which point, how many images)."""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from aerosurvey.errors import InputError


@dataclass(frozen=True)
class Outcome:
    status: str  # pass, fail, info, not-checkable
    measured: str
    required: str
    evidence: list[str] = field(default_factory=list)
    # where on the map the failure lies, for a viewer to highlight: {"run": id}, {"runs": [a, b]},
    # {"station": id}, {"point": control point id} or {"xy": [x, y]} in the planning CRS
    where: list[dict[str, Any]] = field(default_factory=list)


@dataclass(frozen=True)
class Check:
    params: dict[str, type | tuple[type, ...]]
    run: Callable[..., Outcome]
    defaults: dict[str, Any] = field(default_factory=dict)

    def validate(self, params: dict[str, Any], where: str) -> None:
        for key in params:
            if key not in self.params:
                raise InputError(f"{where}: unknown parameter {key!r}; this check takes {', '.join(sorted(self.params)) or 'none'}")
        for key, typ in self.params.items():
            if key not in params and key not in self.defaults:
                raise InputError(f"{where}: parameter {key!r} is missing")
            v = params.get(key, self.defaults.get(key))
            if isinstance(v, bool) or not isinstance(v, typ):
                raise InputError(f"{where}: parameter {key!r} = {v!r} must be a {getattr(typ, '__name__', 'number')}")
        if "formula" in params:
            compile_formula(params["formula"], where)


NUM = (int, float)
CHECKS: dict[str, Check] = {}


def check(name: str, defaults: dict[str, Any] | None = None, **params: type | tuple[type, ...]):
    def deco(fn: Callable[..., Outcome]) -> Callable[..., Outcome]:
        CHECKS[name] = Check(params, fn, defaults or {})
        return fn

    return deco


def _flatnonzero(mask: Any) -> list[int]:
    import numpy as np

    return [int(i) for i in np.flatnonzero(np.asarray(mask))]


def _pct(v: float) -> str:
    return f"{100 * v:.1f} %"


@check("sensor_min_size", min_long_mm=NUM, min_short_mm=NUM)
def _sensor(view, p, ev) -> Outcome:
    w, h = view.camera["sensor_mm"]
    ok = w >= p["min_long_mm"] and h >= p["min_short_mm"]
    return Outcome("pass" if ok else "fail", f"{w:g} x {h:g} mm ({view.camera['name']})",
                   f">= {p['min_long_mm']:g} x {p['min_short_mm']:g} mm")


@check("pixel_pitch_max", max_um=NUM)
def _pitch(view, p, ev) -> Outcome:
    pitch = view.camera["pixel_pitch_um"]
    return Outcome("pass" if pitch <= p["max_um"] + 1e-9 else "fail", f"{pitch:.2f} um ({view.camera['name']})", f"<= {p['max_um']:g} um")


@check("forward_overlap_min", min=NUM)
def _fwd(view, p, ev) -> Outcome:
    per_run = ev.forward_overlaps
    if not per_run:
        return Outcome("fail", "no run with two photos", f">= {_pct(p['min'])}")
    worst = min(per_run, key=lambda t: t[1])
    low = [(rid, v) for rid, v in per_run if v < p["min"] - 1e-9]
    bad = [f"{rid}: {_pct(v)}" for rid, v in low]
    return Outcome("pass" if not bad else "fail", f"{_pct(worst[1])} (lowest, run {worst[0]})", f">= {_pct(p['min'])}",
                   bad[:20] + ([f"... and {len(bad) - 20} more runs"] if len(bad) > 20 else []),
                   [{"run": rid} for rid, _ in low])


@check("side_overlap_min", min=NUM)
def _side(view, p, ev) -> Outcome:
    pairs = ev.side_overlaps
    if not pairs:
        return Outcome("not-checkable", "a single strip", f">= {_pct(p['min'])}", ["one strip has no side neighbour"])
    worst = min(pairs, key=lambda t: t[2])
    low = [(a, b, v) for a, b, v in pairs if v < p["min"] - 1e-9]
    bad = [f"{a} / {b}: {_pct(v)}" for a, b, v in low]
    return Outcome("pass" if not bad else "fail", f"{_pct(worst[2])} (lowest, runs {worst[0]} / {worst[1]})",
                   f">= {_pct(p['min'])}", bad[:20], [{"runs": [a, b]} for a, b, _ in low])


@check("gsd_max", max_cm=NUM)
def _gsd(view, p, ev) -> Outcome:
    cam = view.camera
    gsd_all = view.agl * cam["pixel_pitch_um"] / 1000.0 / cam["focal_mm"] * 100
    gsd = float(gsd_all.max())
    where = [{"station": view.station_ids[i]} for i in _flatnonzero(gsd_all > p["max_cm"] + 1e-9)]
    return Outcome("pass" if gsd <= p["max_cm"] + 1e-9 else "fail", f"{gsd:.2f} cm (coarsest photo)", f"<= {p['max_cm']:g} cm",
                   where=where)


@check("images_beyond_boundary", min=int)
def _beyond(view, p, ev) -> Outcome:
    found = ev.crossings(p["min"])
    if not found:
        return Outcome("fail", "no run crosses the area", f">= {p['min']} photos outside at every crossing")
    bad = [f"{c['run']} {c['where']}: {c['outside_photos']} photos outside" for c in found if not c["ok"]]
    counted = [c["outside_photos"] for c in found if c["where"] in ("entry", "exit")]
    return Outcome("pass" if not bad else "fail", f"{min(counted)} photos (fewest, over {len(counted)} crossings)",
                   f">= {p['min']} at every crossing", bad[:30] + ([f"... and {len(bad) - 30} more"] if len(bad) > 30 else []),
                   [{"run": c["run"]} for c in found if not c["ok"]])


@check("coverage_min_images", min=int)
def _coverage(view, p, ev) -> Outcome:
    counts, gx, gy = ev.grid_counts
    worst = int(counts.argmin())
    short = int((counts < p["min"]).sum())
    evidence = [f"{short} of {len(counts)} sample points seen by fewer photos; the worst at x {gx[worst]:.1f}, y {gy[worst]:.1f}"] if short else []
    where = [{"xy": [round(float(gx[i]), 2), round(float(gy[i]), 2)]} for i in _flatnonzero(counts < p["min"])[:500]]
    return Outcome("pass" if short == 0 else "fail", f"{int(counts.min())} photos (fewest, {len(counts)} sample points)",
                   f">= {p['min']} photos on every point of the area", evidence, where)


@check("max_height_agl", max_m=NUM)
def _height(view, p, ev) -> Outcome:
    h = float(view.agl.max())
    where = [{"station": view.station_ids[i]} for i in _flatnonzero(view.agl > p["max_m"] + 1e-6)]
    return Outcome("pass" if h <= p["max_m"] + 1e-6 else "fail", f"{h:.1f} m (highest photo above ground)", f"<= {p['max_m']:g} m",
                   where=where)


@check("gcp_outside_envelope", defaults={"min_enclosed": 0.98}, min_enclosed=NUM)
def _envelope(view, p, ev) -> Outcome:
    import shapely

    gcps = ev.control_points("gcp")
    if len(gcps) < 3:
        return Outcome("fail", f"{len(gcps)} GCPs", "an envelope of GCPs outside the perimeter")
    inside = [g.id for g in gcps if shapely.contains_xy(view.area, g.x, g.y)]
    hull = shapely.Polygon([(g.x, g.y) for g in ev.ring_order(gcps)])
    hull = hull if hull.is_valid else shapely.convex_hull(hull)
    enclosed = shapely.intersection(view.area, hull).area / view.area.area
    ok = not inside and enclosed >= p["min_enclosed"]
    evidence = [f"GCP {i} lies inside the area" for i in inside]
    if enclosed < p["min_enclosed"]:
        evidence.append(f"the GCP polygon encloses only {_pct(enclosed)} of the area")
    return Outcome("pass" if ok else "fail", f"{len(gcps) - len(inside)} of {len(gcps)} outside, polygon encloses {_pct(enclosed)}",
                   f"all outside, enclosing >= {_pct(p['min_enclosed'])} of the area", evidence, [{"point": i} for i in inside])


@check("gcp_visibility", min_images=int)
def _visible(view, p, ev) -> Outcome:
    gcps = ev.control_points("gcp")
    if not gcps:
        return Outcome("fail", "no GCP", f"each GCP on >= {p['min_images']} photos")
    bad = [f"GCP {g.id}: {g.images} photos" for g in gcps if g.images < p["min_images"]]
    fewest = min(g.images for g in gcps)
    return Outcome("pass" if not bad else "fail", f"{fewest} photos (fewest)", f">= {p['min_images']} photos on each GCP", bad,
                   [{"point": g.id} for g in gcps if g.images < p["min_images"]])


@check("gcp_count", formula=str)
def _gcp_count(view, p, ev) -> Outcome:
    n = len(view.station_ids)
    need = math.ceil(evaluate_formula(p["formula"], n_images=n, area_ha=view.area_ha, area_km2=view.area_ha / 100))
    have = len(ev.control_points("gcp"))
    return Outcome("pass" if have >= need else "fail", f"{have} GCPs", f">= {need} ({p['formula']} with n_images = {n})")


@check("target_size", factor=NUM)
def _target(view, p, ev) -> Outcome:
    cam = view.camera
    gsd = float(view.agl.max()) * cam["pixel_pitch_um"] / 1000.0 / cam["focal_mm"]
    return Outcome("info", f"targets of at least {p['factor'] * gsd * 100:.1f} cm", f"{p['factor']:g} x GSD ({gsd * 100:.2f} cm)")


@check("check_point_density", ha_per_point=NUM)
def _cp_density(view, p, ev) -> Outcome:
    cps = ev.control_points("check")
    need = math.ceil(view.area_ha / p["ha_per_point"] - 1e-9)
    return Outcome("pass" if len(cps) >= need else "fail", f"{len(cps)} check points",
                   f">= {need} (1 per {p['ha_per_point']:g} ha over {view.area_ha:.1f} ha)")


ASPRS_2014 = [(500, 20, 25), (750, 25, 30), (1000, 30, 40), (1250, 35, 50), (1500, 40, 60), (1750, 45, 70),
              (2000, 50, 80), (2250, 55, 90), (2500, 60, 100)]


def asprs_required(edition: str, area_km2: float) -> tuple[int, int]:
    """(horizontal, vertical) check points recommended for the project area.

    2014: Table C.1 of the standard (shared/reference/asprs2014_checkpoint_counts.csv);
    beyond 2,500 km² vertical +5 per 500 km², horizontal by agreement (kept at 60).
    2023 (Edition 2): the accuracy module's table (qa/asprs.py, with its sources).
    """
    if edition == "2023":
        from aerosurvey.qa.asprs import required_2023

        r = required_2023(area_km2)
        return r.horizontal, r.total
    for limit, h, v in ASPRS_2014:
        if area_km2 <= limit:
            return h, v
    extra = math.ceil((area_km2 - 2500) / 500)
    return 60, 100 + 5 * extra


@check("asprs_check_points", edition=str)
def _asprs(view, p, ev) -> Outcome:
    if p["edition"] not in ("2014", "2023"):
        raise InputError(f"asprs_check_points: edition = {p['edition']!r}; allowed: 2014, 2023")
    h, v = asprs_required(p["edition"], view.area_ha / 100)
    have = len(ev.control_points("check"))
    return Outcome("pass" if have >= max(h, v) else "fail", f"{have} check points",
                   f">= {h} horizontal and {v} vertical (ASPRS {p['edition']}, {view.area_ha / 100:.3f} km2)")


@check("check_point_distribution", min_quadrant_share=NUM, min_spacing_diagonal=NUM)
def _distribution(view, p, ev) -> Outcome:
    import numpy as np

    cps = ev.control_points("check")
    if len(cps) < 4:
        return Outcome("fail", f"{len(cps)} check points", "points in every quadrant of the area")
    x = np.array([c.x for c in cps])
    y = np.array([c.y for c in cps])
    x0, y0, x1, y1 = view.area.bounds
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    quads = [((x >= cx) & (y >= cy)).mean(), ((x < cx) & (y >= cy)).mean(), ((x < cx) & (y < cy)).mean(), ((x >= cx) & (y < cy)).mean()]
    d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
    d[np.diag_indices_from(d)] = np.inf
    diag = math.hypot(x1 - x0, y1 - y0)
    closest = float(d.min())
    evidence = []
    if min(quads) < p["min_quadrant_share"]:
        evidence.append("quadrant shares NE/NW/SW/SE: " + ", ".join(_pct(q) for q in quads))
    if closest < p["min_spacing_diagonal"] * diag:
        evidence.append(f"closest pair {closest:.0f} m apart, under {_pct(p['min_spacing_diagonal'])} of the {diag:.0f} m diagonal")
    return Outcome("pass" if not evidence else "fail", f"fewest in a quadrant {_pct(min(quads))}, closest pair {closest:.0f} m",
                   f">= {_pct(p['min_quadrant_share'])} per quadrant, >= {p['min_spacing_diagonal'] * diag:.0f} m apart", evidence)


@check("manual", note=str)
def _manual(view, p, ev) -> Outcome:
    return Outcome("not-checkable", "-", p["note"], ["recorded as metadata; not checkable before flight"])


_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
        ast.FloorDiv: operator.floordiv, ast.Pow: operator.pow, ast.USub: operator.neg}
_FUNCS = {"ceil": math.ceil, "floor": math.floor, "min": min, "max": max, "round": round, "sqrt": math.sqrt}
_NAMES = ("n_images", "area_ha", "area_km2")


def compile_formula(text: str, where: str) -> ast.Expression:
    """Parse a rule formula; only arithmetic, numbers, the names n_images, area_ha, area_km2
    and ceil/floor/min/max/round/sqrt are allowed."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError:
        raise InputError(f"{where}: formula {text!r} is not an expression") from None
    for node in ast.walk(tree):
        ok = isinstance(node, (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Call, ast.Load, ast.operator, ast.unaryop)) \
            or (isinstance(node, ast.Constant) and isinstance(node.value, (int, float))) \
            or (isinstance(node, ast.Name) and (node.id in _NAMES or node.id in _FUNCS))
        if isinstance(node, ast.BinOp) and type(node.op) not in _OPS:
            ok = False
        if isinstance(node, ast.Call) and not (isinstance(node.func, ast.Name) and node.func.id in _FUNCS):
            ok = False
        if not ok:
            raise InputError(f"{where}: formula {text!r} may use only numbers, + - * / // **, {', '.join(_NAMES)} and {', '.join(_FUNCS)}")
    return tree


def evaluate_formula(text: str, **names: float) -> float:
    tree = compile_formula(text, "formula")

    def ev(node: ast.AST) -> Any:
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.Name):
            return names[node.id]
        if isinstance(node, ast.BinOp):
            return _OPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp):
            return _OPS[type(node.op)](ev(node.operand))
        if isinstance(node, ast.Call):
            return _FUNCS[node.func.id](*[ev(a) for a in node.args])
        raise InputError(f"formula {text!r}: unsupported element")

    return float(ev(tree))
