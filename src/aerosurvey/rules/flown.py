"""A plan's rules judged on what was flown: the same checks over a second view of the plan.

The flown view is the plan's view (area, zones, camera, manifest) with the flown photos in
place of the planned stations (`aerosurvey.flight.coverage.flown_view`), so every check runs
unchanged on it: one rule implementation, two views. The footprints are the rules' own
(`aerosurvey.rules.footprints`: nadir rectangles from the camera and each photo's height
above ground, turned to its heading). The control points stay where the plan put them
(its control_points.geojson, or the layout `check` proposes on the planned photos) and each
is counted again on the flown photos: a GCP the flight left short of photos fails there.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey.errors import InputError
from aerosurvey.rules import footprints as fpm
from aerosurvey.rules.checks import Where
from aerosurvey.rules.cp_files import layout_points
from aerosurvey.rules.engine import Evidence, RuleResult, evaluate, layout_settings
from aerosurvey.rules.planview import PlanView
from aerosurvey.rules.profile import Profile, Rule

#: The layer of failing places `aerosurvey check FLIGHT_FOLDER` writes into the flight folder
#: (`failing_places` makes it, `read_places` reads it), and the role of its features.
PLACES_FILE = "failing_places.geojson"
PLACE_ROLE = "failing-place"


def planner_profile() -> Profile:
    """The planner's own rule (uncovered-ground) as a profile, for a flight checked without one: the
    planner measures it exactly from its stations' footprints next to the zones; on flown photos it
    is measured the way `coverage_min_images` measures, on sample points of the area outside the
    zones, planned and flown alike."""
    from aerosurvey.plan.coverage import MIN_IMAGES, PLANNER_PROFILE, UNCOVERED_RULE, UNCOVERED_STATEMENT

    rule = Rule(UNCOVERED_RULE, UNCOVERED_STATEMENT, "coverage_min_images", "error",
                "aerosurvey planner (plan/coverage.py), on sample points of the area", {"min": MIN_IMAGES})
    return Profile(PLANNER_PROFILE, "the planner's own rule", "aerosurvey", (rule,), "")


def plan_evidence(view: PlanView, profiles: list[Profile], folder: Path | None) -> Evidence:
    """The evidence `check` builds for a plan: the control points of the plan folder's
    control_points.geojson when it has one (each counted on the planned photos with the
    footprints the evidence measures once for every check), else those proposed on the planned photos."""
    f = folder / "control_points.geojson" if folder is not None else None
    if f is not None and f.is_file():
        layout = layout_points(f.read_text(encoding="utf-8"), view, str(f))
        return Evidence(view, layout_settings(view, profiles), layout, count_layout=True)
    return Evidence(view, layout_settings(view, profiles))


def on_view(base: Evidence, view: PlanView) -> Evidence:
    """The evidence of another view of the same plan (the flown photos, one sortie's stations):
    the base's control points where they are, each counted again on the view's photos (with
    the footprints the view's evidence measures once for every check)."""
    return Evidence(view, base.settings, base.points, count_layout=True)


def part(view: PlanView, station_ids: Sequence[str]) -> PlanView:
    """The view with only the given stations (one sortie's), in their planned order."""
    keep = set(station_ids)
    idx = np.array([i for i, s in enumerate(view.station_ids) if s in keep], np.intp)
    return dataclasses.replace(view, station_ids=[view.station_ids[i] for i in idx],
                               run_ids=[view.run_ids[i] for i in idx], x=view.x[idx], y=view.y[idx],
                               agl=view.agl[idx], heading_deg=view.heading_deg[idx], pitch_deg=view.pitch_deg[idx],
                               camera_yaw_deg=view.camera_yaw_deg[idx])


@dataclass(frozen=True)
class Judged:
    """One rule as planned and as flown; the verdict is the flown one."""

    planned: RuleResult
    flown: RuleResult

    @property
    def status(self) -> str:
        return self.flown.status

    def line(self) -> str:
        """``rule: planned X / flown Y VERDICT (required …)``."""
        p, f = self.planned, self.flown
        was = ""
        if f.status != p.status and p.status == "pass":
            was = "; passed as planned"
        elif f.status == p.status and f.outcome.status == "fail":
            was = "; fails as planned too"
        return (f"{f.rule}: planned {p.outcome.measured} / flown {f.outcome.measured} {f.status.upper()} "
                f"(required {f.outcome.required}{was})")

    def as_dict(self) -> dict[str, Any]:
        """The flown result as `check --json` gives it, with the planned status and measure."""
        return {**self.flown.as_dict(), "planned": {"status": self.planned.status, "measured": self.planned.outcome.measured}}


def judge(profiles: list[Profile], planned: list[RuleResult], flown: Evidence) -> list[Judged]:
    """The profiles' rules evaluated on the flown evidence, each beside its planned result."""
    after = evaluate(profiles, flown)
    if [(r.profile, r.rule) for r in after] != [(r.profile, r.rule) for r in planned]:
        raise ValueError("the planned and flown results are not of the same rules")  # a bug: both come from `profiles`
    return [Judged(a, b) for a, b in zip(planned, after)]


def failing_places(judged: list[Judged], flown: Evidence) -> dict[str, Any]:
    """GeoJSON (WGS84) of where each failing rule fails on the flown photos: a run as the line
    through its photos, two runs as both lines, a photo, a control point or a sample point of
    the area as a point; a rule that fails nowhere in particular (a count, the camera) as a
    feature without geometry. Each feature names its rule, the planned and flown measures."""
    view = flown.view
    runs = fpm.runs(view)
    photo = {sid: i for i, sid in enumerate(view.station_ids)}
    points = {p.id: p for p in flown.points}
    lon, lat = (np.asarray(a, float) for a in view.to_wgs84.transform(view.x, view.y))

    def lonlat(x: float, y: float) -> list[float]:
        a, b = view.to_wgs84.transform(x, y)
        return [round(float(a), 8), round(float(b), 8)]

    def run_line(rid: str) -> list[list[float]]:
        idx = runs.get(rid, np.empty(0, np.intp))
        return [[round(float(lon[i]), 8), round(float(lat[i]), 8)] for i in idx]

    def place(w: Where) -> tuple[dict[str, Any] | None, dict[str, Any]]:
        if "run" in w:
            line = run_line(w["run"])
            geom = {"type": "LineString", "coordinates": line} if len(line) > 1 else \
                {"type": "Point", "coordinates": line[0]} if line else None
            return geom, {"place": "run", "run": w["run"]}
        if "runs" in w:
            lines = [ln for ln in (run_line(r) for r in w["runs"]) if len(ln) > 1]
            return ({"type": "MultiLineString", "coordinates": lines} if lines else None), {"place": "runs", "runs": w["runs"]}
        if "station" in w:
            i = photo[w["station"]]
            return {"type": "Point", "coordinates": [round(float(lon[i]), 8), round(float(lat[i]), 8)]}, \
                {"place": "photo", "photo": w["station"], "agl_m": round(float(view.agl[i]), 2)}
        if "point" in w:
            p = points[w["point"]]
            return {"type": "Point", "coordinates": lonlat(p.x, p.y)}, {"place": "control point", "point": p.id,
                                                                          "images": p.images}
        if "xy" in w:
            return {"type": "Point", "coordinates": lonlat(*w["xy"])}, {"place": "sample point"}
        raise ValueError(f"rule result place {w!r} is of no known kind (run, runs, station, point, xy)")

    features = []
    for j in judged:
        r = j.flown
        if r.outcome.status != "fail":
            continue
        props = {"role": PLACE_ROLE, "profile": r.profile, "rule": r.rule, "status": r.status,
                 "severity": r.severity, "statement": r.statement, "planned": j.planned.outcome.measured,
                 "flown": r.outcome.measured, "required": r.outcome.required}
        for w in r.outcome.where or [Where()]:
            geom, where = place(w) if w else (None, {"place": "none"})
            features.append({"type": "Feature", "properties": {**props, **where}, "geometry": geom})
    return {"type": "FeatureCollection", "name": "failing_places", "features": features}


@dataclass(frozen=True)
class FailingRule:
    """One rule of a failing-places layer: what it says, its measures and how many places it fails at."""

    rule: str
    status: str
    statement: str
    planned: str
    flown: str
    required: str
    places: int


@dataclass(frozen=True)
class Places:
    drawn: list[dict[str, Any]]  # the features that have a geometry (WGS84)
    rules: tuple[FailingRule, ...]


def read_places(path: Path) -> Places:
    """A failing-places layer as `failing_places` writes it; InputError in one line otherwise."""
    try:
        feats = [f for f in json.loads(path.read_text(encoding="utf-8"))["features"]
                 if f["properties"].get("role") == PLACE_ROLE]
        counts: dict[str, int] = {}
        first: dict[str, dict[str, Any]] = {}
        for f in feats:
            p = f["properties"]
            counts[p["rule"]] = counts.get(p["rule"], 0) + 1
            first.setdefault(p["rule"], p)
        rules = tuple(FailingRule(r, str(p["status"]), str(p["statement"]), str(p["planned"]), str(p["flown"]),
                                  str(p["required"]), counts[r]) for r, p in first.items())
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise InputError(f"{path.name} is not what `aerosurvey check FLIGHT_FOLDER` writes: {exc!r}") from None
    return Places([f for f in feats if f.get("geometry")], rules)
