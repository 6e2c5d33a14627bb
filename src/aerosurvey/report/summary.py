"""The plan's summary: the one set of figures `plan`, `check`, the preview and the web page show.

`plan_summary(manifest, rules)` makes it from the plan's manifest data (what `plan` writes,
what a plan folder holds, what `check` makes in memory from a spec) and the rule results
shown with it, rounded once to the digits it is shown with. `summary_text` writes it for a
terminal, `summary_json` for the web page; the preview draws its head from the same record.
Every count of rules is `RuleCount`'s, the planner's own rule (uncovered-ground) included.

Light on purpose (no numpy): `check` and `plan` import it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

#: failing rules named in a rules line (the rest are counted)
NAMED_FAILURES = 4


@dataclass(frozen=True)
class RuleCount:
    """Rule results by outcome. `failing`: the rules that fail or warn; `failed`: those that
    fail at error level (a `check` of the plan exits 1)."""

    evaluated: int
    passed: int
    failing: tuple[str, ...]
    failed: tuple[str, ...]

    @classmethod
    def of(cls, rules: Sequence[Mapping[str, Any]]) -> RuleCount:
        return cls(len(rules), sum(r["status"] == "pass" for r in rules),
                   tuple(r["rule"] for r in rules if r["status"] in ("fail", "warning")),
                   tuple(r["rule"] for r in rules if r["status"] == "fail"))

    def text(self) -> str:
        """"14 evaluated: 11 passed, 1 failing (cz-gsd)"."""
        names = ""
        if self.failing:
            more = len(self.failing) - NAMED_FAILURES
            names = f" ({', '.join(self.failing[:NAMED_FAILURES])}{f' and {more} more' if more > 0 else ''})"
        return f"{self.evaluated} evaluated: {self.passed} passed, {len(self.failing)} failing{names}"


@dataclass(frozen=True)
class SortieFigures:
    id: str
    photos: int
    time_min: float
    distance_km: float
    battery_pct: float  # of the whole battery, the reserve included
    first_station: str
    last_station: str
    wind_pct: float | None = None  # of the usable battery, what the wind takes (None: a plan written before conditions.wind)


@dataclass(frozen=True)
class Summary:
    """The plan's main figures, each rounded to the digits every view shows."""

    name: str
    area_ha: float
    crs: str
    camera: str
    height_agl_m: float
    terrain_mode: str  # "none": flat ground
    height_range_m: tuple[float, float]  # lowest and highest above the ground
    ground_min_m: float | None  # the lowest ground (AMSL) the heights are above: the area's, a structure's foot; None: no DEM
    gsd_cm: tuple[float, float]  # finest and coarsest
    gsd_target_cm: float
    footprint_m: tuple[float, float]  # across and along the line
    spacing_m: float
    photo_base_m: float
    trigger_distance_m: float | None
    trigger_interval_s: float | None
    speed_ms: float
    speed_limited_by: str
    speed_limits_ms: tuple[float, float, float]  # cruise, camera cycle, motion blur
    heading_deg: float
    heading_chosen: str
    cross_hatch: bool
    lines: int
    runs: int
    photos: int
    bounds: tuple[int, int] | None  # the fewest strips and photos for the guarantee (derived.bounds), None in older manifests
    route: tuple[str, ...]  # per pass, how its lines are ordered
    distance_km: float
    time_min: float
    sorties: tuple[SortieFigures, ...]
    wind: str | None  # the wind planned in ("5 m/s from 270 deg true, gusts 7 m/s"), None in still air
    sun_elevation_deg: tuple[float, float] | None
    mission_items: int
    rules: RuleCount
    # the terrain clearance (manifest "clearance"): the minimum and each flight's lowest; None without a DEM
    clearance: tuple[float, tuple[Mapping[str, Any], ...]] | None = None
    # a structure's faces as the photos see them (manifest "faces"), None for a plan of the ground only
    faces: Mapping[str, Any] | None = None
    # per pass whose body-fixed camera turns with the plane's crab (manifest pattern.passes crab_deg): (pass, degrees)
    crab_deg: tuple[tuple[int, float], ...] = ()


