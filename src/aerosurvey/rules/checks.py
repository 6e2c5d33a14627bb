"""The checks a rule can name. Each takes the plan view, the rule's parameters and the
shared evidence, and returns an outcome with the measured value, the required one and
the evidence (which line, which crossing, which point, how many images)."""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypedDict

import numpy as np
import numpy.typing as npt
import shapely

from aerosurvey.errors import InputError
from aerosurvey.rules.footprints import ViewCamera, coarsest_gsd_m
from aerosurvey.rules.planview import PlanView
from aerosurvey.rules.profile import ParamValue

if TYPE_CHECKING:  # engine.py imports this module
    from aerosurvey.rules.engine import Evidence


class Where(TypedDict, total=False):
    """Where on the map a failure lies, for a viewer to highlight (one key per entry)."""

    run: str
    runs: list[str]
    station: str
    point: str  # control point id
    xy: list[float]  # planning CRS


@dataclass(frozen=True)
class Outcome:
    """What a check found: its status, the measured and required values as text, evidence and where."""

    status: str  # pass, fail, info, not-checkable
    measured: str
    required: str
    evidence: list[str] = field(default_factory=list)
    where: list[Where] = field(default_factory=list)


@dataclass(frozen=True)
class Params:
    """A rule's parameters (defaults filled in), read with the type the check declared."""

    values: Mapping[str, ParamValue]

    def _get(self, key: str) -> ParamValue:
        if key not in self.values:
            raise InputError(f"rule parameter {key!r} is missing")
        return self.values[key]

    def num(self, key: str) -> float:
        v = self._get(key)
        if isinstance(v, str):
            raise InputError(f"rule parameter {key!r} = {v!r} must be a number")
        return v

    def whole(self, key: str) -> int:
        v = self._get(key)
        if not isinstance(v, int):
            raise InputError(f"rule parameter {key!r} = {v!r} must be a whole number")
        return v

    def text(self, key: str) -> str:
        v = self._get(key)
        if not isinstance(v, str):
            raise InputError(f"rule parameter {key!r} = {v!r} must be a string")
        return v


CheckFn = Callable[[PlanView, Params, "Evidence"], Outcome]


@dataclass(frozen=True)
class Check:
    """A check the profiles may name: the parameters it takes (and their defaults) and the function that runs it."""

    params: dict[str, type | tuple[type, ...]]
    run: CheckFn
    defaults: dict[str, ParamValue] = field(default_factory=dict)

    def validate(self, params: Mapping[str, object], where: str) -> dict[str, ParamValue]:
        """The parameters a profile gives, checked against what this check takes."""
        for key in params:
            if key not in self.params:
                raise InputError(f"{where}: unknown parameter {key!r}; this check takes {', '.join(sorted(self.params)) or 'none'}")
        for key, typ in self.params.items():
            if key not in params and key not in self.defaults:
                raise InputError(f"{where}: parameter {key!r} is missing")
            v = params.get(key, self.defaults.get(key))
            if isinstance(v, bool) or not isinstance(v, typ):
                raise InputError(f"{where}: parameter {key!r} = {v!r} must be a {getattr(typ, '__name__', 'number')}")
        out: dict[str, ParamValue] = {}
        for key, v in params.items():
            if not isinstance(v, (int, float, str)):  # the declared types are all of these
                raise InputError(f"{where}: parameter {key!r} = {v!r} must be a number or a string")
            out[key] = v
        formula = out.get("formula")
        if isinstance(formula, str):
            compile_formula(formula, where)
        return out


NUM = (int, float)
CHECKS: dict[str, Check] = {}


def check(name: str, defaults: dict[str, ParamValue] | None = None, **params: type | tuple[type, ...]) -> Callable[[CheckFn], CheckFn]:
    def deco(fn: CheckFn) -> CheckFn:
        CHECKS[name] = Check(params, fn, defaults or {})
        return fn

    return deco


def _flatnonzero(mask: npt.ArrayLike) -> list[int]:
    return [int(i) for i in np.flatnonzero(np.asarray(mask))]


def _pct(v: float) -> str:
    return f"{100 * v:.1f} %"