def plan_summary(manifest: Mapping[str, Any], rules: Sequence[Mapping[str, Any]]) -> Summary:
    """The summary of a plan from its manifest data (JSON as `manifest.json` holds it; stations
    not needed) and the rule results shown with it (manifest "rules" records)."""
    d, e = manifest["derived"], manifest["estimates"]
    sun = manifest.get("conditions")
    limits = d["speed_limits_ms"]
    return Summary(
        name=manifest["mission"]["name"], area_ha=round(d["area_ha"], 2), crs=manifest["crs"]["planning"],
        camera=manifest["camera"]["name"], height_agl_m=round(d["height_agl_m"], 1), terrain_mode=d["terrain"]["mode"],
        height_range_m=(round(d["lowest_agl_m"], 1), round(d["highest_agl_m"], 1)),
        ground_min_m=d["terrain"]["ground_min_m"],
        gsd_cm=(round(d["gsd_min_cm"], 2), round(d["gsd_max_cm"], 2)), gsd_target_cm=round(manifest["targets"]["gsd_cm"], 2),
        footprint_m=(round(d["footprint_across_m"], 1), round(d["footprint_along_m"], 1)),
        spacing_m=round(d["line_spacing_m"], 1), photo_base_m=round(d["photo_base_m"], 2),
        trigger_distance_m=None if d["trigger_distance_m"] is None else round(d["trigger_distance_m"], 2),
        trigger_interval_s=None if not d["trigger_interval_s"] else round(d["trigger_interval_s"], 2),
        speed_ms=round(d["speed_ms"], 1), speed_limited_by=d["speed_reason"],
        speed_limits_ms=(round(limits["cruise"], 1), round(limits["camera_cycle"], 1), round(limits["motion_blur"], 1)),
        heading_deg=round(d["heading_deg"], 1), heading_chosen=d["heading_chosen"], cross_hatch=bool(d["cross_hatch"]),
        lines=len({r["line"] for r in manifest["lines"]}), runs=len(manifest["lines"]), photos=int(e["photos"]),
        bounds=(int(d["bounds"]["strips"]), int(d["bounds"]["photos"])) if "bounds" in d else None,
        route=tuple(d["route_strategy"]),
        distance_km=round(e["total_distance_m"] / 1000, 2), time_min=round(e["total_time_s"] / 60, 1),
        sorties=tuple(SortieFigures(s["id"], s["photos"], round(s["time_s"] / 60, 1), round(s["distance_m"] / 1000, 2),
                                    round(s["battery_used_pct"], 1), s["first_station"], s["last_station"],
                                    None if "wind_used_pct" not in s else round(s["wind_used_pct"], 1))
                      for s in manifest["sorties"]),
        wind=_wind_text(manifest.get("wind")),
        sun_elevation_deg=None if sun is None else (round(sun["min_elevation_deg"], 2), round(sun["max_elevation_deg"], 2)),
        mission_items=int(manifest["mission_items"]), rules=RuleCount.of(rules),
        clearance=None if "clearance" not in manifest else (float(manifest["clearance"]["min_clearance_m"]),
                                                             tuple(manifest["clearance"]["flights"])),
        faces=manifest.get("faces"),
        crab_deg=tuple((int(p["pass"]), round(p["crab_deg"], 1)) for p in manifest["pattern"]["passes"] if "crab_deg" in p),
    )


def _wind_text(wind: Mapping[str, float] | None) -> str | None:
    if wind is None:
        return None
    gusts = f", gusts {wind['gust_ms']:g} m/s" if wind["gust_ms"] > wind["speed_ms"] else ""
    return f"{wind['speed_ms']:g} m/s from {wind['from_deg']:g} deg true{gusts}"


def summary_text(s: Summary, check_command: str | None = None) -> list[str]:
    """The summary as terminal lines; `check_command`, the command that shows the rules' evidence."""
    height = ("flat ground, no DEM" if s.terrain_mode == "none"
              else f"terrain mode {s.terrain_mode}; {s.height_range_m[0]:.1f}..{s.height_range_m[1]:.1f} m above the ground")
    cruise, cycle, blur = s.speed_limits_ms
    lines = [f"mission {s.name}: {s.area_ha:.2f} ha in {s.crs}, camera {s.camera}", *_height_and_gsd(s, height)]
    lines += [
        f"  footprint       {s.footprint_m[0]:.1f} m across x {s.footprint_m[1]:.1f} m along",
        f"  line spacing    {s.spacing_m:.1f} m, photo base {s.photo_base_m:.2f} m"
        + (f", trigger distance {s.trigger_distance_m:.2f} m" if s.trigger_distance_m is not None else "")
        + (f", interval {s.trigger_interval_s:.2f} s" if s.trigger_interval_s else ""),
        f"  max speed       {s.speed_ms:.1f} m/s, limited by {s.speed_limited_by} (cruise {cruise:.1f}, "
        f"camera cycle {cycle:.1f}, motion blur {blur:.1f} m/s)",
        f"  heading         {s.heading_deg:.1f} deg ({s.heading_chosen})" + (", cross-hatch at +90 deg" if s.cross_hatch else ""),
        f"  lines           {s.lines} lines in {s.runs} runs, {s.photos} photos",
    ]
    if s.bounds is not None:
        lines.append(f"  lower bounds    strips {s.lines} (bound {s.bounds[0]}), photos {s.photos} (bound {s.bounds[1]})")
    lines += [
        "  route           " + "; ".join(f"pass {i}: {how}" for i, how in enumerate(s.route, start=1)),
        f"  flight          {s.distance_km:.2f} km, {s.time_min:.1f} min estimated",
    ]
    if s.wind is not None:
        lines.append(f"  wind            {s.wind} (each leg timed at its ground speed)")
    if s.crab_deg:
        lines.append("  crab            " + "; ".join(f"pass {i}: {c:.1f} deg" for i, c in s.crab_deg)
                     + f" (the camera fixed to the body turns with it: line spacing {s.spacing_m:.1f} m and photo base "
                     f"{s.photo_base_m:.2f} m keep the overlaps under it)")
    if s.sorties:
        windy = s.wind is not None and all(x.wind_pct is not None for x in s.sorties)
        lines.append("  sorties         id   photos  time min  dist km  battery %" + ("  wind %" if windy else "")
                     + "  first station -> last station")
        lines += [f"                  {x.id} {x.photos:7d} {x.time_min:9.1f} {x.distance_km:8.2f} {x.battery_pct:10.1f}  "
                  + (f"{x.wind_pct:6.1f}  " if windy else "") + f"{x.first_station} -> {x.last_station}" for x in s.sorties]
    if s.clearance is not None:
        least, flights = s.clearance
        lines.append(f"  clearance       the lowest above the DEM along the legs, per flight (terrain.min_clearance_m {least:g} m)")
        lines += [f"                  {w['flight']}: {w['clearance_m']:.1f} m on the leg to point {w['seq']} ({w['what']}), "
                  f"{w['along_m']:.0f} m along it" for w in flights]
    if s.sun_elevation_deg is not None:
        lines.append(f"  sun elevation   {s.sun_elevation_deg[0]:.2f}..{s.sun_elevation_deg[1]:.2f} deg over the planned window")
    hint = f" (`{check_command}` for the evidence)" if check_command else ""
    lines.append(f"  rules           {s.rules.text()}{hint}")
    return lines