@check("sensor_min_size", min_long_mm=NUM, min_short_mm=NUM)
def _sensor(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    cam = ViewCamera.of(view).camera
    w, h = cam.sensor_width_mm, cam.sensor_height_mm
    ok = w >= p.num("min_long_mm") and h >= p.num("min_short_mm")
    return Outcome("pass" if ok else "fail", f"{w:g} x {h:g} mm ({cam.name})",
                   f">= {p.num('min_long_mm'):g} x {p.num('min_short_mm'):g} mm")


@check("pixel_pitch_max", max_um=NUM)
def _pitch(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    cam = ViewCamera.of(view).camera
    pitch = cam.pixel_pitch_um
    return Outcome("pass" if pitch <= p.num("max_um") + 1e-9 else "fail", f"{pitch:.2f} um ({cam.name})", f"<= {p.num('max_um'):g} um")


@check("forward_overlap_min", min=NUM)
def _fwd(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    per_run = ev.forward_overlaps
    least = p.num("min")
    if not per_run:
        return Outcome("fail", "no run with two photos", f">= {_pct(least)}")
    worst = min(per_run, key=lambda t: t[1])
    low = [(rid, v) for rid, v in per_run if v < least - 1e-9]
    bad = [f"{rid}: {_pct(v)}" for rid, v in low]
    return Outcome("pass" if not bad else "fail", f"{_pct(worst[1])} (lowest, run {worst[0]})", f">= {_pct(least)}",
                   bad[:20] + ([f"... and {len(bad) - 20} more runs"] if len(bad) > 20 else []),
                   [{"run": rid} for rid, _ in low])


@check("side_overlap_min", min=NUM)
def _side(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    pairs = ev.side_overlaps
    least = p.num("min")
    if not pairs:
        return Outcome("not-checkable", "a single strip", f">= {_pct(least)}", ["one strip has no side neighbour"])
    worst = min(pairs, key=lambda t: t[2])
    low = [(a, b, v) for a, b, v in pairs if v < least - 1e-9]
    bad = [f"{a} / {b}: {_pct(v)}" for a, b, v in low]
    return Outcome("pass" if not bad else "fail", f"{_pct(worst[2])} (lowest, runs {worst[0]} / {worst[1]})",
                   f">= {_pct(least)}", bad[:20], [{"runs": [a, b]} for a, b, _ in low])


@check("gsd_max", max_cm=NUM)
def _gsd(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    most = p.num("max_cm")
    gsd_all = ViewCamera.of(view).gsd_m(view.agl, view.pitch_deg) * 100
    if not np.isfinite(gsd_all).any():
        return Outcome("not-checkable", "no photo's centre meets the ground (a level camera)", f"<= {most:g} cm",
                       ["the ground GSD is that of photos looking down; the faces' GSD is the structure-faces rule's"])
    gsd = float(np.nanmax(gsd_all))
    where: list[Where] = [{"station": view.station_ids[i]} for i in _flatnonzero(gsd_all > most + 1e-9)]
    return Outcome("pass" if gsd <= most + 1e-9 else "fail", f"{gsd:.2f} cm (coarsest photo)", f"<= {most:g} cm",
                   where=where)


@check("images_beyond_boundary", min=int)
def _beyond(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    least = p.whole("min")
    found = ev.crossings(least)
    if not found:
        return Outcome("fail", "no run crosses the area", f">= {least} photos outside at every crossing")
    bad = [f"{c.run} {c.where}: {c.outside_photos} photos outside" for c in found if not c.ok]
    counted = [c.outside_photos for c in found if c.where in ("entry", "exit")]
    return Outcome("pass" if not bad else "fail", f"{min(counted)} photos (fewest, over {len(counted)} crossings)",
                   f">= {least} at every crossing", bad[:30] + ([f"... and {len(bad) - 30} more"] if len(bad) > 30 else []),
                   [{"run": c.run} for c in found if not c.ok])


@check("coverage_min_images", min=int)
def _coverage(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    least = p.whole("min")
    counts, gx, gy = ev.grid_counts
    worst = int(counts.argmin())
    short = int((counts < least).sum())
    evidence = [f"{short} of {len(counts)} sample points seen by fewer photos; "
                f"the worst at x {gx[worst]:.1f}, y {gy[worst]:.1f}"] if short else []
    where: list[Where] = [{"xy": [round(float(gx[i]), 2), round(float(gy[i]), 2)]} for i in _flatnonzero(counts < least)[:500]]
    return Outcome("pass" if short == 0 else "fail", f"{int(counts.min())} photos (fewest, {len(counts)} sample points)",
                   f">= {least} photos on every point of the area", evidence, where)


@check("max_height_agl", max_m=NUM)
def _height(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    most = p.num("max_m")
    h = float(view.agl.max())
    where: list[Where] = [{"station": view.station_ids[i]} for i in _flatnonzero(view.agl > most + 1e-6)]
    return Outcome("pass" if h <= most + 1e-6 else "fail", f"{h:.1f} m (highest photo above ground)", f"<= {most:g} m", where=where)


@check("gcp_outside_envelope", defaults={"min_enclosed": 0.98}, min_enclosed=NUM)
def _envelope(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    least = p.num("min_enclosed")
    gcps = ev.control_points("gcp")
    if len(gcps) < 3:
        return Outcome("fail", f"{len(gcps)} GCPs", "an envelope of GCPs outside the perimeter")
    inside = [g.id for g in gcps if shapely.contains_xy(view.area, g.x, g.y)]
    hull = shapely.Polygon([(g.x, g.y) for g in ev.ring_order(gcps)])
    hull = hull if hull.is_valid else shapely.convex_hull(hull)
    enclosed = shapely.intersection(view.area, hull).area / view.area.area
    ok = not inside and enclosed >= least
    evidence = [f"GCP {i} lies inside the area" for i in inside]
    if enclosed < least:
        evidence.append(f"the GCP polygon encloses only {_pct(enclosed)} of the area")
    return Outcome("pass" if ok else "fail", f"{len(gcps) - len(inside)} of {len(gcps)} outside, polygon encloses {_pct(enclosed)}",
                   f"all outside, enclosing >= {_pct(least)} of the area", evidence, [{"point": i} for i in inside])


@check("gcp_visibility", min_images=int)
def _visible(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    least = p.whole("min_images")
    gcps = ev.control_points("gcp")
    if not gcps:
        return Outcome("fail", "no GCP", f"each GCP on >= {least} photos")
    bad = [f"GCP {g.id}: {g.images} photos" for g in gcps if g.images < least]
    fewest = min(g.images for g in gcps)
    return Outcome("pass" if not bad else "fail", f"{fewest} photos (fewest)", f">= {least} photos on each GCP", bad,
                   [{"point": g.id} for g in gcps if g.images < least])


@check("gcp_count", formula=str)
def _gcp_count(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    formula = p.text("formula")
    n = len(view.station_ids)
    need = math.ceil(evaluate_formula(formula, n_images=n, area_ha=view.area_ha, area_km2=view.area_ha / 100))
    have = len(ev.control_points("gcp"))
    return Outcome("pass" if have >= need else "fail", f"{have} GCPs", f">= {need} ({formula} with n_images = {n})")


@check("target_size", factor=NUM)
def _target(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    factor = p.num("factor")
    gsd = coarsest_gsd_m(view)
    return Outcome("info", f"targets of at least {factor * gsd * 100:.1f} cm", f"{factor:g} x GSD ({gsd * 100:.2f} cm)")


#: Photos that must see a check point for it to count: a point is measured from two photos at least.
CHECK_POINT_MIN_IMAGES = 2


def _check_points(ev: Evidence, need: int, required: str) -> Outcome:
    """At least `need` check points that photos can measure; where: those too few photos see."""
    cps = ev.control_points("check")
    unseen = [c for c in cps if c.images < CHECK_POINT_MIN_IMAGES]
    have = len(cps) - len(unseen)
    measured = f"{have} check points" + (f" ({len(unseen)} more seen by fewer than {CHECK_POINT_MIN_IMAGES} photos)"
                                          if unseen else "")
    if have >= need:
        return Outcome("pass", measured, required)
    return Outcome("fail", measured, required, [f"check point {c.id}: seen by {c.images} photos" for c in unseen][:20],
                   [{"point": c.id} for c in unseen])


@check("check_point_density", ha_per_point=NUM)
def _cp_density(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    ha = p.num("ha_per_point")
    need = math.ceil(view.area_ha / ha - 1e-9)
    return _check_points(ev, need, f">= {need} (1 per {ha:g} ha over {view.area_ha:.1f} ha)")


ASPRS_2014 = [(500, 20, 25), (750, 25, 30), (1000, 30, 40), (1250, 35, 50), (1500, 40, 60), (1750, 45, 70),
              (2000, 50, 80), (2250, 55, 90), (2500, 60, 100)]


def asprs_required(edition: str, area_km2: float) -> tuple[int, int]:
    """(horizontal, vertical) check points recommended for the project area.

    2014: Table C.1 of the standard (Korumaz and Yıldız, Heritage 4 (2021), Table 5);
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
def _asprs(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    edition = p.text("edition")
    if edition not in ("2014", "2023"):
        raise InputError(f"asprs_check_points: edition = {edition!r}; allowed: 2014, 2023")
    h, v = asprs_required(edition, view.area_ha / 100)
    return _check_points(ev, max(h, v), f">= {h} horizontal and {v} vertical (ASPRS {edition}, {view.area_ha / 100:.3f} km2)")


@check("check_point_distribution", min_quadrant_share=NUM, min_spacing_diagonal=NUM)
def _distribution(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    share, spacing = p.num("min_quadrant_share"), p.num("min_spacing_diagonal")
    cps = ev.control_points("check")
    if len(cps) < 4:
        return Outcome("fail", f"{len(cps)} check points", "points in every quadrant of the area")
    x = np.array([c.x for c in cps])
    y = np.array([c.y for c in cps])
    x0, y0, x1, y1 = view.area.bounds
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    quads = [float(((x >= cx) & (y >= cy)).mean()), float(((x < cx) & (y >= cy)).mean()),
             float(((x < cx) & (y < cy)).mean()), float(((x >= cx) & (y < cy)).mean())]
    d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
    d[np.diag_indices_from(d)] = np.inf
    diag = math.hypot(x1 - x0, y1 - y0)
    closest = float(d.min())
    evidence = []
    if min(quads) < share:
        evidence.append("quadrant shares NE/NW/SW/SE: " + ", ".join(_pct(q) for q in quads))
    if closest < spacing * diag:
        evidence.append(f"closest pair {closest:.0f} m apart, under {_pct(spacing)} of the {diag:.0f} m diagonal")
    return Outcome("pass" if not evidence else "fail", f"fewest in a quadrant {_pct(min(quads))}, closest pair {closest:.0f} m",
                   f">= {_pct(share)} per quadrant, >= {spacing * diag:.0f} m apart", evidence)


@check("manual", note=str)
def _manual(view: PlanView, p: Params, ev: Evidence) -> Outcome:
    return Outcome("not-checkable", "-", p.text("note"), ["recorded as metadata; not checkable before flight"])


_BINOPS: dict[type[ast.operator], Callable[[float, float], float]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv, ast.Pow: operator.pow}
_UNOPS: dict[type[ast.unaryop], Callable[[float], float]] = {ast.USub: operator.neg}
_FUNCS: dict[str, Callable[..., float]] = {"ceil": math.ceil, "floor": math.floor, "min": min, "max": max, "round": round,
                                           "sqrt": math.sqrt}
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
        if isinstance(node, ast.BinOp) and type(node.op) not in _BINOPS:
            ok = False
        if isinstance(node, ast.UnaryOp) and type(node.op) not in _UNOPS:
            ok = False
        if isinstance(node, ast.Call) and not (isinstance(node.func, ast.Name) and node.func.id in _FUNCS):
            ok = False
        if not ok:
            raise InputError(f"{where}: formula {text!r} may use only numbers, + - * / // **, {', '.join(_NAMES)} and {', '.join(_FUNCS)}")
    return tree


def evaluate_formula(text: str, **names: float) -> float:
    tree = compile_formula(text, "formula")

    def ev(node: ast.AST) -> float:
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return node.value
        if isinstance(node, ast.Name):
            return names[node.id]
        if isinstance(node, ast.BinOp):
            return _BINOPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp):
            return _UNOPS[type(node.op)](ev(node.operand))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            return _FUNCS[node.func.id](*[ev(a) for a in node.args])
        raise InputError(f"formula {text!r}: unsupported element")

    return float(ev(tree))