def _height_and_gsd(s: Summary, height: str) -> list[str]:
    """The height and GSD lines: the nadir figures, and a structure's faces as its photos see them;
    a plan that takes no photo straight down (an orbit, a facade) is given by its faces alone."""
    f = s.faces
    nadir = [f"  height AGL      {s.height_agl_m:.1f} m ({height})",
             f"  GSD             {s.gsd_cm[0]:.2f}..{s.gsd_cm[1]:.2f} cm (target {s.gsd_target_cm:.2f} cm)"]
    if f is None:
        return nadir
    agl = "" if f["station_agl_m"] is None else f"{f['station_agl_m'][0]:.1f}..{f['station_agl_m'][1]:.1f} m"
    gsd = "no point seen" if f["gsd_cm"] is None else f"{f['gsd_cm'][0]:.2f}..{f['gsd_cm'][1]:.2f} cm"
    limit = "" if f["max_gsd_cm"] is None else f", at most {f['max_gsd_cm']:.2f} cm counted"
    faces = [f"  faces           {f['area_m2']:.0f} m2, each point asked {f['min_images']} photos{limit}: fewest "
             f"{f['fewest_images']}, {f['short_m2']:.2f} m2 short",
             f"  GSD on faces    {gsd}"]
    if f["nadir_photos"]:
        return nadir + faces
    if s.ground_min_m is not None:  # a structure over a DEM: its heights above the ground it stands on
        height = f"terrain mode {s.terrain_mode}: heights above the structure's foot, {s.ground_min_m:.1f} m"
    return [f"  photos taken    {agl} above the ground ({height}), none straight down", *faces]


def _span(r: Sequence[float], unit: str) -> str:
    return f"{r[0]:.2f} {unit}" if r[0] == r[1] else f"{r[0]:.2f}..{r[1]:.2f} {unit}"


def title_figures(s: Summary) -> str:
    """The height and GSD in a title ("12.0 m AGL, GSD 0.53 cm"): for a plan that takes no photo straight
    down (an orbit, a facade), the heights its photos are taken at and the GSD on the faces they see."""
    f = s.faces
    if f is None or f["nadir_photos"]:
        return f"{s.height_agl_m:.1f} m AGL, GSD {_span(s.gsd_cm, 'cm')}"
    agl = "no photo" if f["station_agl_m"] is None else f"photos {f['station_agl_m'][0]:.1f}..{f['station_agl_m'][1]:.1f} m AGL"
    return f"{agl}, GSD on faces " + ("none seen" if f["gsd_cm"] is None else _span(f["gsd_cm"], "cm"))


def _faces_json(f: Mapping[str, Any] | None) -> dict[str, Any] | None:
    """A structure's faces (manifest "faces") as the summary gives them: their area, the area short of photos, the
    heights the photos are taken at and the GSD on the faces, rounded as printed; None for a plan of the ground only."""
    if f is None:
        return None

    def rounded(r: Sequence[float] | None, digits: int) -> list[float] | None:
        return None if r is None else [round(r[0], digits), round(r[1], digits)]
    return {"area_m2": round(f["area_m2"]), "short_m2": round(f["short_m2"], 2), "min_images": f["min_images"],
            "fewest_images": f["fewest_images"], "station_agl_m": rounded(f["station_agl_m"], 1),
            "gsd_cm": rounded(f["gsd_cm"], 2), "nadir_photos": f["nadir_photos"]}


def summary_json(s: Summary) -> dict[str, Any]:
    """The summary as the web page's JSON (its keys are the page's)."""
    return {
        "area_ha": s.area_ha, "crs": s.crs, "camera": s.camera, "height_agl_m": s.height_agl_m,
        "height_range_m": list(s.height_range_m), "gsd_cm": list(s.gsd_cm), "heading_deg": s.heading_deg,
        "lines": s.lines, "runs": s.runs, "photos": s.photos, "spacing_m": s.spacing_m, "photo_base_m": s.photo_base_m,
        "speed_ms": s.speed_ms, "speed_limited_by": s.speed_limited_by, "distance_km": s.distance_km,
        "time_min": s.time_min, "sorties": len(s.sorties), "mission_items": s.mission_items,
        "faces": _faces_json(s.faces),
        "rules": {"evaluated": s.rules.evaluated, "passed": s.rules.passed, "failing": list(s.rules.failing),
                  "text": s.rules.text()},
    }
